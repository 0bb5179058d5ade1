"""Step 3 of LSR18 section 5.5: Lloyd relaxation weighted by the Laplacian importance.

Each iteration assigns every support pixel to its nearest point (Voronoi cells restricted to the
pixels with a nonzero Laplacian, by a k-d tree) and moves each point to the importance-weighted
centroid of its cell; a point whose cell is empty stays. Positions stay continuous during the
iterations (each iteration then provably does not increase the weighted quantisation energy) and
are rounded to pixels at the end, as the runtime can only splat at integer offsets. Points that
round onto the same pixel are kept once.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .voronoi import assign

__all__ = ["lloyd", "quantisation_energy"]


def lloyd(sy: np.ndarray, sx: np.ndarray, weight: np.ndarray, py: np.ndarray, px: np.ndarray,
          iterations: int = 50, tol: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Relax points towards the weighted centroids of their Voronoi cells.

    Parameters
    ----------
    sy, sx : ndarray of int, (K,)
        Support pixel coordinates.
    weight : ndarray of float, (K,)
        Importance of each support pixel (> 0).
    py, px : ndarray of int, (n,)
        Starting points (dart throwing), n >= 1.
    iterations : int, default 50
        Maximum number of iterations (LSR18: 50).
    tol : float, default 1e-3
        Stop early once no point moves more than this many pixels (a fixed point).

    Returns
    -------
    py, px : ndarray, int32 (m,)
        Rounded, distinct points (m <= n), in the order of their first occurrence.
    """
    pix = np.column_stack([sy, sx]).astype(np.float64)
    pts = np.column_stack([py, px]).astype(np.float64)
    w = np.asarray(weight, np.float64)
    n = len(pts)
    for _ in range(iterations):
        _, lab = cKDTree(pts).query(pix)
        mass = np.bincount(lab, w, minlength=n)
        has = mass > 0
        cen = np.stack([np.bincount(lab, w * pix[:, k], minlength=n) for k in (0, 1)], axis=1)
        new = pts.copy()
        new[has] = cen[has] / mass[has, None]
        step = np.abs(new - pts).max()
        pts = new
        if step < tol:
            break
    rounded = np.rint(pts).astype(np.int32)
    _, first = np.unique(rounded, axis=0, return_index=True)
    keep = np.sort(first)
    return rounded[keep, 0], rounded[keep, 1]


def quantisation_energy(sy, sx, weight, py, px, shape) -> float:
    """Weighted quantisation energy ``sum_q weight(q) |q - nearest point|^2`` of integer points."""
    _, d2 = assign(sy, sx, py, px, shape)
    return float(np.dot(np.asarray(weight, np.float64), d2))
