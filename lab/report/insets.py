"""Zoomed insets of the hardest regions of a scene, picked from the methods' error maps.

The error of every method (:func:`lab.report.metrics.error_map`) is averaged, so a region is
hard when the methods miss the reference there together (the bokeh of a light, an occlusion
edge); its mean over every square window of ``size`` px is the smoothed error, and the windows are
taken greedily, largest first, each overlapping none taken before. Each region is shown as
reference and method crops side by side at nearest-neighbour zoom (the pixels as they are, the
reference's Monte Carlo speckle included), and as a box on the reference.
"""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from .images import save_png, to_uint8
from .metrics import tonemap

__all__ = ["hardest_windows", "window_size", "write_insets"]

INSET_PX = 200     # a crop is zoomed to about this many pixels across
OVERVIEW_PX = 512  # the reference with the boxes, at least this wide


def window_size(shape) -> int:
    """The inset window edge for an image of ``shape``: an eighth of its short side, at least 12 px
    (enough context around an edge or a bokeh rim at 64 px)."""
    return int(max(12, min(shape[0], shape[1]) // 8))


def hardest_windows(error: np.ndarray, size: int, k: int = 3) -> list[tuple[int, int, float]]:
    """The ``k`` non-overlapping ``size`` x ``size`` windows of largest mean ``error`` (H, W).

    Returns ``(row, col, mean error)`` of each window's top-left corner, hardest first; fewer
    than ``k`` when no more fit without overlap. Ties go to the first in row-major order.
    """
    e = np.asarray(error, dtype=np.float64)
    h, w = e.shape
    size = int(min(size, h, w))
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = e.cumsum(0).cumsum(1)
    means = (s[size:, size:] - s[:-size, size:] - s[size:, :-size] + s[:-size, :-size]) / size**2
    free = np.ones(means.shape, bool)
    out = []
    while len(out) < k and free.any():
        flat = np.where(free, means, -np.inf)
        r, c = np.unravel_index(int(np.argmax(flat)), flat.shape)
        out.append((int(r), int(c), float(means[r, c])))
        # windows whose top-left lies within size-1 of this one's would overlap it
        free[max(0, r - size + 1):r + size, max(0, c - size + 1):c + size] = False
    return out


def _zoomed(rgb8: np.ndarray, factor: int) -> Image.Image:
    img = Image.fromarray(rgb8)
    return img.resize((img.width * factor, img.height * factor), Image.NEAREST)


def write_insets(reference: np.ndarray, methods: dict, out_dir, k: int = 3) -> dict:
    """Crops of the ``k`` hardest windows for the reference and every method (name -> linear RGB),
    written as PNGs into ``out_dir``; returns what the report records of them."""
    from .metrics import error_map

    error = np.mean([error_map(rgb, reference) for rgb in methods.values()], axis=0)
    size = window_size(reference.shape)
    windows = hardest_windows(error, size, k)
    zoom = max(1, INSET_PX // size)
    images = {"reference": to_uint8(tonemap(reference))}
    images.update({name: to_uint8(tonemap(rgb)) for name, rgb in methods.items()})
    regions = []
    for i, (r, c, mean) in enumerate(windows):
        crops = {}
        for name, rgb8 in images.items():
            file = f"inset{i + 1}_{name.replace(':', '_')}.png"
            save_png(_zoomed(rgb8[r:r + size, c:c + size], zoom), out_dir / file)
            crops[name] = file
        errors = {name: float(error_map(rgb[r:r + size, c:c + size], reference[r:r + size, c:c + size]).mean())
                  for name, rgb in methods.items()}
        regions.append({"row": r, "col": c, "size": size, "mean_error": mean, "zoom": zoom,
                        "crops": crops, "method_errors": errors})
    up = max(1, -(-OVERVIEW_PX // reference.shape[1]))
    overview = _zoomed(images["reference"], up)
    draw = ImageDraw.Draw(overview)
    font = ImageFont.load_default(size=max(14, 4 * up))
    for i, reg in enumerate(regions):
        box = [reg["col"] * up, reg["row"] * up, (reg["col"] + size) * up - 1, (reg["row"] + size) * up - 1]
        draw.rectangle(box, outline=(255, 64, 255), width=max(2, up // 2))
        draw.text((box[0] + 4, box[1] + 2), str(i + 1), fill=(255, 64, 255), font=font,
                  stroke_width=2, stroke_fill=(0, 0, 0))
    save_png(overview, out_dir / "insets_overview.png")
    return {"about": f"the {len(regions)} non-overlapping {size}x{size} px windows of largest mean error, "
                     "averaged over the methods; crops at nearest-neighbour zoom",
            "overview": "insets_overview.png", "regions": regions}
