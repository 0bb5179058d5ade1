"""Built-in aperture images: ``star`` (a pentagram, tip up) and ``heart`` (point down).

Rasterised once at 512 x 512 with 4 x 4 supersampled coverage (anti-aliased edges), then sampled
like any :class:`~lab.optics.aperture.image.ImageAperture`. The outlines are those of
``lab.sparsify.polygon_shapes`` (MHU21 polygon kernels): the same heart, and the same pentagram
except that here it is centred on its centre of symmetry (there on its bounding box, 0.095
circumradii higher), which is where a star-shaped stop sits on the optical axis.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from lab.optics.aperture.base import register_aperture
from lab.optics.aperture.image import ImageAperture

__all__ = ["StarAperture", "HeartAperture", "BUILTIN_RESOLUTION", "star_raster", "heart_raster",
           "polygon_mask"]

BUILTIN_RESOLUTION = 512  # finer than the edge of any PSF the lab traces
_SUPERSAMPLE = 4          # per axis
_PENTAGRAM_INNER = math.sin(math.pi / 10) / math.sin(7 * math.pi / 10)


def _coverage(mask: np.ndarray, resolution: int) -> np.ndarray:
    return mask.reshape(resolution, _SUPERSAMPLE, resolution, _SUPERSAMPLE).mean(axis=(1, 3))


def _star_inside(x, y, points: int = 5, inner: float = _PENTAGRAM_INNER):
    """The star with ``points`` tips on the unit circle (one up) and inner corners at ``inner``."""
    sector = math.pi / points
    a = np.mod(np.arctan2(y, x) - math.pi / 2, 2 * sector)
    b = np.minimum(a, 2 * sector - a)  # 0 at a tip, sector at an inner corner
    r = np.hypot(x, y)
    px, py = r * np.cos(b), r * np.sin(b)
    ex, ey = inner * math.cos(sector) - 1.0, inner * math.sin(sector)  # tip -> inner corner
    return ex * py - ey * (px - 1.0) >= 0.0  # the origin's side of the edge


@lru_cache(maxsize=None)
def star_raster(resolution: int = BUILTIN_RESOLUTION) -> np.ndarray:
    """Coverage of the pentagram over [-1, 1]^2 (y up, row 0 at the top), read-only."""
    n = resolution * _SUPERSAMPLE
    t = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    w = _coverage(_star_inside(t[None, :], -t[:, None]), resolution)
    w.setflags(write=False)
    return w


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
def heart_raster(resolution: int = BUILTIN_RESOLUTION, vertices: int = 400) -> np.ndarray:
    """Coverage of x = 16 sin^3 t, y = 13 cos t - 5 cos 2t - 2 cos 3t - cos 4t (y up), its
    bounding box centred and scaled to circumradius 1, over [-1, 1]^2; read-only."""
    t = 2 * np.pi * np.arange(vertices) / vertices
    v = np.stack([16 * np.sin(t) ** 3, 13 * np.cos(t) - 5 * np.cos(2 * t) - 2 * np.cos(3 * t)
                  - np.cos(4 * t)], axis=1)
    v = v - (v.max(axis=0) + v.min(axis=0)) / 2
    v = v / np.linalg.norm(v, axis=1).max()
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


@register_aperture("heart")
@dataclass(frozen=True, eq=False)
class HeartAperture(ImageAperture):
    """A heart, point down."""

    @property
    def weights(self) -> np.ndarray:
        return heart_raster()
