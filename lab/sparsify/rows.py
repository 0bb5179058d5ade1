"""Row-difference spreadlets: a PSF as sparse jumps along its rows, integrated by a prefix sum.

LSR18 stores a PSF as its sparse Laplacian. A flat shape's Laplacian lies on its outline, two to
three pixels wide all round, and a thin shape (a crescent) or a small disc is little sparser than
dense. Along one axis (MHU21's directional differences) a flat row has a jump where it enters the
shape and one where it leaves, so the same PSF needs about as many terms as it has rows times
its edges per row. Each row is fitted by a piecewise-constant function with the fewest jumps for
its accuracy: the exact minimiser of

    sum_x |f(x) - u(x)|^2  +  lambda * (number of segments)

(the Potts functional) by dynamic programming over the row's support, every channel in one cost
(a jump is shared by the channels), each segment at its mean or at 0. The stored terms are the
fit's backward differences ``u(x) - u(x - 1)``; the runtime splats them and sums each canvas row
(:mod:`runtime_cl.integrate.rows`). No term ever leaves its row, so there is no far field and the
integration is exact (no Poisson solve).

lambda is ``LAMBDA / density`` times the PSF's level squared (``sum_c level_c^2``, level_c =
``sum f_c^2 / sum f_c`` as for the Laplacian spreadlets), plus, for a ray-histogram PSF, a jump's
worth of noise: ``2 ln(n) sigma^2`` with sigma^2 the row's mean per-pixel variance (``f quantum``
summed over channels), the BIC of a change point, so a fit never follows ray noise. ``LAMBDA =
0.05`` was chosen on pre-filtered discs with 8192 rays per pixel (relative ray noise 1.1 %), as
terms per dense pixel and SSIM against the exact disc, Laplacian spreadlets at density 1 beside
them:

    r = 2-2.5 px     rows  96 % 1.000 (lambda 0.03) | 72 % .992 (0.1)   Laplacian 148 % (dense)
    r = 5-5.5 px     rows  51 % 1.000               | 39 % .972         Laplacian 103 % (dense)
    r = 20-21 px     rows  16 % .991                | 12 % .958         Laplacian  33 % .938
    r = 60-62 px     rows 6.9 % .993                | 5.0 % .979        Laplacian  11 % .963

so at a higher SSIM than the Laplacian's, half its terms or fewer, and small PSFs need no dense
fast track. The basis cannot be turned by any angle (a turned row difference is a difference
along another axis): it is for models whose PSFs are drawn as stored or turned by 180 degrees
(symmetries ``rotation`` and ``coc_sign``), where the half turn is exact: the turned PSF's
difference at x is minus the stored one's at 1 - x.
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["LAMBDA", "L1_MAX", "REFITS", "fit_rows", "row_terms"]

# Segment cost at density 1, in units of the PSF's level squared (see the module docstring).
LAMBDA = 0.05
# A fit with a larger relative L1 error is redone with a quarter of the cost, at most REFITS
# times (lab.sparsify.spreadlets): on the traced demo database, 3 x 3 PSFs came out at 31 % L1
# with 8 terms for 9 pixels; large discs stay at 1.6-2 %, as the Laplacian spreadlets do.
L1_MAX = 0.05
REFITS = 3


@numba.njit(cache=True)
def _potts(y: np.ndarray, lam: float):
    """Exact Potts fit of one row ``y`` (n, C): segment starts and whether each is held at 0."""
    n, c = y.shape
    s1 = np.zeros((n + 1, c))
    s2 = np.zeros(n + 1)
    for i in range(n):
        acc = 0.0
        for k in range(c):
            s1[i + 1, k] = s1[i, k] + y[i, k]
            acc += y[i, k] * y[i, k]
        s2[i + 1] = s2[i] + acc
    best = np.full(n + 1, np.inf)
    best[0] = 0.0
    start = np.zeros(n + 1, np.int64)
    zero = np.zeros(n + 1, np.bool_)
    for j in range(1, n + 1):
        for i in range(j):
            energy = s2[j] - s2[i]
            mean_sq = 0.0
            for k in range(c):
                d = s1[j, k] - s1[i, k]
                mean_sq += d * d
            at_mean = energy - mean_sq / (j - i)
            cost = best[i] + lam + min(at_mean, energy)
            if cost < best[j]:
                best[j], start[j], zero[j] = cost, i, energy <= at_mean
    # walk back from the row's end
    starts, zeros = [], []
    j = n
    while j > 0:
        starts.append(start[j])
        zeros.append(zero[j])
        j = start[j]
    return starts[::-1], zeros[::-1]


def fit_rows(psf: np.ndarray, lam_scale: float, quantum: np.ndarray | None = None) -> np.ndarray:
    """The piecewise-constant fit of every row of ``psf`` (R, R, C), float64, same shape.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        Non-negative PSF.
    lam_scale : float
        Segment cost in units of the PSF's level squared (``LAMBDA / density``).
    quantum : ndarray (C,), optional
        ``1 / rays`` per channel of a ray-histogram PSF: adds the noise term to each row's cost.
    """
    f = np.asarray(psf, np.float64)
    level = (f * f).sum(axis=(0, 1)) / np.maximum(f.sum(axis=(0, 1)), 1e-300)
    base = lam_scale * float((level ** 2).sum())
    out = np.zeros_like(f)
    lit = (f != 0).any(axis=2)
    for y in np.flatnonzero(lit.any(axis=1)):
        xs = np.flatnonzero(lit[y])
        a, b = int(xs[0]), int(xs[-1]) + 1
        row = np.ascontiguousarray(f[y, a:b])
        lam = base
        if quantum is not None:
            var = float((row.mean(axis=0) * quantum).sum())
            lam += 2.0 * math.log(b - a + 1) * var
        starts, zeros = _potts(row, lam)
        ends = starts[1:] + [b - a]
        for s, e, z in zip(starts, ends, zeros):
            if not z:
                out[y, a + s:a + e] = row[s:e].mean(axis=0)
    return out


def row_terms(fit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The backward row differences of ``fit`` (R, R, C) where they are non-zero.

    Returns ``points`` (n, 2) int16 offsets (dx, dy) from the centre (R//2, R//2), sorted by (dy,
    dx), and ``values`` (n, C) float32. The last term of each row is minus the float32 sum of the
    others, so a float32 prefix sum in term order returns to exactly 0 after the row's shape.
    """
    c = fit.shape[0] // 2
    diff = np.diff(fit.astype(np.float32), axis=1, prepend=0.0, append=0.0)   # (R, R + 1, C)
    ys, xs = np.nonzero((diff != 0).any(axis=2))
    values = diff[ys, xs]
    # close each row exactly in float32: its last term cancels the running sum of the others
    for row in np.split(np.arange(len(ys)), np.flatnonzero(np.diff(ys)) + 1):
        if len(row):
            run = np.zeros(fit.shape[2], np.float32)
            for v in values[row[:-1]]:
                run = run + v
            values[row[-1]] = -run
    points = np.column_stack([xs - c, ys - c]).astype(np.int16)
    return points, values
