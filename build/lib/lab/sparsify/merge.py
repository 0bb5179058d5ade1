"""Step 6 of LSR18 section 5.5: merge spreadlets that fall on the same pixel."""
from __future__ import annotations

import numpy as np

__all__ = ["merge_coincident"]


def merge_coincident(points: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sum the values of coincident points and drop points whose values are all exactly zero.

    Zero points come from annealing moves onto an occupied pixel: the Voronoi tie rule gives the
    whole cell to the lower index, the other point's cell is empty and draws nothing.

    Parameters
    ----------
    points : ndarray of int, (n, 2)
        Integer positions.
    values : ndarray, (n, C)
        Values per channel.

    Returns
    -------
    points : ndarray, (m, 2), same dtype
        Distinct positions, sorted lexicographically.
    values : ndarray, (m, C), same dtype
        Their summed values.
    """
    points, values = np.asarray(points), np.asarray(values)
    uniq, inverse = np.unique(points, axis=0, return_inverse=True)
    summed = np.zeros((len(uniq), values.shape[1]), np.float64)
    np.add.at(summed, inverse.reshape(-1), values)
    keep = (summed != 0).any(axis=1)
    return uniq[keep].astype(points.dtype), summed[keep].astype(values.dtype)
