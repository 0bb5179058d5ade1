"""Monte Carlo noise of light-traced PSFs: detect it, and keep it out of the spreadlet importance.

Not in LSR18, but needed for its idea to work on traced PSFs. A traced PSF is a histogram of N
equal-weight rays (``count / N``): per-pixel variance ``q f`` with the quantum ``q = 1/N``. The
5-point Laplacian multiplies that noise by sqrt(20): with 2^24 rays on a 250 px disc the Laplacian
noise (about 0.5 of the disc's level per pixel) exceeds the rim's own Laplacian, and dart
throwing would spend its points on noise all over the interior.

So for a histogram PSF we
1. blur it by the smallest Gaussian (sigma from a fixed ladder) that brings the Laplacian noise
   of a flat region below ``TAU`` of the PSF's level (the units of :mod:`.laplacian`'s importance;
   the rim of a disc pre-filtered over w px stands at about 1/w of the level), and
2. soft-threshold the importance at ``K_SIGMA`` standard deviations of the propagated Laplacian
   noise, ``var(L(g * f)) = q ((L g)^2 * f)``, so pure noise pixels get (almost) zero importance.

The ray count comes from the tracer (``sparsify(..., rays=N)``), never guessed from values.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.signal

from runtime_cl.integrate import laplacian5

__all__ = ["Denoised", "denoise", "TAU", "K_SIGMA", "SIGMA_LADDER"]

TAU = 0.01
K_SIGMA = 3.0
SIGMA_LADDER = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0)


def _kernels(sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """1D normalised Gaussian g1 (g = g1 g1^T) and the 5-point Laplacian of g, both odd-sized."""
    if sigma == 0:
        g1 = np.ones(1)
    else:
        x = np.arange(-int(np.ceil(4 * sigma)), int(np.ceil(4 * sigma)) + 1)
        g1 = np.exp(-x * x / (2 * sigma * sigma))
        g1 /= g1.sum()
    return g1, laplacian5(np.pad(np.outer(g1, g1), 1))


@dataclass(frozen=True)
class Denoised:
    """Result of :func:`denoise`: the PSF to sparsify and the noise of its Laplacian."""

    psf: np.ndarray      # (R, R, C) float64, blurred, zero within 2 px of the border, unit sums
    lap_sd: np.ndarray   # (R, R, C) float64, standard deviation of the Laplacian's noise
    sigma: float         # blur in px (0 = none)


def denoise(psf: np.ndarray, quantum: np.ndarray, tau: float | None = None) -> Denoised:
    """Blur a ray-histogram PSF just enough and estimate its Laplacian's noise.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        Histogram PSF (counts / rays), each channel summing to 1.
    quantum : ndarray, (C,)
        ``1 / rays`` per channel: the tracer's ray count.
    tau : float, optional
        Largest accepted Laplacian noise in a flat region, relative to the PSF's level
        (default: the module's ``TAU``).

    Returns
    -------
    Denoised
    """
    tau = TAU if tau is None else tau
    f = np.asarray(psf, np.float64)
    level = (f * f).sum(axis=(0, 1)) / f.sum(axis=(0, 1))
    rel = float(np.max(np.sqrt(quantum / level)))  # relative per-pixel noise at the level
    for sigma in SIGMA_LADDER:
        g1, k = _kernels(sigma)
        if rel * np.sqrt((k * k).sum()) <= tau:
            break
    if sigma > 0:
        for axis in (0, 1):
            f = scipy.ndimage.convolve1d(f, g1, axis=axis, mode="constant")
        f[:2], f[-2:], f[:, :2], f[:, -2:] = 0, 0, 0, 0
        f /= f.sum(axis=(0, 1))
    var = np.stack([scipy.signal.fftconvolve(psf[..., c].astype(np.float64), k * k, "same")
                    for c in range(f.shape[2])], axis=2)
    sd = np.sqrt(np.maximum(var, 0.0) * quantum)
    return Denoised(f, sd, float(sigma))
