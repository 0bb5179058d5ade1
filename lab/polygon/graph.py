"""MHU21 section 4, the two numeric stages of polygon rectification (numba).

Graph construction: every input vertex ``v_i`` and travel direction ``t`` (both signs of each
line in D) whose line touches the polygon at ``v_i`` from outside is a *candidate edge*. A
*transition* ``(i, t) -> (j, t')`` (``j`` after ``i`` counter-clockwise) is a pair of candidate
edges that meet at ``X`` outside the polygon: ``X = v_i + s t = v_j - s' t'`` with ``s, s' >= 0``,
neither segment ``v_i X`` nor ``X v_j`` entering the polygon's interior, and the pocket between
them and the boundary chain ``v_i .. v_j`` turning clockwise (it lies outside). Its weight is the
pocket's area. Traversal: the cheapest cycle of at most N transitions that goes once around.

The polygon passed here is counter-clockwise (positive shoelace area), centred and of unit size,
so the tolerances are absolute.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["free_lengths", "transitions", "cycle_dp"]

TOL = 1e-9


@njit(cache=True)
def _strictly_inside(v, x, y):
    """Point strictly inside (farther than TOL from the boundary) the polygon ``v``."""
    k = v.shape[0]
    inside = False
    for e in range(k):
        px, py = v[e, 0], v[e, 1]
        qx, qy = v[(e + 1) % k, 0], v[(e + 1) % k, 1]
        ex, ey = qx - px, qy - py
        l2 = ex * ex + ey * ey
        t = 0.0 if l2 == 0.0 else min(1.0, max(0.0, ((x - px) * ex + (y - py) * ey) / l2))
        dx, dy = px + t * ex - x, py + t * ey - y
        if dx * dx + dy * dy <= TOL * TOL:
            return False
        if (py > y) != (qy > y) and x < px + (y - py) * ex / ey:
            inside = not inside
    return inside


@njit(cache=True)
def _free_length(v, ox, oy, tx, ty):
    """How far the ray ``o + s t`` (s > 0) runs before it enters the interior (inf: never)."""
    k = v.shape[0]
    tt = tx * tx + ty * ty
    params = np.empty(2 * k + 1)
    m = 0
    for e in range(k):
        px, py = v[e, 0] - ox, v[e, 1] - oy
        qx, qy = v[(e + 1) % k, 0] - ox, v[(e + 1) % k, 1] - oy
        cp = tx * py - ty * px
        cq = tx * qy - ty * qx
        if abs(cp) <= TOL and abs(cq) <= TOL:          # edge on the ray's line
            params[m] = (px * tx + py * ty) / tt
            params[m + 1] = (qx * tx + qy * ty) / tt
            m += 2
        elif (cp <= TOL and cq >= -TOL) or (cp >= -TOL and cq <= TOL):
            f = cp / (cp - cq)
            params[m] = ((px + f * (qx - px)) * tx + (py + f * (qy - py)) * ty) / tt
            m += 1
    params = np.sort(params[:m])
    prev = 0.0
    for s in params:
        if s <= prev + TOL:
            continue
        mid = 0.5 * (prev + s)
        if _strictly_inside(v, ox + mid * tx, oy + mid * ty):
            return prev
        prev = s
    return np.inf


@njit(cache=True)
def free_lengths(v, cand_vertex, cand_t):
    """Forward and backward free lengths of every candidate edge (units of its direction)."""
    n = cand_vertex.size
    fwd = np.empty(n)
    bwd = np.empty(n)
    for c in range(n):
        o = v[cand_vertex[c]]
        t = cand_t[c]
        fwd[c] = _free_length(v, o[0], o[1], t[0], t[1])
        bwd[c] = _free_length(v, o[0], o[1], -t[0], -t[1])
    return fwd, bwd


@njit(cache=True)
def transitions(v, cand_vertex, cand_t, fwd, bwd):
    """All transitions between candidates sorted by (vertex, angle): src, dst, X, weight."""
    k = v.shape[0]
    chain = np.zeros(2 * k + 1)                       # shoelace terms along the boundary
    for m in range(2 * k):
        a, b = m % k, (m + 1) % k
        chain[m + 1] = chain[m] + v[a, 0] * v[b, 1] - v[a, 1] * v[b, 0]
    n = cand_vertex.size
    tx, ty = cand_t[:, 0].copy(), cand_t[:, 1].copy()
    cap = 16 * n + 16
    src = np.empty(cap, np.int64)
    dst = np.empty(cap, np.int64)
    out = np.empty((cap, 3))                          # X and pocket area
    m = 0
    for a in range(n):
        i = cand_vertex[a]
        for b in range(n):
            if a == b:
                continue
            j = cand_vertex[b]
            cr = tx[a] * ty[b] - ty[a] * tx[b]
            if abs(cr) <= TOL:
                continue
            delta = (j - i) % k
            if delta == 0:                            # turn at the vertex itself, no pocket
                if b < a or cr <= TOL:
                    continue
                x, y, w = v[i, 0], v[i, 1], 0.0
            else:
                wx, wy = v[j, 0] - v[i, 0], v[j, 1] - v[i, 1]
                s = (wx * ty[b] - wy * tx[b]) / cr
                if s < -TOL or s > fwd[a] + TOL:
                    continue
                s2 = (tx[a] * wy - ty[a] * wx) / cr
                if s2 < -TOL or s2 > bwd[b] + TOL:
                    continue
                x, y = v[i, 0] + s * tx[a], v[i, 1] + s * ty[a]
                twice = (chain[i + delta] - chain[i] + (v[j, 0] * y - v[j, 1] * x)
                         + (x * v[i, 1] - y * v[i, 0]))
                if twice > TOL:                       # counter-clockwise: would hold the polygon
                    continue
                w = max(0.0, -0.5 * twice)
            if m == cap:
                cap *= 2
                src, dst, out = _grow(src, cap), _grow(dst, cap), _grow(out, cap)
            src[m], dst[m] = a, b
            out[m, 0], out[m, 1], out[m, 2] = x, y, w
            m += 1
    return src[:m].copy(), dst[:m].copy(), out[:m, :2].copy(), out[:m, 2].copy()


@njit(cache=True)
def _grow(arr, cap):
    new = np.empty((cap,) + arr.shape[1:], arr.dtype)
    new[:arr.shape[0]] = arr
    return new


@njit(cache=True)
def cycle_dp(n_cand, start, src, dst, weight, out_start, max_steps):
    """Cheapest forward paths from ``start`` using 0 .. max_steps transitions.

    ``src``/``dst`` are rotated positions, forward transitions only (``dst > src``), grouped by
    ``src`` with ``out_start`` as CSR offsets. Returns ``cost[n, c]`` and the transition
    ``pred[n, c]`` that reached ``c`` with ``n`` transitions.
    """
    cost = np.full((max_steps + 1, n_cand), np.inf)
    pred = np.full((max_steps + 1, n_cand), -1, np.int64)
    cost[0, start] = 0.0
    for c in range(start, n_cand):
        for e in range(out_start[c], out_start[c + 1]):
            d = dst[e]
            for n in range(max_steps):
                val = cost[n, c] + weight[e]
                if val < cost[n + 1, d]:
                    cost[n + 1, d] = val
                    pred[n + 1, d] = e
    return cost, pred
