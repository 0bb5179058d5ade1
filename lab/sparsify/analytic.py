"""Analytic PSFs in numpy for tests and benchmarks of the sparsifier.

Every PSF is an (R, R, C) float32 image centred at pixel (R//2, R//2), non-negative, each channel
summing to 1 and zero on a border of at least two pixels (the contract of
:func:`lab.sparsify.sparsify`). "Pre-filtered" follows LSR18 section 5.4: the average of the
PSFs over a small box of the PSF parameter, here the radius in ``[r - width/2, r + width/2]``, which
turns the hard rim into a ramp about ``width`` pixels wide.

Discs and capsules are the points within a radius of a segment (of length 0 for a disc), each
pixel in or out by its centre: the staircase rims the sparsifier's tests are tuned on. The
exact-area disc the tracer converges to, and the supersampled one of the runtime's synthetic
databases, are :func:`runtime_cl.psf.disc.disc_psf`.
"""
from __future__ import annotations

import math

import numpy as np

from lab.errors import UserError

__all__ = ["prefiltered_disc", "prefiltered_capsule", "gaussian", "delta", "rgb_discs"]

_MARGIN = 2  # empty pixels kept on every side, as the tracer does


def _grid(resolution: int, extent: float, name: str):
    if not isinstance(resolution, (int, np.integer)) or resolution < 8:
        raise UserError(f"{name}: resolution = {resolution!r} must be an integer >= 8")
    need = 2 * (math.ceil(extent) + _MARGIN) + 1
    if resolution < need:
        raise UserError(f"{name}: resolution = {resolution} cannot hold extent {extent:g} px; "
                        f"use resolution >= {need}")
    c = resolution // 2
    y, x = np.mgrid[0:resolution, 0:resolution].astype(np.float64)
    return y - c, x - c


def _radii(radius: float, width: float, name: str) -> np.ndarray:
    if not (math.isfinite(radius) and radius >= 0):
        raise UserError(f"{name}: radius = {radius!r} must be a finite number >= 0")
    if not (math.isfinite(width) and width >= 0):
        raise UserError(f"{name}: width = {width!r} must be a finite number >= 0")
    lo, hi = max(radius - width / 2, 0.0), radius + width / 2
    # four radii per pixel of ramp, so the ramp has no visible steps
    return np.linspace(lo, hi, max(1, math.ceil(4 * (hi - lo)) + 1))


def _average_of_shapes(dist: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Mean over ``radii`` of the normalised indicator ``dist <= r`` (each a unit-sum shape)."""
    out = np.zeros(dist.shape, np.float64)
    for r in radii:
        inside = dist <= r + 1e-9
        out += inside / inside.sum()
    return out / len(radii)


def _prefiltered_capsule(resolution: int, radius: float, length: float, width: float,
                         name: str) -> np.ndarray:
    if not (math.isfinite(length) and length >= 0):
        raise UserError(f"{name}: length = {length!r} must be a finite number >= 0")
    y, x = _grid(resolution, radius + width / 2 + length / 2, name)
    xs = np.clip(x, -length / 2, length / 2)
    dist = np.hypot(x - xs, y)
    f = _average_of_shapes(dist, _radii(radius, width, name))
    return f[..., None].astype(np.float32)


def prefiltered_disc(resolution: int, radius: float, width: float = 3.0) -> np.ndarray:
    """Disc PSF of ``radius`` px pre-filtered over a radius box ``width`` px wide, (R, R, 1):
    the capsule of length 0 (:func:`prefiltered_capsule`).

    Parameters
    ----------
    resolution : int
        R, the image edge in pixels.
    radius : float
        Centre of the radius box in pixels (0 gives a delta when ``width`` < 2).
    width : float, default 3.0
        Width of the radius box in pixels (0 = a hard disc).
    """
    return _prefiltered_capsule(resolution, radius, 0.0, width, "prefiltered_disc")


def prefiltered_capsule(resolution: int, radius: float, length: float,
                        width: float = 3.0) -> np.ndarray:
    """Motion-blurred disc: points within ``radius`` of a horizontal segment of ``length`` px.

    Parameters
    ----------
    resolution : int
        R, the image edge in pixels.
    radius : float
        Disc radius in pixels, pre-filtered over ``width`` px like :func:`prefiltered_disc`.
    length : float
        Length of the motion segment in pixels, centred on the PSF centre.
    width : float, default 3.0
        Width of the radius box in pixels.
    """
    return _prefiltered_capsule(resolution, radius, length, width, "prefiltered_capsule")


def gaussian(resolution: int, sigma: float, cutoff: float = 4.0) -> np.ndarray:
    """Isotropic Gaussian PSF of standard deviation ``sigma`` px, zero beyond ``cutoff`` sigma."""
    if not (math.isfinite(sigma) and sigma > 0):
        raise UserError(f"gaussian: sigma = {sigma!r} must be a finite number > 0")
    y, x = _grid(resolution, cutoff * sigma, "gaussian")
    d2 = x * x + y * y
    f = np.where(d2 <= (cutoff * sigma) ** 2, np.exp(-d2 / (2 * sigma * sigma)), 0.0)
    return (f / f.sum())[..., None].astype(np.float32)


def delta(resolution: int, channels: int = 1) -> np.ndarray:
    """In-focus PSF: all energy in the centre pixel, (R, R, channels)."""
    _grid(resolution, 0, "delta")
    f = np.zeros((resolution, resolution, channels), np.float32)
    f[resolution // 2, resolution // 2, :] = 1.0
    return f


def rgb_discs(resolution: int, radii: tuple[float, float, float],
              width: float = 3.0) -> np.ndarray:
    """Chromatic disc PSF: one pre-filtered disc per channel with its own radius, (R, R, 3)."""
    if len(radii) != 3:
        raise UserError(f"rgb_discs: radii = {radii!r} must hold three radii (R, G, B)")
    return np.concatenate([prefiltered_disc(resolution, r, width) for r in radii], axis=2)
