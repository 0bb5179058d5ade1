"""The uniform disc PSF on pixels: the one definition, with the pixel rule as a parameter.

A disc of radius ``r`` pixels centred on a pixel centre, as the share of its light each pixel
receives (the pixel at offset (i, j) covers [j - 1/2, j + 1/2) x [i - 1/2, i + 1/2)). Two pixel
rules, because two kinds of caller need different ones:

``"area"``
    The exact area of overlap (circle-segment integrals) over the disc's area: what a light
    tracer's histogram converges to, so the lab checks its traced PSFs against it. Hard rim only.
``"supersampled"``
    The mean over a ``supersample`` x ``supersample`` grid of sub-pixel points of the disc's
    indicator, or of a rim that falls off linearly over ``edge`` pixels, normalised to sum 1:
    the synthetic databases of the runtime's self-tests and benchmarks (soft rims included).

Radii up to 1/2 lie inside the centre pixel: an exact delta under either rule.
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["PIXEL_RULES", "disc_psf", "disc_area_in_rect"]

PIXEL_RULES = ("supersampled", "area")


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


def _area(radius: float) -> np.ndarray:
    k = math.ceil(radius + 0.5)  # pixel offsets -k..k touch the disc
    edges = np.arange(-k, k + 2) - 0.5
    lo, hi = edges[:-1], edges[1:]
    area = disc_area_in_rect(radius, lo[None, :], hi[None, :], lo[:, None], hi[:, None])
    # Pixels beyond the disc are exactly empty; elsewhere clip the ~1e-17 cancellation residue.
    near = np.maximum(np.abs(np.arange(-k, k + 1)) - 0.5, 0.0)
    area = np.where(near[None, :] ** 2 + near[:, None] ** 2 < radius * radius, np.maximum(area, 0.0), 0.0)
    return area / (math.pi * radius * radius)


def _supersampled(radius: float, supersample: int, edge: float) -> np.ndarray:
    big = int(np.ceil(radius + edge / 2))
    sub = (np.arange(supersample) + 0.5) / supersample - 0.5
    c = np.arange(-big, big + 1)
    y = (c[:, None] + sub[None, :]).reshape(-1)
    rho = np.sqrt(y[:, None] ** 2 + y[None, :] ** 2)
    inside = np.clip((radius - rho) / edge + 0.5, 0.0, 1.0) if edge > 0 else (rho <= radius).astype(float)
    cover = inside.reshape(2 * big + 1, supersample, 2 * big + 1, supersample).mean(axis=(1, 3))
    return cover / cover.sum()


def _place(crop: np.ndarray, radius: float, resolution: int) -> np.ndarray:
    """``crop`` centred at (R//2, R//2) of an R x R image."""
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise InputError(f"resolution = {resolution!r}: must be an integer >= 1")
    k, c = crop.shape[0] // 2, resolution // 2
    if k > (resolution - 1) // 2:
        raise InputError(f"a disc of radius {radius} px does not fit a {resolution}^2 image centred at "
                         f"{c}; use resolution >= {2 * k + 1}")
    out = np.zeros((resolution, resolution))
    out[c - k:c + k + 1, c - k:c + k + 1] = crop
    return out


def disc_psf(radius: float, resolution: int | None = None, *, pixel: str = "supersampled",
             supersample: int = 4, edge: float = 0.0) -> np.ndarray:
    """The disc of ``radius`` pixels, as each pixel's share of its light, float64.

    Parameters
    ----------
    radius : float
        Disc radius in pixels (>= 0); up to 1/2 gives a delta.
    resolution : int, optional
        R: place the disc at the centre (R//2, R//2) of an R x R image. Default: the crop
        (2k+1) x (2k+1) that holds every pixel the disc touches, k = ceil(radius + 1/2) for
        ``"area"``, ceil(radius + edge / 2) for ``"supersampled"``.
    pixel : {"supersampled", "area"}, default "supersampled"
        The pixel rule (see the module docstring).
    supersample : int, default 4
        ``"supersampled"``: sub-pixel points per axis.
    edge : float, default 0
        ``"supersampled"``: width in pixels of a linear rim centred on ``radius`` (0: hard). Its
        Laplacian is non-zero over the whole ramp, so exact spreadlets number more (r = 80: 1352
        hard, 1884 with edge 1, 2420 with edge 2).

    Returns
    -------
    ndarray, shape (2k+1, 2k+1) or (R, R)
        Sums to 1.

    Raises
    ------
    InputError
        Bad radius, rule, edge or resolution, or a disc that does not fit R (the message gives
        the smallest R).
    """
    if not (math.isfinite(radius) and radius >= 0):
        raise InputError(f"disc radius = {radius!r}: must be a finite number >= 0")
    if pixel not in PIXEL_RULES:
        raise InputError(f"pixel = {pixel!r}: choose one of {PIXEL_RULES}")
    if not (np.isfinite(edge) and edge >= 0):
        raise InputError(f"edge = {edge!r}: must be a finite width in pixels >= 0")
    if edge > 0 and pixel != "supersampled":
        raise InputError(f"edge = {edge!r}: a soft rim needs pixel='supersampled'")
    if radius <= 0.5:  # inside one pixel: a delta
        crop = np.ones((1, 1))
    elif pixel == "area":
        crop = _area(radius)
    else:
        crop = _supersampled(radius, supersample, edge)
    return crop if resolution is None else _place(crop, radius, resolution)
