"""PNG output for reports: tonemapped renders, error maps, PSF and spreadlet views."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from runtime_cl.atomic_file import atomic_path

from .metrics import tonemap


def to_uint8(values: np.ndarray) -> np.ndarray:
    """Display values in [0, 1] (clipped) as 8-bit image data, rounded to nearest."""
    return np.round(np.clip(values, 0.0, 1.0) * 255).astype(np.uint8)


def save_png(img: Image.Image, path) -> None:
    """Write ``img`` as a PNG atomically, creating the folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        img.save(tmp, format="PNG")


def save_render(linear: np.ndarray, path) -> None:
    """Tonemapped 8-bit PNG of a linear RGB image (H, W, 3)."""
    save_png(Image.fromarray(to_uint8(tonemap(linear))), path)


def save_heatmap(values: np.ndarray, path, vmax: float | None = None, cmap: str = "magma") -> None:
    """A (H, W) map through a matplotlib colormap, scaled to [0, vmax] (default: its maximum)."""
    from matplotlib import colormaps

    v = np.asarray(values, dtype=np.float64)
    top = vmax if vmax is not None else (float(v.max()) if v.size and v.max() > 0 else 1.0)
    rgba = colormaps[cmap](np.clip(v / top, 0.0, 1.0))
    save_png(Image.fromarray(to_uint8(rgba[..., :3])), path)
