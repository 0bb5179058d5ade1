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

Detection (:func:`detect_quantum`): every channel is an integer multiple of one quantum, with at
least ``MIN_COUNT`` rays in the fullest pixel and ``MIN_LEVELS`` distinct values (a hard-edged disc
or a delta has one or two levels and is not taken for a 1-ray-per-pixel histogram).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.signal

from runtime_cl.integrate import laplacian5

__all__ = ["detect_quantum", "Denoised", "denoise", "TAU", "K_SIGMA", "SIGMA_LADDER"]

TAU = 0.01
K_SIGMA = 3.0
SIGMA_LADDER = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0)
MIN_COUNT = 4
MIN_LEVELS = 4


def _ray_count(v: np.ndarray) -> float | None:
    """Total ray count N if the positive values ``v`` are all ``count / N``, else None."""
    u = np.unique(v)
    gaps = np.diff(u)
    if u.size < MIN_LEVELS:
        return None
    # neighbouring counts differ by one ray: the small gaps are 1/N, to float32 rounding
    first = 1.0 / float(np.median(gaps[gaps < 1.5 * gaps.min()]))
    # pin N down exactly: the smallest value is an integer count j / N, j near its estimate
    k0 = float(u[0]) * first
    spread = max(2.0, 0.01 * k0)
    for j in range(max(1, int(k0 - spread)), int(np.ceil(k0 + spread)) + 1):
        rays = j / float(u[0])
        rays = float(np.rint(np.rint(v * rays).sum() / v.sum()))
        k = v * rays
        if (MIN_COUNT <= k.max() <= 2 ** 22
                and np.abs(k - np.rint(k)).max() <= 0.01 + 1e-7 * k.max()):
            return rays
    return None


def detect_quantum(psf: np.ndarray) -> np.ndarray | None:
    """Per-channel ray quantum ``q_c = 1 / N_c`` if ``psf`` (R, R, C) is a ray histogram, else None.

    The gaps between distinct values give a first estimate of ``1/N``; the exact ``N`` is the one
    near it for which the smallest value, and then every value, is an integer count to float32
    precision (counts up to 2^22, where float32 still separates them).
    """
    quanta = []
    for c in range(psf.shape[2]):
        v = np.asarray(psf[..., c], np.float64)
        rays = _ray_count(v[v > 0])
        if rays is None:
            return None
        quanta.append(1.0 / rays)
    return np.array(quanta)


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
        ``1 / rays`` per channel, from :func:`detect_quantum`.
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
