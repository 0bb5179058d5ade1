"""Built-in polygon outlines for bokeh kernels: regular polygons, heart, clover, star.

Every shape is centred on the origin with circumradius 1, in image coordinates (``x`` right,
``y`` down: the heart's point is at +y, and so is one tip of the star). Regular polygons have two
vertical edges (the hexagon stands on a vertex), as MHU21's kernels do. The heart and the
pentagram are defined here once; the lab's traced ``heart`` and ``star`` apertures are
rasterised from them.

The runtime needs no rectification: ``shapes.json`` beside this module holds every shape
rectified once by the lab (MHU21's D, ``m = 2``, the default edge budget; written by
``python -m lab.polygon.ship``), and :func:`unit_polygon` reads it.
"""
from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["SHAPES", "SHIPPED", "SHIPPED_FORMAT", "SHIPPED_DIRECTIONS_M", "shape", "pentagram",
           "unit_polygon"]

_REGULAR = {"hexagon": 6, "octagon": 8, "dodecagon": 12, "hexadecagon": 16}
SHAPES = (*_REGULAR, "heart", "clover", "star")
SHIPPED = Path(__file__).with_name("shapes.json")
SHIPPED_FORMAT = 1
SHIPPED_DIRECTIONS_M = 2  # the shipped polygons' D: MHU21's, run and rise up to 2


def _regular(n: int) -> np.ndarray:
    ang = np.pi / n + 2 * np.pi * np.arange(n) / n
    return np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _heart(k: int) -> np.ndarray:
    """``k`` points of x = 16 sin^3 t, y = -(13 cos t - 5 cos 2t - 2 cos 3t - cos 4t), t uniform.

    The heart's point is at +y; its units are the formula's (16 wide each side, not centred).
    """
    t = 2 * np.pi * np.arange(k) / k
    x = 16 * np.sin(t) ** 3
    y = -(13 * np.cos(t) - 5 * np.cos(2 * t) - 2 * np.cos(3 * t) - np.cos(4 * t))
    return np.stack([x, y], axis=1)


def _clover(k: int) -> np.ndarray:
    t = 2 * np.pi * np.arange(k) / k
    r = 0.3 + 0.7 * np.abs(np.cos(2 * t)) ** 0.7            # four leaves, notched between them
    return np.stack([r * np.sin(t), -r * np.cos(t)], axis=1)


def pentagram(k: int = 10) -> np.ndarray:
    """The five-pointed star: tips on the unit circle, one at +y, centred on its centre of symmetry.

    Parameters
    ----------
    k : int, default 10
        Outline points: the 10 corners (tips and inner corners, at radius
        sin(pi/10) / sin(7 pi/10) = 0.382) for 10, more put points along the edges.
    """
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
        Centred on the middle of its bounding box.
    """
    if name not in SHAPES:
        raise InputError(f"shape: unknown name {name!r}; choose one of {', '.join(SHAPES)}")
    if name in _REGULAR:
        if n_vertices is not None:
            raise InputError(f"n_vertices: {name} has {_REGULAR[name]} vertices; omit n_vertices")
        return _regular(_REGULAR[name])
    k = n_vertices if n_vertices is not None else (10 if name == "star" else 200)
    if int(k) != k or k < 10:
        raise InputError(f"n_vertices: {k!r} is not an integer >= 10; pass e.g. 200")
    v = {"heart": _heart, "clover": _clover, "star": pentagram}[name](int(k))
    v = v - (v.max(axis=0) + v.min(axis=0)) / 2
    return v / np.linalg.norm(v, axis=1).max()


@lru_cache(maxsize=None)
def _shipped() -> dict:
    where = f"{SHIPPED} (the rectified built-in shapes)"
    try:
        data = json.loads(SHIPPED.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{where} cannot be read ({exc}); reinstall splatlab, or regenerate it "
                         "with `python -m lab.polygon.ship`") from None
    found = (data.get("format"), data.get("directions_m")) if isinstance(data, dict) else None
    if found != (SHIPPED_FORMAT, SHIPPED_DIRECTIONS_M) or not isinstance(data.get("shapes"), dict):
        raise InputError(f"{where}: (format, directions_m) = {found}, this runtime reads "
                         f"{(SHIPPED_FORMAT, SHIPPED_DIRECTIONS_M)}; regenerate it with "
                         "`python -m lab.polygon.ship`")
    return data


def unit_polygon(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The rectified unit polygon of the built-in shape ``name``, as the lab shipped it.

    ``name``'s outline (:func:`shape`) rectified with MHU21's D (:data:`SHIPPED_DIRECTIONS_M`) and
    its default edge budget (its corners, at most 16), centred on the outline's centroid, in units
    of the outline's circumradius: what :class:`runtime_cl.polygon.splat.PolygonSplatter` takes.

    Parameters
    ----------
    name : str
        One of :data:`SHAPES`.

    Returns
    -------
    vertices : ndarray of float64, shape (n, 2)
        Corners, counter-clockwise in the (x, y) frame.
    directions : ndarray of int64, shape (n, 2)
        Edge ``k`` runs from ``vertices[k]`` to ``vertices[k + 1]`` along ``+directions[k]``.

    Raises
    ------
    InputError
        Unknown name (the message lists the shapes), or a missing or foreign ``shapes.json``.
    """
    if name not in SHAPES:
        raise InputError(f"shape: unknown name {name!r}; choose one of {', '.join(SHAPES)}")
    entry = _shipped()["shapes"].get(name)
    if entry is None:
        raise InputError(f"{SHIPPED} has no shape {name!r}: it is older than this runtime; "
                         "regenerate it with `python -m lab.polygon.ship`")
    return np.array(entry["vertices"], np.float64), np.array(entry["directions"], np.int64)
