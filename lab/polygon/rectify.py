"""Polygon rectification (MHU21 section 4): the minimum-area enclosing polygon with edges in D.

``rectify(vertices, directions, max_edges)`` takes any simple polygon (convex or concave) and a
set D of small-integer edge directions and returns the enclosing polygon of least area with at
most ``max_edges`` edges, every edge along a direction of D, by the paper's graph construction
(candidate edges touching input vertices from outside, pairs meeting outside with their pocket
areas; :mod:`lab.polygon.graph`) and DP traversal once around the polygon.

The traversal is cut where the fewest transitions cross the start of the vertex order; one DP
per distinct first edge after that cut covers every cycle, instead of one per input vertex.
Optimality holds within the paper's search space, polygons whose every edge touches an input
vertex. MHU21 argues the optimum always lies there; for concave outlines it need not: a short
step edge can be held by its corner resting on an input edge and touch no vertex (a 0.4 % smaller
example is in tests/lab/polygon/test_rectify.py). The result always encloses the input.

Coordinates are kept as given (``y`` down for image kernels); :meth:`Rectified.unit` gives the
polygon in radius units for :func:`runtime_cl.polygon.kernel.scale_polygon`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from math import gcd

import numpy as np
import shapely

from lab.errors import UserError
from lab.polygon import graph

__all__ = ["Rectified", "rectify", "direction_set", "normalize_directions"]


@dataclass(frozen=True)
class Rectified:
    """A rectified polygon and how it was found.

    Attributes
    ----------
    vertices : ndarray, shape (n, 2)
        Corners, counter-clockwise in the input's (x, y) frame (positive shoelace area).
    directions : ndarray of int64, shape (n, 2)
        Edge ``k`` runs from ``vertices[k]`` to ``vertices[k + 1]`` along ``+directions[k]``.
    touch : ndarray of int64, shape (n,)
        Index (into the input) of an input vertex that edge ``k`` touches.
    area, input_area : float
        Areas of the rectified and the input polygon (input units squared).
    area_by_edges : ndarray, shape (max_edges + 1,)
        Least enclosing area with exactly ``n`` edges (inf where none), a by-product of the DP.
    construction_s, traversal_s : float
        Wall time of graph construction (T0) and traversal (T1), seconds.
    n_candidates, n_transitions : int
        Graph size: candidate edges and transitions (weighted pairs).
    centre, circumradius : ndarray, float
        Input polygon's area centroid and largest vertex distance from it (for :meth:`unit`).
    """

    vertices: np.ndarray
    directions: np.ndarray
    touch: np.ndarray
    area: float
    input_area: float
    area_by_edges: np.ndarray
    construction_s: float
    traversal_s: float
    n_candidates: int
    n_transitions: int
    centre: np.ndarray
    circumradius: float

    def unit(self) -> tuple[np.ndarray, np.ndarray]:
        """``(vertices, directions)`` centred on the input's centroid, input circumradius 1."""
        return (self.vertices - self.centre) / self.circumradius, self.directions.copy()


