"""Depth and circle-of-confusion ranges of a labelled-pixel input, for sizing the PSF database.

The signed CoC r(z) = s (1/F - 1/z) grows monotonically with z, so its extremes over an image
are at the nearest and farthest depths. Background at infinity counts (it is splatted too).
No Mitsuba here: this only reads Z.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime_cl.camera import from_header

from ..errors import UserError
from ..exr_io import LabelledImage


@dataclass(frozen=True)
class CocRange:
    """Depth range (metres) and signed CoC range (pixels) of one image; negative = foreground."""

    z_min_m: float
    z_max_m: float
    coc_min_px: float
    coc_max_px: float

    @property
    def max_abs_px(self) -> float:
        """The largest |CoC| radius in pixels anywhere in the image."""
        return max(abs(self.coc_min_px), abs(self.coc_max_px))


def depth_range(image) -> tuple[float, float]:
    """Nearest and farthest depth of an image.

    Parameters
    ----------
    image : LabelledImage or ndarray
        A labelled-pixel image, or its Z array (metres, > 0, inf allowed).

    Returns
    -------
    (z_min, z_max) : tuple of float
        Metres; ``z_max`` is ``inf`` when background at infinity is visible.
    """
    z = image.depth if isinstance(image, LabelledImage) else np.asarray(image)
    if z.size == 0:
        raise UserError("depth_range: the image has no pixels")
    bad = ~(z > 0)
    if np.any(bad):
        raise UserError(f"depth_range: {int(bad.sum())} pixel(s) with NaN or non-positive Z")
    return float(z.min()), float(z.max())


def coc_range(image: LabelledImage, lens=None) -> CocRange:
    """Signed CoC range in pixels over ``image``: what the PSF database must cover.

    Parameters
    ----------
    image : LabelledImage
        Its Z and width (pixels) are used.
    lens : runtime camera, optional
        A :mod:`runtime_cl.camera` camera, e.g. ``ThinLens``; default: the image's
        ``splatlab.camera``. A pinhole camera has no defocus: [0, 0].

    Returns
    -------
    CocRange
        ``max_abs_px`` is the largest |CoC| radius anywhere in the image.
    """
    z_min, z_max = depth_range(image)
    lens = lens or from_header(image.camera, "camera header")
    if getattr(lens, "has_focal_map", False):   # the focus differs per pixel: the extremes of the map
        r = lens.coc_radius_px(np.asarray(image.depth, np.float64), image.width)
        return CocRange(z_min, z_max, float(r.min()), float(r.max()))
    r = lens.coc_radius_px(np.array([z_min, z_max]), image.width)
    return CocRange(z_min, z_max, float(r[0]), float(r[1]))
