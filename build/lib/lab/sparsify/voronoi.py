"""Discrete Voronoi cells of integer spreadlet positions and the collapse of a cell into its point.

Cells are taken over the support (the pixels whose Laplacian is nonzero in some channel): every
support pixel belongs to its nearest point, ties going to the lower point index. All coordinates
are integers, so squared distances are exact integers and the tie rule makes the partition
deterministic; the annealer (:mod:`lab.sparsify.anneal`) updates cells incrementally with the same
rule, so a full re-assignment and an incremental one agree pixel for pixel.

Nearest points are found on an occupancy image (per-pixel linked lists of points) by scanning
square rings of growing radius k and stopping once k^2 exceeds the best squared distance: the
work is about the squared distance to the nearest point.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["build_occupancy", "nearest", "assign", "collapse"]


@numba.njit(cache=True)
def build_occupancy(py, px, h, w):
    """Per-pixel linked lists of points: ``head[y, x]`` first point there, ``nxt[i]`` the next."""
    head = np.full((h, w), -1, np.int32)
    nxt = np.full(py.shape[0], -1, np.int32)
    for i in range(py.shape[0] - 1, -1, -1):
        nxt[i] = head[py[i], px[i]]
        head[py[i], px[i]] = i
    return head, nxt


@numba.njit(cache=True, inline="always")
def _scan_pixel(yy, xx, y, x, head, nxt, best, bd2):
    i = head[yy, xx]
    if i >= 0:
        d2 = (yy - y) * (yy - y) + (xx - x) * (xx - x)
        while i >= 0:
            if best < 0 or d2 < bd2 or (d2 == bd2 and i < best):
                best, bd2 = i, d2
            i = nxt[i]
    return best, bd2


@numba.njit(cache=True)
def nearest(y, x, head, nxt):
    """Index and squared distance of the point nearest to pixel (y, x); (-1, -1) if none."""
    h, w = head.shape
    best, bd2 = -1, -1
    for k in range(max(h, w) + 1):
        if best >= 0 and k * k > bd2:
            break
        y0, y1, x0, x1 = y - k, y + k, x - k, x + k
        for xx in range(max(x0, 0), min(x1, w - 1) + 1):
            if y0 >= 0:
                best, bd2 = _scan_pixel(y0, xx, y, x, head, nxt, best, bd2)
            if k > 0 and y1 < h:
                best, bd2 = _scan_pixel(y1, xx, y, x, head, nxt, best, bd2)
        for yy in range(max(y0 + 1, 0), min(y1 - 1, h - 1) + 1):
            if x0 >= 0:
                best, bd2 = _scan_pixel(yy, x0, y, x, head, nxt, best, bd2)
            if k > 0 and x1 < w:
                best, bd2 = _scan_pixel(yy, x1, y, x, head, nxt, best, bd2)
    return best, bd2


@numba.njit(cache=True)
def _assign(sy, sx, head, nxt):
    lab = np.empty(sy.shape[0], np.int32)
    d2 = np.empty(sy.shape[0], np.int64)
    for q in range(sy.shape[0]):
        lab[q], d2[q] = nearest(sy[q], sx[q], head, nxt)
    return lab, d2


def assign(sy: np.ndarray, sx: np.ndarray, py: np.ndarray, px: np.ndarray,
           shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Voronoi label of every support pixel.

    Parameters
    ----------
    sy, sx : ndarray of int, (K,)
        Support pixel coordinates inside a canvas of ``shape``.
    py, px : ndarray of int, (n,)
        Integer point coordinates inside the same canvas (n >= 1; coincident points allowed).
    shape : (int, int)
        Canvas height and width.

    Returns
    -------
    labels : ndarray, int32 (K,)
        Index of the nearest point (lowest index on ties).
    d2 : ndarray, int64 (K,)
        Squared distance to it in px^2.
    """
    head, nxt = build_occupancy(np.asarray(py, np.int32), np.asarray(px, np.int32), *shape)
    return _assign(np.asarray(sy, np.int32), np.asarray(sx, np.int32), head, nxt)


def collapse(labels: np.ndarray, lap: np.ndarray, n: int) -> np.ndarray:
    """Sum each cell's signed Laplacian into its point, per channel (LSR18 section 5.5).

    Parameters
    ----------
    labels : ndarray of int, (K,)
        Cell of each support pixel, from :func:`assign`.
    lap : ndarray, (K, C)
        Laplacian of each support pixel.
    n : int
        Number of points.

    Returns
    -------
    ndarray, float64 (n, C)
        Every support pixel lands in exactly one point, so each channel's total is kept.
    """
    return np.stack([np.bincount(labels, lap[:, c], minlength=n) for c in range(lap.shape[1])],
                    axis=1)