def direction_set(m: int) -> np.ndarray:
    """All reduced directions ``(a, b)`` with ``|a|, |b| <= m``, one per line, ``a >= 0``.

    ``direction_set(2)`` is MHU21's D: (1,0), (0,1), (1,+-1), (1,+-2), (2,+-1).
    """
    if int(m) != m or m < 1:
        raise UserError(f"m: {m!r} is not an integer >= 1; pass the largest |rise| or |run|")
    out = {(a // gcd(a, b), b // gcd(a, b)) for a in range(0, m + 1) for b in range(-m, m + 1)
           if (a, b) != (0, 0) and (a > 0 or b > 0)}
    return np.array(sorted(out, key=lambda d: np.arctan2(d[1], d[0]) % np.pi), np.int64)


def normalize_directions(directions) -> np.ndarray:
    """Validate D: integer, non-zero, |components| <= 64; primitive, one per line, a >= 0."""
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != 2 or len(d) == 0:
        raise UserError(f"directions: expected (m, 2) (run, rise) pairs, got shape {d.shape}; "
                        "e.g. direction_set(2)")
    if not np.isfinite(d).all() or (d != np.round(d)).any() or (np.abs(d) > 64).any() \
            or (np.abs(d).sum(1) == 0).any():
        raise UserError(f"directions: {d.tolist()} must be non-zero small integers (|.| <= 64); "
                        "use e.g. (1, 2) for a slope of rise 2 over run 1")
    out = []
    for a, b in d.astype(np.int64):
        g = gcd(int(a), int(b))
        a, b = int(a) // g, int(b) // g
        if a < 0 or (a == 0 and b < 0):
            a, b = -a, -b
        if (a, b) not in out:
            out.append((a, b))
    if len(out) < 2:
        raise UserError(f"directions: {d.tolist()} span a single line and cannot enclose a "
                        "polygon; add at least one direction that is not parallel to it")
    return np.array(out, np.int64)


def _as_polygon(vertices) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or not np.isfinite(v).all():
        raise UserError(f"vertices: expected a finite (k, 2) array, got shape {v.shape}; pass one "
                        "(x, y) row per vertex")
    v = v[np.any(v != np.roll(v, 1, axis=0), axis=1)] if len(v) > 1 else v
    if len(v) < 3:
        raise UserError(f"vertices: a polygon needs 3 or more distinct vertices, got {len(v)}")
    if not shapely.LinearRing(v).is_simple:
        raise UserError("vertices: the polygon intersects itself; pass a simple polygon (edges "
                        "meet only at shared vertices), e.g. order the vertices along the outline")
    if shapely.Polygon(v).area <= 1e-12 * np.ptp(v, axis=0).max() ** 2:
        raise UserError("vertices: the polygon has zero area; pass a proper outline")
    return v


def _candidates(v: np.ndarray, travel: np.ndarray):
    """Candidate edges (vertex, travel direction) sorted by vertex, then turning angle."""
    e_in = v - np.roll(v, 1, axis=0)
    e_out = np.roll(v, -1, axis=0) - v
    t = travel.astype(np.float64)
    left_in = t[None, :, 0] * -e_in[:, None, 1] - t[None, :, 1] * -e_in[:, None, 0]
    left_out = t[None, :, 0] * e_out[:, None, 1] - t[None, :, 1] * e_out[:, None, 0]
    ii, tt = np.nonzero((left_in >= -graph.TOL) & (left_out >= -graph.TOL))
    heading = np.arctan2(e_in[ii, 1], e_in[ii, 0])
    ang = (np.arctan2(t[tt, 1], t[tt, 0]) - heading + 1e-12) % (2 * np.pi) - 1e-12
    turn = (np.arctan2(e_out[ii, 1], e_out[ii, 0]) - heading + 1e-12) % (2 * np.pi) - 1e-12
    ok = ang <= turn + 1e-12                 # t lies between the incoming and outgoing edges
    ii, tt, ang = ii[ok], tt[ok], ang[ok]
    order = np.lexsort((ang, ii))
    return ii[order].astype(np.int64), tt[order].astype(np.int64)


def rectify(vertices, directions, max_edges: int) -> Rectified:
    """Minimum-area enclosing polygon whose edges lie along ``directions`` (MHU21 section 4).

    Parameters
    ----------
    vertices : array_like, shape (k, 2)
        A simple polygon, convex or concave, either orientation, any units.
    directions : array_like of int, shape (m, 2)
        The set D of edge directions as (run, rise) pairs; each also allows its opposite.
    max_edges : int
        N, the most edges the result may have (>= 3).

    Returns
    -------
    Rectified
        The best polygon with at most N edges (fewest edges among equal areas) and timings.

    Raises
    ------
    UserError
        Self-intersecting or degenerate input, D of a single line, N < 3, or N smaller than
        any enclosing polygon with edges in D needs (the message gives the smallest N).
    """
    if int(max_edges) != max_edges or max_edges < 3:
        raise UserError(f"max_edges: {max_edges!r} is not an integer >= 3; pass N >= 3")
    max_edges = int(max_edges)
    v_in = _as_polygon(vertices)
    dirs = normalize_directions(directions)
    flip = shapely.Polygon(v_in).exterior.is_ccw is False
    index = np.arange(len(v_in))[::-1] if flip else np.arange(len(v_in))
    poly = shapely.Polygon(v_in)
    centre = np.array(poly.centroid.coords[0])
    radius = float(np.linalg.norm(v_in - centre, axis=1).max())
    v = (v_in[index] - centre) / radius
    travel = np.concatenate([dirs, -dirs])

    t0 = time.perf_counter()
    cand_v, cand_d = _candidates(v, travel)
    cand_t = travel[cand_d].astype(np.float64)
    fwd, bwd = graph.free_lengths(v, cand_v, cand_t)
    src, dst, xy, weight = graph.transitions(v, cand_v, cand_t, fwd, bwd)
    t1 = time.perf_counter()
    cycle, by_edges = _traverse(len(cand_v), src, dst, weight, max_edges)
    t2 = time.perf_counter()
    if cycle is None:
        enough = max(2 * len(dirs), max_edges + 1) + 8
        smallest = _traverse(len(cand_v), src, dst, weight, enough)[0]
        hint = f"the smallest feasible N is {len(smallest)}" if smallest else "no N found"
        raise UserError(f"max_edges: N={max_edges} is too small to enclose this polygon with "
                        f"edges along {dirs.tolist()}; {hint}")
    corners = xy[cycle]                                   # corner k ends edge cand[dst[cycle[k-1]]]
    edges = dst[np.roll(cycle, 1)]
    out = np.roll(corners, 1, axis=0) * radius + centre
    if not shapely.Polygon(out).is_valid:      # pockets of a very convoluted outline overlapped
        raise UserError("vertices: the best polygon for this outline intersects itself; "
                        "simplify the outline or allow more edges (max_edges) or directions")
    area_scale = radius ** 2
    return Rectified(
        vertices=out, directions=travel[cand_d[edges]], touch=index[cand_v[edges]],
        area=float(shapely.Polygon(out).area), input_area=float(poly.area),
        area_by_edges=by_edges * area_scale + poly.area, construction_s=t1 - t0,
        traversal_s=t2 - t1, n_candidates=int(len(cand_v)), n_transitions=int(len(src)),
        centre=centre, circumradius=radius)


def _traverse(n_cand: int, src, dst, weight, max_edges: int):
    """Cheapest cycle once around (list of transition indices, in order) and areas by edge count."""
    by_edges = np.full(max_edges + 1, np.inf)
    if len(src) == 0:
        return None, by_edges
    diff = np.zeros(n_cand + 1, np.int64)                # transitions covering each cut
    wrap = dst <= src
    np.add.at(diff, src + 1, 1)
    np.add.at(diff, np.where(wrap, n_cand, dst + 1), -1)
    np.add.at(diff, np.zeros(wrap.sum(), np.int64), 1)
    np.add.at(diff, dst[wrap] + 1, -1)
    cut = int(np.argmin(np.cumsum(diff)[:n_cand]))
    s, d = (src - cut) % n_cand, (dst - cut) % n_cand
    crossing = np.flatnonzero(d < s)
    fwd = np.flatnonzero(d > s)
    fwd = fwd[np.argsort(s[fwd], kind="stable")]
    out_start = np.searchsorted(s[fwd], np.arange(n_cand + 1))
    best, choice = (np.inf, 0), None
    for start in np.unique(d[crossing]):
        cost, pred = graph.cycle_dp(n_cand, start, s[fwd], d[fwd], weight[fwd], out_start,
                                    max_edges - 1)
        for x in crossing[d[crossing] == start]:
            total = cost[:, s[x]] + weight[x]                 # n forward steps -> n + 1 edges
            np.minimum(by_edges[1:], total, out=by_edges[1:])
            n = int(np.flatnonzero(total <= total.min() + 1e-12)[0])  # fewest edges of equals
            if total[n] < best[0] - 1e-12 or (total[n] <= best[0] + 1e-12 and n < best[1]):
                best, choice = (total[n], n), (x, n, pred)
    if choice is None:
        return None, by_edges
    x, n, pred = choice
    path, node = [x], s[x]
    for step in range(n, 0, -1):
        e = pred[step, node]
        path.append(fwd[e])
        node = s[fwd[e]]
    return path[::-1], by_edges
