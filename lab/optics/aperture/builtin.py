"""Built-in aperture images: ``star`` (a pentagram, tip up) and ``heart`` (point down).

Rasterised once at 512 x 512 with 4 x 4 supersampled coverage (anti-aliased edges), then sampled
like any :class:`~lab.optics.aperture.image.ImageAperture`. The outlines are the runtime's
(:mod:`runtime_cl.polygon.shapes`, MHU21 polygon kernels), read here with y up: the same heart,
and the same pentagram except that here it is centred on its centre of symmetry (there on its
bounding box, 0.095 circumradii off), which is where a star-shaped stop sits on the optical axis.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from lab.optics.aperture.base import register_aperture
from lab.optics.aperture.image import ImageAperture
from runtime_cl.polygon.shapes import pentagram, shape

__all__ = ["StarAperture", "HeartAperture", "BUILTIN_RESOLUTION", "star_raster", "heart_raster",
           "polygon_mask"]

BUILTIN_RESOLUTION = 512  # finer than the edge of any PSF the lab traces
_SUPERSAMPLE = 4          # per axis


def _coverage(mask: np.ndarray, resolution: int) -> np.ndarray:
    return mask.reshape(resolution, _SUPERSAMPLE, resolution, _SUPERSAMPLE).mean(axis=(1, 3))


def polygon_mask(v: np.ndarray, n: int) -> np.ndarray:
    """Even-odd fill of the closed polygon ``v`` (k, 2), y up, at the n x n pixel centres of
    [-1, 1]^2 (row 0 at the top): one scanline per row, crossings sorted, parity by bisection."""
    t = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x0, y0 = v[:, 0], v[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    mask = np.zeros((n, n), bool)
    for row, yc in enumerate(-t):
        cross = (y0 <= yc) != (y1 <= yc)  # half-open in y: a vertex on the line counts once
        xs = np.sort(x0[cross] + (yc - y0[cross]) * (x1[cross] - x0[cross]) / (y1[cross] - y0[cross]))
        mask[row] = np.searchsorted(xs, t) % 2 == 1
    return mask


@lru_cache(maxsize=None)
def star_raster(resolution: int = BUILTIN_RESOLUTION) -> np.ndarray:
    """Coverage of the pentagram (:func:`runtime_cl.polygon.shapes.pentagram`), its tip at +y
    (up), over [-1, 1]^2 (row 0 at the top), read-only."""
    w = _coverage(polygon_mask(pentagram(), resolution * _SUPERSAMPLE), resolution)
    w.setflags(write=False)
    return w


@lru_cache(maxsize=None)
def heart_raster(resolution: int = BUILTIN_RESOLUTION, vertices: int = 400) -> np.ndarray:
    """Coverage of the heart (:func:`runtime_cl.polygon.shapes.shape`), flipped to y up (its
    point down), over [-1, 1]^2; read-only."""
    v = shape("heart", vertices) * np.array([1.0, -1.0])
    w = _coverage(polygon_mask(v, resolution * _SUPERSAMPLE), resolution)
    w.setflags(write=False)
    return w


@register_aperture("star")
@dataclass(frozen=True, eq=False)
class StarAperture(ImageAperture):
    """A pentagram, one tip up (inner corners at 0.382 of the tip radius)."""

    @property
    def weights(self) -> np.ndarray:
        return star_raster()

    @property
    def turn_period_deg(self) -> float:
        return 72.0


@register_aperture("heart")
@dataclass(frozen=True, eq=False)
class HeartAperture(ImageAperture):
    """A heart, point down."""

    @property
    def weights(self) -> np.ndarray:
        return heart_raster()
