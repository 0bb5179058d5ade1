"""Step 2 of LSR18 section 5.5: a Poisson-disk pattern by dart throwing with |Laplacian| importance.

Candidates are support pixels drawn with probability proportional to their importance I (pixels
with a zero Laplacian never). A candidate x is accepted when no accepted point lies closer than
its own disk radius r(x), with

    pi r(x)^2 I(x) = m,

so every disk carries about the same importance mass m: the cell area is inversely proportional
to the Laplacian, as LSR18 notes for the collapsed cells. A pixel that already holds a point is
always rejected (r < 1 px would otherwise allow duplicates). Throwing stops after
``max_failures`` consecutive rejections (LSR18: 10 000).

Accepted points sit in a bucket grid so a candidate checks only the buckets its disk overlaps.
Uniforms come from a numpy Generator in chunks, so a seed fixes the pattern.
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["throw_darts"]

_CHUNK = 1 << 14


@numba.njit(cache=True)
def _throw(u, cdf, sy, sx, r2, cell, ghead, gnext, py, px, n, fails, max_failures):
    gh, gw = ghead.shape
    total = cdf[-1]
    for t in range(u.shape[0]):
        q = np.searchsorted(cdf, u[t] * total, side="right")
        if q >= cdf.shape[0]:
            q = cdf.shape[0] - 1
        y, x, rr = sy[q], sx[q], r2[q]
        r = math.sqrt(rr)
        hit = False
        for gy in range(max(int((y - r) // cell), 0), min(int((y + r) // cell), gh - 1) + 1):
            for gx in range(max(int((x - r) // cell), 0), min(int((x + r) // cell), gw - 1) + 1):
                i = ghead[gy, gx]
                while i >= 0:
                    d2 = (py[i] - y) ** 2 + (px[i] - x) ** 2
                    if d2 == 0 or d2 < rr:
                        hit = True
                        break
                    i = gnext[i]
                if hit:
                    break
            if hit:
                break
        if hit:
            fails += 1
            if fails >= max_failures:
                return n, fails, True
        else:
            py[n], px[n] = y, x
            gy, gx = y // cell, x // cell
            gnext[n] = ghead[gy, gx]
            ghead[gy, gx] = n
            n += 1
            fails = 0
    return n, fails, False


def throw_darts(sy: np.ndarray, sx: np.ndarray, weight: np.ndarray, mass: float,
                rng: np.random.Generator, max_failures: int = 10_000,
                shape: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Importance-driven Poisson-disk sampling of the support pixels.

    Parameters
    ----------
    sy, sx : ndarray of int, (K,)
        Support pixel coordinates (non-negative).
    weight : ndarray of float, (K,)
        Importance of each support pixel, > 0.
    mass : float
        Importance mass m per disk; the disk radius at x is ``sqrt(m / (pi weight(x)))`` px.
    rng : numpy.random.Generator
        Source of all randomness.
    max_failures : int, default 10000
        Stop after this many consecutive rejected candidates.
    shape : (int, int), optional
        Canvas holding the coordinates; defaults to their bounding range.

    Returns
    -------
    py, px : ndarray, int32 (n,)
        Accepted points in acceptance order, all distinct.
    """
    sy, sx = np.asarray(sy, np.int64), np.asarray(sx, np.int64)
    weight = np.asarray(weight, np.float64)
    r2 = mass / (math.pi * weight)
    h, w = shape if shape is not None else (int(sy.max()) + 1, int(sx.max()) + 1)
    # buckets about one typical disk across: few points per bucket, few buckets per disk
    cell = max(1, int(math.ceil(math.sqrt(float(np.median(r2))))))
    ghead = np.full((h // cell + 1, w // cell + 1), -1, np.int64)
    gnext = np.full(sy.size, -1, np.int64)
    py, px = np.empty(sy.size, np.int64), np.empty(sy.size, np.int64)
    cdf = np.cumsum(weight)
    n, fails, done = 0, 0, False
    while not done:
        n, fails, done = _throw(rng.random(_CHUNK), cdf, sy, sx, r2, cell, ghead, gnext,
                                py, px, n, fails, max_failures)
    return py[:n].astype(np.int32), px[:n].astype(np.int32)
