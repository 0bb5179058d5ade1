"""Analytic SimpleLens PSFs in numpy: the uniform disc integrated exactly over pixel areas, and
its pre-filtered average over a range of radii. The references the light tracer is tested against.

Pixels follow the tracer: the pixel at offset (i, j) from the centre (R//2, R//2) covers
[j - 1/2, j + 1/2) x [i - 1/2, i + 1/2). A disc's share of a pixel is its exact area of overlap
(circle-segment integrals) over the disc area; the pre-filtered PSF averages that over radii drawn
uniformly from [lo, hi] with the midpoint rule in r.
"""
from __future__ import annotations

import math

import numpy as np

from lab.errors import UserError

__all__ = ["disc_area_in_rect", "disc_psf", "prefiltered_disc_psf"]


def _quadrant_area(x, y, r):
    """Area of {0 <= u <= x, 0 <= v <= y, u^2 + v^2 <= r^2} for x, y >= 0."""
    xm = np.minimum(x, r)
    u0 = np.minimum(np.sqrt(np.maximum(r * r - y * y, 0.0)), xm)  # where the arc drops below y

    def arc(u):  # integral of sqrt(r^2 - t^2) from 0 to u (u <= r)
        return 0.5 * (u * np.sqrt(np.maximum(r * r - u * u, 0.0)) + r * r * np.arcsin(np.clip(u / r, -1, 1)))

    return u0 * y + arc(xm) - arc(u0)


def _corner_area(x, y, r):
    """Signed area of the disc in the rectangle between the origin and (x, y)."""
    return np.sign(x) * np.sign(y) * _quadrant_area(np.abs(x), np.abs(y), r)


def disc_area_in_rect(r: float, x0, x1, y0, y1) -> np.ndarray:
    """Exact area of the disc of radius ``r`` (centred at the origin) inside [x0, x1] x [y0, y1]."""
    return (_corner_area(x1, y1, r) - _corner_area(x0, y1, r)
            - _corner_area(x1, y0, r) + _corner_area(x0, y0, r))


def _check(resolution, radius):
    if not (isinstance(resolution, int) and resolution >= 1):
        raise UserError(f"resolution = {resolution!r}: must be an integer >= 1")
    if not (math.isfinite(radius) and radius >= 0):
        raise UserError(f"disc radius = {radius!r}: must be a finite number >= 0")
    if math.ceil(radius + 0.5) > resolution // 2 - (1 - resolution % 2):
        raise UserError(f"a disc of radius {radius} px does not fit a {resolution}^2 image centred at "
                        f"{resolution // 2}; use resolution >= {2 * math.ceil(radius + 0.5) + 1}")


def disc_psf(radius: float, resolution: int) -> np.ndarray:
    """The uniform disc of ``radius`` pixels, as fractions of its area per pixel, (R, R) float64.

    Radii <= 1/2 lie inside the centre pixel: an exact delta.
    """
    _check(resolution, radius)
    out = np.zeros((resolution, resolution))
    c = resolution // 2
    if radius <= 0.5:
        out[c, c] = 1.0
        return out
    k = math.ceil(radius + 0.5)  # pixel offsets -k..k touch the disc
    edges = np.arange(-k, k + 2) - 0.5
    lo, hi = edges[:-1], edges[1:]
    area = disc_area_in_rect(radius, lo[None, :], hi[None, :], lo[:, None], hi[:, None])
    # Pixels beyond the disc are exactly empty; elsewhere clip the ~1e-17 cancellation residue.
    near = np.maximum(np.abs(np.arange(-k, k + 1)) - 0.5, 0.0)
    area = np.where(near[None, :] ** 2 + near[:, None] ** 2 < radius * radius, np.maximum(area, 0.0), 0.0)
    out[c - k:c + k + 1, c - k:c + k + 1] = area / (math.pi * radius * radius)
    return out


def prefiltered_disc_psf(lo: float, hi: float, resolution: int, nodes: int = 256) -> np.ndarray:
    """The disc PSF averaged over radii uniform in [lo, hi] pixels, (R, R) float64, sums to 1.

    Parameters
    ----------
    lo, hi : float
        Radius range in pixels, 0 <= lo <= hi.
    resolution : int
        R, the image edge in pixels; must hold the disc of radius ``hi``.
    nodes : int, default 256
        Midpoint-rule nodes in r (the integrand is continuous in r; error falls ~ nodes^-2).
    """
    if not (0 <= lo <= hi):
        raise UserError(f"radius range [{lo}, {hi}]: needs 0 <= lo <= hi")
    if hi == lo:
        return disc_psf(lo, resolution)
    _check(resolution, hi)
    radii = lo + (hi - lo) * (np.arange(nodes) + 0.5) / nodes
    return sum(disc_psf(float(r), resolution) for r in radii) / nodes
