"""Plain numpy references for the OpenCL kernels, and random databases to test them on."""
from __future__ import annotations

import numpy as np

from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.grid import NestedGrid

STATS = {"sparsity": 0.5, "ssim": 0.9, "l1": 0.01}


def random_database(rng, samples=12, channels=1, r_max=6, spreadlets=(0, 40), fast=0.3,
                    model="simple_lens", beta=(2.0,), ranges=None, delta_cell0=True):
    """Random spreadlets (positions within the crop radius + 1) and random dense crops per cell."""
    ns = len(beta)
    ranges = ranges or [(0.0, float(r_max))] * ns
    grid = NestedGrid.for_samples(samples, beta, ranges, [f"c{d}" for d in range(ns)])
    b = DatabaseBuilder(model, {"test": True}, grid, channels, 2 * r_max + 1)
    for i in range(grid.size):
        r = 0 if (i == 0 and delta_cell0) else int(rng.integers(0, r_max + 1))
        dense = rng.standard_normal((2 * r + 1, 2 * r + 1, channels)).astype(np.float32)
        if i == 0 and delta_cell0:
            dense[:] = 1.0  # a delta: in focus
        k = int(rng.integers(*spreadlets))
        pts = rng.integers(-(r + 1), r + 2, size=(k, 2))
        vals = rng.standard_normal((k, channels))
        if i == 0 and delta_cell0:  # the exact Laplacian of the delta
            pts = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]])
            vals = np.repeat([[-4.0], [1.0], [1.0], [1.0], [1.0]], channels, axis=1)
        b.add(pts, vals, dense, fast_track=bool(rng.random() < fast), stats=STATS)
    return b.build()


def laplacian_database(rng, samples=12, channels=1, r_max=6, fast=0.0):
    """Random dense crops whose spreadlets are exactly their 5-point Laplacians."""
    grid = NestedGrid.for_samples(samples, (2.0,), [(0.0, float(r_max))], ["coc"])
    b = DatabaseBuilder("simple_lens", {"test": "laplacian"}, grid, channels, 2 * r_max + 1)
    for i in range(grid.size):
        r = int(rng.integers(0, r_max + 1))
        dense = rng.random((2 * r + 1, 2 * r + 1, channels)).astype(np.float32)
        lap = laplacian5(np.pad(dense.astype(np.float64), ((1, 1), (1, 1), (0, 0))))
        ys, xs = np.nonzero(np.any(lap != 0, axis=-1))
        b.add(np.stack([xs - r - 1, ys - r - 1], 1), lap[ys, xs], dense,
              fast_track=bool(rng.random() < fast), stats=STATS)
    return b.build()


def cells(db, coords):
    return db.grid.index(np.asarray(coords, np.float64))


def _broadcast(db, colour):
    oc = max(colour.shape[-1], db.channels)
    return np.broadcast_to(colour, colour.shape[:2] + (oc,)).astype(np.float64), oc


def spreadlet_canvases(db, colour, coords, shape, dense_all=False):
    """(laplacian, dense) canvases of ``shape`` (Hc, Wc) by a plain scatter, float64."""
    col, oc = _broadcast(db, colour)
    h, w = colour.shape[:2]
    pad = db.pad
    lap = np.zeros(shape + (oc,))
    dense = np.zeros(shape + (oc,))
    cell = cells(db, coords)
    for y in range(h):
        for x in range(w):
            c, i = col[y, x], cell[y, x]
            if not np.any(c):
                continue
            if dense_all or db.fast_track[i]:
                r = db.dense_radius[i]
                dense[y + pad - r:y + pad + r + 1, x + pad - r:x + pad + r + 1] += db.dense_psf(i) * c
            else:
                p, v = db.spreadlets(i)
                np.add.at(lap, (y + pad + p[:, 1].astype(int), x + pad + p[:, 0].astype(int)),
                          v.astype(np.float64) * c)
    return lap, dense


def splat_image(db, colour, coords):
    """LSR18's Splat baseline, cropped to the image, float64."""
    h, w = colour.shape[:2]
    pad = db.pad
    _, dense = spreadlet_canvases(db, colour, coords, (h + 2 * pad, w + 2 * pad), dense_all=True)
    return dense[pad:pad + h, pad:pad + w]


def filter_image(db, colour, coords):
    """Gather: out(x) = sum_o psf_x(o) in(x - o), in = 0 outside the image, float64."""
    col, oc = _broadcast(db, colour)
    h, w = colour.shape[:2]
    cell = cells(db, coords)
    big = int(db.dense_radius.max())
    padded = np.zeros((h + 2 * big, w + 2 * big, oc))
    padded[big:big + h, big:big + w] = col
    out = np.zeros((h, w, oc))
    for y in range(h):
        for x in range(w):
            i = cell[y, x]
            r = db.dense_radius[i]
            window = padded[y + big - r:y + big + r + 1, x + big - r:x + big + r + 1]
            # in(x - o) for o = (ox, oy) in [-r, r]^2: the window flipped
            out[y, x] = np.sum(db.dense_psf(i) * window[::-1, ::-1], axis=(0, 1))
    return out
