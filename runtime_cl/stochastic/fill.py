"""Normalised reconstruction with a push-pull fill: the splatted colour divided by the splatted
sample density, and, where too few samples landed to divide by, the same ratio from coarser pixels.

The re-centred samples of a surface lie at random places; the splatted colour ``C`` over the
splatted sample count ``D`` (each sample splatted with its own PSF) is the colour without that
randomness (a normalised convolution). Where ``D`` is small -- a pixel no sample's PSF reaches,
a thin PSF beside a hole -- the ratio is noise or undefined. There the ratio of the 2 x 2 sums of
``C`` and ``D`` one level up the pyramid fills in (push-pull, Gortler et al. 1996), recursively:

    out_k = (C_k + max(m - D_k, 0) up(out_{k+1})) / max(D_k, m)

``m`` the least density trusted. A pixel with ``D >= m`` keeps its own ratio ``C / D``; one with
``D = 0`` takes the coarser estimate; in between the two blend, continuously at ``D = m``. A flat
colour stays flat at every level, so the fill adds no bias there.
"""
from __future__ import annotations

import numpy as np

__all__ = ["normalise"]


def _down(a: np.ndarray) -> np.ndarray:
    """2 x 2 sums (an odd edge row or column is summed alone)."""
    h, w = a.shape[:2]
    a = np.pad(a, ((0, h % 2), (0, w % 2)) + ((0, 0),) * (a.ndim - 2))
    return a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]


def _up(a: np.ndarray, shape: tuple) -> np.ndarray:
    """Bilinear upsampling by 2 (pixel centres aligned), cropped to ``shape``."""
    p = np.pad(a, ((1, 1), (1, 1)) + ((0, 0),) * (a.ndim - 2), mode="edge")
    out = np.empty((2 * a.shape[0], 2 * a.shape[1]) + a.shape[2:], a.dtype)
    for dy in (0, 1):
        for dx in (0, 1):
            # the fine pixel (2i + dy, 2j + dx) lies a quarter pixel from coarse i, j towards its neighbour
            ny, nx = (0, 2)[dy], (0, 2)[dx]
            c, y, x, d = p[1:-1, 1:-1], p[ny:ny + a.shape[0], 1:-1], p[1:-1, nx:nx + a.shape[1]], \
                p[ny:ny + a.shape[0], nx:nx + a.shape[1]]
            out[dy::2, dx::2] = 0.5625 * c + 0.1875 * (y + x) + 0.0625 * d
    return out[:shape[0], :shape[1]]


def normalise(colour: np.ndarray, density: np.ndarray, min_density: float) -> np.ndarray:
    """``colour / density`` where ``density >= min_density``, pushed and pulled from coarser
    levels elsewhere (module docstring).

    Parameters
    ----------
    colour : (H, W, C)
        The splatted colour of every re-centred sample.
    density : (H, W, 1)
        The splatted sample count (the same splats with value 1).
    min_density : float
        ``m``: the least density whose ratio is used alone.
    """
    c, d = np.asarray(colour, np.float64), np.asarray(density, np.float64)
    d = np.maximum(d, 0.0)   # the Laplacian integration leaves float round-off of either sign
    if min(d.shape[:2]) <= 1 or d.min() >= min_density:
        return (c / np.maximum(d, min_density)).astype(np.float32)
    coarse = normalise(_down(c), _down(d), min_density)
    fill = _up(np.asarray(coarse, np.float64), d.shape)
    return ((c + np.maximum(min_density - d, 0.0) * fill) / np.maximum(d, min_density)).astype(np.float32)
