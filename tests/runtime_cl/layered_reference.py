"""Plain numpy references of the layered lens-ray tracer (runtime_cl/kernels/layered/trace.cl)."""
import numpy as np


def brute_force_hits(inv_depth, rays, thickness):
    """The nearest surfel hit of each ray, by testing every cell of every layer (float64).

    A ray q(w) = a + b w hits layer k's cell c where q(w) lies in [cx, cx+1] x [cy, cy+1] and
    h_c - thickness <= w <= h_c, for 0 <= w <= wmax (the greatest inverse depth of any layer);
    the hit is the largest such w, ties to the lower layer. Returns (n, 3): w (-1 none), layer,
    cell y W + x (-1 none).
    """
    inv = np.asarray(inv_depth, np.float64)
    n_layers, h, w = inv.shape
    wmax = inv.max()
    ys, xs = np.mgrid[0:h, 0:w]
    out = np.full((len(rays), 3), -1.0)
    for i, (ax, ay, bx, by) in enumerate(np.asarray(rays, np.float64)):
        lo = np.zeros((h, w))
        hi = np.full((h, w), wmax)
        for a, b, c in ((ax, bx, xs), (ay, by, ys)):
            if b == 0:
                inside = (a >= c) & (a <= c + 1)
                lo = np.where(inside, lo, np.inf)
            else:
                w1, w2 = (c - a) / b, (c + 1 - a) / b
                lo, hi = np.maximum(lo, np.minimum(w1, w2)), np.minimum(hi, np.maximum(w1, w2))
        best = (-1.0, -1, -1)
        for k in range(n_layers):
            hk = inv[k]
            top = np.minimum(hi, hk)
            ok = (hk >= 0) & (np.maximum(lo, hk - thickness) <= top)
            if ok.any():
                j = int(np.argmax(np.where(ok, top, -np.inf)))
                if top.flat[j] > best[0]:
                    best = (float(top.flat[j]), k, j)
        out[i] = best
    return out


def march_hits(inv_depth, rays, thickness, steps=20000):
    """The same hits by marching each ray from wmax down to 0 in ``steps`` equal steps: the first
    step whose point lies in a cell and the cell's slab, over every layer (coarser, independent)."""
    inv = np.asarray(inv_depth, np.float64)
    n_layers, h, w = inv.shape
    ws = np.linspace(inv.max(), 0.0, steps)
    out = np.full((len(rays), 3), -1.0)
    for i, (ax, ay, bx, by) in enumerate(np.asarray(rays, np.float64)):
        qx, qy = ax + bx * ws, ay + by * ws
        inside = (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h)
        cx, cy = np.clip(qx.astype(int), 0, w - 1), np.clip(qy.astype(int), 0, h - 1)
        hv = inv[:, cy, cx]                                   # (L, steps)
        hit = inside & (hv >= 0) & (ws <= hv) & (ws >= hv - thickness)
        first = [int(np.argmax(row)) if row.any() else steps for row in hit]
        k = int(np.argmin(first))
        if first[k] < steps:
            out[i] = (ws[first[k]], k, cy[first[k]] * w + cx[first[k]])
    return out
