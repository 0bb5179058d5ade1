"""PNG output for reports: tonemapped renders, error maps, PSF and spreadlet views."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from runtime_cl.atomic_file import atomic_path

from .metrics import tonemap


def _atomic_save(img: Image.Image, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        img.save(tmp, format="PNG")


def save_render(linear: np.ndarray, path) -> None:
    """Tonemapped 8-bit PNG of a linear RGB image (H, W, 3)."""
    rgb = np.round(tonemap(linear) * 255.0).astype(np.uint8)
    _atomic_save(Image.fromarray(rgb), path)


def save_heatmap(values: np.ndarray, path, vmax: float | None = None, cmap: str = "magma") -> None:
    """A (H, W) map through a matplotlib colormap, scaled to [0, vmax] (default: its maximum)."""
    from matplotlib import colormaps

    v = np.asarray(values, dtype=np.float64)
    top = vmax if vmax is not None else (float(v.max()) if v.size and v.max() > 0 else 1.0)
    rgba = colormaps[cmap](np.clip(v / top, 0.0, 1.0))
    _atomic_save(Image.fromarray(np.round(rgba[..., :3] * 255).astype(np.uint8)), path)
