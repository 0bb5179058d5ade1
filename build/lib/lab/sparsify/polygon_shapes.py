"""Built-in polygon outlines for bokeh kernels: regular polygons, heart, clover, star.

Every shape is centred on the origin with circumradius 1, in image coordinates (``x`` right,
``y`` down: the heart's point and the star's lower legs are at +y). Regular polygons have two
vertical edges (the hexagon stands on a vertex), as MHU21's kernels do.
"""
from __future__ import annotations

import numpy as np

from lab.errors import UserError

__all__ = ["SHAPES", "shape"]

_REGULAR = {"hexagon": 6, "octagon": 8, "dodecagon": 12, "hexadecagon": 16}
SHAPES = (*_REGULAR, "heart", "clover", "star")


def _regular(n: int) -> np.ndarray:
    ang = np.pi / n + 2 * np.pi * np.arange(n) / n
    return np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _heart(k: int) -> np.ndarray:
    t = 2 * np.pi * np.arange(k) / k
    x = 16 * np.sin(t) ** 3
    y = -(13 * np.cos(t) - 5 * np.cos(2 * t) - 2 * np.cos(3 * t) - np.cos(4 * t))
    return np.stack([x, y], axis=1)


def _clover(k: int) -> np.ndarray:
    t = 2 * np.pi * np.arange(k) / k
    r = 0.3 + 0.7 * np.abs(np.cos(2 * t)) ** 0.7            # four leaves, notched between them
    return np.stack([r * np.sin(t), -r * np.cos(t)], axis=1)


def _star(k: int) -> np.ndarray:
    ang = -np.pi / 2 + np.pi * np.arange(10) / 5
    r = np.where(np.arange(10) % 2 == 0, 1.0, np.sin(np.pi / 10) / np.sin(7 * np.pi / 10))
    corners = np.stack([r * np.cos(ang), -r * np.sin(ang)], axis=1)
    per_edge = np.diff(np.linspace(0, k, 11).round().astype(int))   # k points along 10 edges
    pts = [c + np.outer(np.arange(m) / m, nxt - c)
           for c, nxt, m in zip(corners, np.roll(corners, -1, axis=0), per_edge)]
    return np.concatenate(pts)


def shape(name: str, n_vertices: int | None = None) -> np.ndarray:
    """Vertices of the built-in shape ``name`` (see :data:`SHAPES`), circumradius 1.

    Parameters
    ----------
    name : str
        One of ``hexagon, octagon, dodecagon, hexadecagon, heart, clover, star``.
    n_vertices : int, optional
        Outline resolution of heart, clover (default 200) and star (default 10: the pentagram's
        corners; more put points along its edges). Regular polygons take no resolution.

    Returns
    -------
    ndarray, shape (k, 2)
    """
    if name not in SHAPES:
        raise UserError(f"shape: unknown name {name!r}; choose one of {', '.join(SHAPES)}")
    if name in _REGULAR:
        if n_vertices is not None:
            raise UserError(f"n_vertices: {name} has {_REGULAR[name]} vertices; omit n_vertices")
        return _regular(_REGULAR[name])
    k = n_vertices if n_vertices is not None else (10 if name == "star" else 200)
    if int(k) != k or k < 10:
        raise UserError(f"n_vertices: {k!r} is not an integer >= 10; pass e.g. 200")
    v = {"heart": _heart, "clover": _clover, "star": _star}[name](int(k))
    v = v - (v.max(axis=0) + v.min(axis=0)) / 2
    return v / np.linalg.norm(v, axis=1).max()
