"""Step 5 of LSR18 section 5.5: simulated annealing of the integer spreadlet positions.

Each step moves a random ``fraction`` of the points (at least one) by one pixel to one of the 8
neighbours, re-assigns the values from the new Voronoi cells (the signed Laplacian summed per cell,
as in the collapse) and scores the result with the reconstruction cost (relative L1 of the PSF
minus the integrated spreadlets, :class:`lab.sparsify.cost.BoxCost`). Metropolis acceptance:
better is always kept, worse with probability ``exp(-increase / T)``.

Temperature schedule: geometric, from ``T0 = 1e-2 c0`` down to ``1e-4 c0`` at the last step,
where ``c0`` is the cost after the collapse. A typical move changes the cost by 1e-4 .. 1e-2 of
``c0``, so early steps can climb out of the local minima Lloyd leaves and the last hundred steps
are practically greedy. The best state seen is returned, so annealing never returns a cost above
its starting cost.

Voronoi cells are updated incrementally with the tie rule of :mod:`lab.sparsify.voronoi`: pixels
of the moved points' old cells get an exact nearest-point search, and pixels near a moved point's
new position (within the largest current pixel-to-point distance, the only ones that can switch)
are compared against it. A rejected step is undone from a log of the pixels it touched.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from .cost import BoxCost
from .voronoi import assign, build_occupancy, collapse, nearest

__all__ = ["anneal", "AnnealResult", "T_START", "T_END"]

T_START = 2e-3  # temperature at the first step, relative to the starting cost
T_END = 1e-5    # temperature at the last step, relative to the starting cost
_OFFSETS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)],
                    np.int32)


@numba.njit(cache=True)
def _move(mv, ny, nx, py, px, head, nxt):
    for t in range(mv.shape[0]):
        i = mv[t]
        y, x = py[i], px[i]
        if head[y, x] == i:
            head[y, x] = nxt[i]
        else:
            j = head[y, x]
            while nxt[j] != i:
                j = nxt[j]
            nxt[j] = nxt[i]
        py[i], px[i] = ny[t], nx[t]
        nxt[i] = head[ny[t], nx[t]]
        head[ny[t], nx[t]] = i


@numba.njit(cache=True)
def _reassign(mv, py, px, head, nxt, moved, sy, sx, sidx, lab, d2, max_d2,
              log_q, log_lab, log_d2, touched, lap, vals):
    """Update cells after the points ``mv`` moved; log touched pixels; update values."""
    h, w = head.shape
    for t in range(mv.shape[0]):
        moved[mv[t]] = True
    nlog = 0
    for q in range(sy.shape[0]):
        if moved[lab[q]]:
            touched[q] = True
            log_q[nlog], log_lab[nlog], log_d2[nlog] = q, lab[q], d2[q]
            nlog += 1
            lab[q], d2[q] = nearest(sy[q], sx[q], head, nxt)
    rad = int(math.sqrt(max_d2)) + 1
    for t in range(mv.shape[0]):
        i = mv[t]
        y, x = py[i], px[i]
        for yy in range(max(y - rad, 0), min(y + rad, h - 1) + 1):
            for xx in range(max(x - rad, 0), min(x + rad, w - 1) + 1):
                q = sidx[yy, xx]
                if q < 0:
                    continue
                dd = (yy - y) * (yy - y) + (xx - x) * (xx - x)
                if dd < d2[q] or (dd == d2[q] and i < lab[q]):
                    if not touched[q]:
                        touched[q] = True
                        log_q[nlog], log_lab[nlog], log_d2[nlog] = q, lab[q], d2[q]
                        nlog += 1
                    lab[q], d2[q] = i, dd
    for t in range(mv.shape[0]):
        moved[mv[t]] = False
    for e in range(nlog):
        q = log_q[e]
        touched[q] = False
        a, b = log_lab[e], lab[q]
        if a != b:
            for c in range(lap.shape[1]):
                vals[a, c] -= lap[q, c]
                vals[b, c] += lap[q, c]
    return nlog


@numba.njit(cache=True)
def _undo(nlog, log_q, log_lab, log_d2, lab, d2, lap, vals):
    for e in range(nlog - 1, -1, -1):
        q = log_q[e]
        a, b = log_lab[e], lab[q]
        if a != b:
            for c in range(lap.shape[1]):
                vals[b, c] -= lap[q, c]
                vals[a, c] += lap[q, c]
        lab[q], d2[q] = a, log_d2[e]


@numba.njit(cache=True)
def _splat(py, px, vals, canvas):
    canvas[:] = 0.0
    for i in range(py.shape[0]):
        for c in range(vals.shape[1]):
            canvas[py[i], px[i], c] += vals[i, c]


@dataclass(frozen=True)
class AnnealResult:
    """Outcome of :func:`anneal` (positions in canvas coordinates)."""

    py: np.ndarray
    px: np.ndarray
    values: np.ndarray      # (n, C) float64, the raw Voronoi sums of the best state
    costs: np.ndarray       # cost of the current state after every step
    best_costs: np.ndarray  # best cost so far after every step
    start_cost: float
    accepted: int


def anneal(sy, sx, lap, py, px, cost: BoxCost, rng: np.random.Generator, steps: int = 400,
           fraction: float = 0.01, bounds: tuple[int, int, int, int] | None = None,
           project: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
           fixed: np.ndarray | None = None) -> AnnealResult:
    """Anneal integer spreadlet positions against the reconstruction cost.

    Parameters
    ----------
    sy, sx : ndarray of int, (K,)
        Support pixels (nonzero Laplacian) in the canvas of ``cost``.
    lap : ndarray, (K, C)
        Their Laplacian per channel.
    py, px : ndarray of int, (n,)
        Starting points (after Lloyd), n >= 1.
    cost : BoxCost
        The reconstruction cost on the canvas.
    rng : numpy.random.Generator
        Source of all randomness.
    steps : int, default 400
        Number of annealing steps (LSR18: 400).
    fraction : float, default 0.01
        Fraction of the points moved per step (LSR18: 1 %), at least one point.
    bounds : (y_lo, y_hi, x_lo, x_hi), optional
        Inclusive range points may move in; defaults to the canvas without its border ring.
    project : callable (py, px, values) -> values, optional
        Applied to the Voronoi sums before scoring (e.g. :class:`lab.sparsify.moments.MomentMatch`);
        the returned values stay the raw sums.
    fixed : ndarray, (n, C), optional
        Values that stay with each point whatever its cell (the Laplacian of pixels outside the
        annealed support, assigned once; see :func:`lab.sparsify.sparsify`).

    Returns
    -------
    AnnealResult
        The best state seen, its values and the cost trace.
    """
    h, w = cost.target.shape[:2]
    ylo, yhi, xlo, xhi = bounds if bounds is not None else (1, h - 2, 1, w - 2)
    sy, sx = np.asarray(sy, np.int64), np.asarray(sx, np.int64)
    lap = np.ascontiguousarray(lap, np.float64)
    py, px = np.asarray(py, np.int64).copy(), np.asarray(px, np.int64).copy()
    n, k_sup = py.size, sy.size
    lab, d2 = assign(sy, sx, py, px, (h, w))
    lab, d2 = lab.astype(np.int64), d2.astype(np.int64)
    vals = collapse(lab, lap, n)
    if fixed is not None:
        vals += fixed
    head, nxt = build_occupancy(py.astype(np.int32), px.astype(np.int32), h, w)
    sidx = np.full((h, w), -1, np.int64)
    sidx[sy, sx] = np.arange(k_sup)
    moved, touched = np.zeros(n, np.bool_), np.zeros(k_sup, np.bool_)
    log_q, log_lab, log_d2 = (np.empty(k_sup, np.int64) for _ in range(3))
    canvas = np.zeros((h, w, lap.shape[1]), np.float32)

    def score():
        _splat(py, px, vals if project is None else project(py, px, vals), canvas)
        return cost(canvas)

    current = start = score()
    best, best_state = current, (py.copy(), px.copy(), vals.copy())
    max_d2 = int(d2.max())
    k = max(1, int(round(fraction * n)))
    temps = start * T_START * (T_END / T_START) ** (np.arange(steps) / max(steps - 1, 1))
    costs, bests, accepted = np.empty(steps), np.empty(steps), 0
    for s in range(steps):
        mv = rng.choice(n, size=min(k, n), replace=False).astype(np.int64)
        off = _OFFSETS[rng.integers(0, 8, mv.size)]
        u = rng.random()
        ny, nx = py[mv] + off[:, 0], px[mv] + off[:, 1]
        ok = (ny >= ylo) & (ny <= yhi) & (nx >= xlo) & (nx <= xhi)
        mv, ny, nx = mv[ok], ny[ok], nx[ok]
        if mv.size:
            oy, ox = py[mv], px[mv]
            _move(mv, ny, nx, py, px, head, nxt)
            nlog = _reassign(mv, py, px, head, nxt, moved, sy, sx, sidx, lab, d2, max_d2,
                             log_q, log_lab, log_d2, touched, lap, vals)
            trial = score()
            if trial <= current or u < math.exp(-(trial - current) / temps[s]):
                current, accepted = trial, accepted + 1
                max_d2 = int(d2.max())
                if current < best:
                    best, best_state = current, (py.copy(), px.copy(), vals.copy())
            else:
                _undo(nlog, log_q, log_lab, log_d2, lab, d2, lap, vals)
                _move(mv, oy, ox, py, px, head, nxt)
        costs[s], bests[s] = current, best
    by, bx, bv = best_state
    return AnnealResult(by.astype(np.int32), bx.astype(np.int32), bv, costs, bests, start,
                        accepted)
