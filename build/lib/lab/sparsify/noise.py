"""Monte Carlo noise of light-traced PSFs: detect it, and keep it out of the spreadlet importance.

Not in LSR18, but needed for its idea to work on traced PSFs. A traced PSF is a histogram of N
equal-weight rays (``count / N``): per-pixel variance ``q f`` with the quantum ``q = 1/N``. The
5-point Laplacian multiplies that noise by sqrt(20): with 2^24 rays on a 250 px disc the Laplacian
noise (about 0.5 of the disc's level per pixel) exceeds the rim's own Laplacian, and dart
throwing would spend its points on noise all over the interior.

So for a histogram PSF we
1. blur it just enough, pixel by pixel: each pixel's rays are spread by the smallest Gaussian
   (sigma from a fixed ladder) that brings the Laplacian noise of a flat region at the PSF's
   *local* level below ``TAU`` of that level (the units of :mod:`.laplacian`'s importance; the rim
   of a disc pre-filtered over w px stands at about 1/w of the level). The local level at scale
   sigma is :func:`~lab.sparsify.laplacian.local_level` of the blurred PSF with the reach
   ``2 sigma + LEVEL_REACH``: a disc's rim counts at its plateau's level and the whole disc gets
   the one sigma a global rule would give it, while a faint halo of 10 rays per pixel beside a
   sharp core of 10^6 rays gets a wide filter. The rays are spread from where they landed (a
   sample-point kernel estimate), so no blur leaks from the core into the halo. The blur is kept
   inside the image less its 2 px border and divided by the share of its kernel there
   (normalised convolution), so a halo that the image edge cuts keeps its height up to that edge
   instead of growing a shoulder; the sum is restored at the end. A pixel holding significantly
   more light than its 8 neighbours together is a point (the unscattered core): its rays stay
   where they landed, as no blur can resolve it and blurring would only smear it;
2. soft-threshold the importance at ``K_SIGMA`` standard deviations of the propagated Laplacian
   noise, ``var(L(g * f)) = q ((L g)^2 * f)`` summed over the pixels of each sigma, so pure
   noise pixels get (almost) zero importance; and
3. measure what lies below that floor at coarser scales (:func:`coarse_laplacian`): the Laplacian
   of a smooth halo is 10^-3 .. 10^-4 of its per-pixel noise, but averaged over a few to 16 px it
   often stands out, and it then decides where the halo's spreadlets go.

The ray count comes from the tracer (``sparsify(..., rays=N)``), never guessed from values.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.signal

from runtime_cl.integrate.poisson import laplacian5

from .laplacian import LEVEL_REACH, local_level

__all__ = ["Denoised", "denoise", "coarse_laplacian", "TAU", "K_SIGMA", "SIGMA_LADDER",
           "COARSE_SCALES"]

TAU = 0.01
K_SIGMA = 3.0
SIGMA_LADDER = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0)
# px: averaging scales of the below-floor Laplacian, up to about a tenth of a 255 px PSF image
COARSE_SCALES = (1.0, 2.0, 4.0, 8.0, 16.0)
# px: the below-floor fringe of a rim or core, whose Laplacian belongs to it (collapsed with it)
FRINGE = 2


def _kernels(sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """1D normalised Gaussian g1 (g = g1 g1^T) and the 5-point Laplacian of g, both odd-sized."""
    if sigma == 0:
        g1 = np.ones(1)
    else:
        x = np.arange(-int(np.ceil(4 * sigma)), int(np.ceil(4 * sigma)) + 1)
        g1 = np.exp(-x * x / (2 * sigma * sigma))
        g1 /= g1.sum()
    return g1, laplacian5(np.pad(np.outer(g1, g1), 1))


def _blur(f: np.ndarray, g1: np.ndarray) -> np.ndarray:
    """Separable convolution of (R, R, C) ``f`` with ``g1 g1^T``, zero outside the image."""
    for axis in (0, 1):
        f = scipy.ndimage.convolve1d(f, g1, axis=axis, mode="constant")
    return f


def _around(mask: np.ndarray, margin: int) -> tuple[slice, slice]:
    """Rows and columns of the bounding box of ``mask`` (R, R) plus ``margin`` px, in the image."""
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return slice(0, 0), slice(0, 0)
    return (slice(max(int(ys.min()) - margin, 0), int(ys.max()) + margin + 1),
            slice(max(int(xs.min()) - margin, 0), int(xs.max()) + margin + 1))


def _point_sources(f: np.ndarray, quantum: np.ndarray) -> np.ndarray:
    """(R, R) bool: pixels holding more light than their 8 neighbours together, by ``K_SIGMA``
    standard deviations of that difference in every channel with light there.

    Such a pixel is a point (an unscattered core, a sharp focus) smaller than the pixel: blurring
    can only smear it, and its rays are not noise around a smoother signal. A plateau or a rim
    never qualifies, nor does a lone ray in a faint region (1 count against 0 is 1 sd).
    """
    around = _blur(f, np.ones(3)) - f
    sd = np.sqrt(quantum * (f + around))
    return ((f - around > K_SIGMA * sd) | (f == 0)).all(axis=2) & (f > 0).any(axis=2)


def _noise_var(f: np.ndarray, k: np.ndarray, quantum: np.ndarray) -> np.ndarray:
    """``q (k^2 * f)`` per channel: the variance of ``k * f`` for a histogram ``f``."""
    return np.stack([scipy.signal.fftconvolve(f[..., c], k * k, "same")
                     for c in range(f.shape[2])], axis=2) * quantum


@dataclass(frozen=True)
class Denoised:
    """Result of :func:`denoise`: the PSF to sparsify and the noise of its Laplacian."""

    psf: np.ndarray      # (R, R, C) float64, blurred, zero within 2 px of the border, unit sums
    lap_sd: np.ndarray   # (R, R, C) float64, standard deviation of the Laplacian's noise
    sigma: float         # largest blur applied to a pixel holding rays, px (0 = none)
    sigma_map: np.ndarray  # (R, R) float64, the blur each pixel's rays got, px (0: none, a point)

    @property
    def reach(self) -> np.ndarray:
        """(R, R) int: the :func:`~lab.sparsify.laplacian.local_level` reach of the blurred PSF,
        ``LEVEL_REACH`` px plus twice the largest blur within ``LEVEL_REACH`` px."""
        size = 2 * LEVEL_REACH + 1
        near = scipy.ndimage.maximum_filter(self.sigma_map, size=size, mode="constant")
        return LEVEL_REACH + np.ceil(2 * near).astype(np.int64)


def denoise(psf: np.ndarray, quantum: np.ndarray, tau: float | None = None) -> Denoised:
    """Spread each pixel's rays just enough and estimate the Laplacian's noise.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        Histogram PSF (counts / rays), each channel summing to 1.
    quantum : ndarray, (C,)
        ``1 / rays`` per channel: the tracer's ray count.
    tau : float, optional
        Largest accepted Laplacian noise in a flat region, relative to the PSF's local level
        (default: the module's ``TAU``).

    Returns
    -------
    Denoised
    """
    tau = TAU if tau is None else tau
    full = np.asarray(psf, np.float64)
    quantum = np.asarray(quantum, np.float64)
    level = (full * full).sum(axis=(0, 1)) / full.sum(axis=(0, 1))
    # work around the light only: kernels reach 4 sigma, the window's blur twice that
    crop = _around((full > 0).any(axis=2), 8 * int(math.ceil(SIGMA_LADDER[-1])))
    f = full[crop]
    window = np.zeros(full.shape[:2] + (1,))  # where a PSF may hold light: 2 px from the border
    window[2:-2, 2:-2] = 1.0
    window = window[crop]
    left = (f > 0).any(axis=2) & ~_point_sources(f, quantum)  # pixels whose rays are to spread
    out, var = f * ~left[..., None], np.zeros_like(f)   # point sources stay where they landed
    var += _noise_var(out, _kernels(0.0)[1], quantum)
    sigma_map = np.zeros(f.shape[:2])
    used = 0.0
    for i, sigma in enumerate(SIGMA_LADDER):
        g1, k = _kernels(sigma)
        height = local_level(_blur(f, g1), int(math.ceil(2 * sigma)) + LEVEL_REACH, level)
        with np.errstate(divide="ignore"):
            noise = np.sqrt(quantum / height) * np.sqrt((k * k).sum())
        take = left & ((noise <= tau) | (f == 0)).all(axis=2)
        if i == len(SIGMA_LADDER) - 1:
            take = left
        if take.any():
            part = f * take[..., None]
            inside = _blur(window, g1)  # the kernel's share in the window (normalised convolution)
            out += np.where(window > 0, _blur(part, g1) / np.maximum(inside, 1e-12), 0.0)
            var += _noise_var(part, k, quantum)
            sigma_map[take] = sigma
            used = sigma
            left &= ~take
        if not left.any():
            break
    out /= out.sum(axis=(0, 1))
    psf_out, sd, smap = np.zeros_like(full), np.zeros_like(full), np.zeros(full.shape[:2])
    psf_out[crop], sd[crop], smap[crop] = out, np.sqrt(np.maximum(var, 0.0)), sigma_map
    return Denoised(psf_out, sd, float(used), smap)


def coarse_laplacian(lap: np.ndarray, floor: np.ndarray, psf: np.ndarray,
                     quantum: np.ndarray) -> np.ndarray:
    """Magnitude of the below-floor Laplacian at the smallest scale where it exceeds its noise.

    The Laplacian of the pixels below ``floor`` is averaged by Gaussians of ``COARSE_SCALES``; at
    each pixel the first average above ``K_SIGMA`` standard deviations of its noise counts (soft
    threshold, as the floor). A rim, core or hard edge already represented at the fine scale (an
    above-floor region holding a 2x2 block; scattered pixels where noise alone crosses the floor
    do not count) must not leak into its surroundings: its pixels and its ``FRINGE`` are left out
    of the averages, and the average at scale s is only used farther than ``FRINGE + 2 s`` from
    it. The noise is bounded by that of the raw histogram's Laplacian-of-Gaussian,
    ``q ((L g_s)^2 * f)``, over the pixels whose rays reach the averaged Laplacian.

    Parameters
    ----------
    lap : ndarray, (R, R, C)
        Laplacian of the denoised PSF.
    floor : ndarray, (R, R, C)
        Its noise floor (``K_SIGMA`` standard deviations).
    psf : ndarray, (R, R, C)
        The histogram PSF before denoising.
    quantum : ndarray, (C,)
        ``1 / rays`` per channel.

    Returns
    -------
    ndarray, (R, R, C) float64
        Zero above the floor and where no scale rises out of the noise.
    """
    out = np.zeros(np.shape(lap))
    crop = _around((np.asarray(lap) != 0).any(axis=2), 2)   # every result is read on the support
    lap, floor, psf = np.asarray(lap)[crop], np.asarray(floor)[crop], np.asarray(psf)[crop]
    is_below = np.abs(lap) <= floor
    # structure: above-floor regions holding a 2x2 block (rims, cores, hard edges), not the
    # scattered pixels where noise alone crosses the floor
    block = np.ones((2, 2, 1), bool)
    structure = scipy.ndimage.binary_opening(~is_below, block)
    dist = np.stack([scipy.ndimage.distance_transform_edt(~structure[..., c])
                     if structure[..., c].any() else np.full(lap.shape[:2], np.inf)
                     for c in range(lap.shape[2])], axis=2)
    below = np.where(is_below & (dist > FRINGE), lap, 0.0)
    cross = scipy.ndimage.generate_binary_structure(2, 1)[..., None]
    source = np.where(scipy.ndimage.binary_dilation(below != 0, cross), psf, 0.0)
    mags = np.zeros_like(below)
    for s in COARSE_SCALES:
        g1, k = _kernels(s)
        noise = np.sqrt(np.maximum(_noise_var(source, k, quantum), 0.0))
        mag = np.abs(_blur(below, g1)) - K_SIGMA * noise
        new = (mags == 0) & (mag > 0) & (below != 0) & (dist > FRINGE + 2 * s)
        mags[new] = mag[new]
    out[crop] = mags
    return out
