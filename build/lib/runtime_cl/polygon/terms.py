"""Differenced terms of one integer polygon in O(vertices), and its exact pixel count.

:func:`runtime_cl.polygon.kernel.differenced_kernel` is the O(area) definition; the runtime needs
the terms of hundreds of polygons up to radius ~200 (one per radius interval of a
:class:`runtime_cl.polygon.scale.ScaleTable`), so this module writes them down from the edges.
Any split of the vertical difference ``K1`` into directions reconstructs ``K`` exactly (eq. 9-11),
so the terms need not equal ``differenced_kernel``'s one by one; they are checked against the
brute-force rasteriser in ``tests/runtime_cl/test_polygon_terms.py``.

Construction (simple polygons; others go to ``differenced_kernel``)
------------------------------------------------------------------
With ``s`` the sign of the shoelace sum (``y`` down), a non-vertical edge is a *top* edge when
``sign(ex) == s`` (the inside lies below it) and a *bottom* edge otherwise. In a column ``x`` that
holds no vertex, a simple closed polygon meets the column in disjoint closed intervals from a top
crossing ``yt`` to a bottom crossing ``yb``; the pixels ``ceil(yt) .. floor(yb)`` are inside, so
``K1`` is ``+1`` at ``ceil(yt)`` and ``-1`` at ``floor(yb) + 1`` (an interval holding no pixel
centre gives two cancelling terms). Along an edge of direction ``(a, b)`` these positions repeat
with period ``(a, b)``, so over the edge's half-open column range ``[min x, max x)`` (``m`` periods)
the directional difference leaves ``a`` terms at the start and ``a`` opposite terms ``m (a, b)``
further on: ``2 a`` terms per edge, MHU21's count.

Columns through a vertex (turning points, vertical edges, several edges meeting) are solved
exactly: the column's closed intervals from the rational crossings and the winding number of
each gap, minus what the edge terms already put there. The remainder is a handful of ``K1`` terms,
each stored as ``+c`` at ``(x, y)`` and ``-c`` at ``(x, y) + d`` in a direction buffer ``d`` that
already holds ``-c`` at ``(x, y)`` when there is one (the edge then simply extends one column).

The pixel count (the kernel's area, its normalisation) is Pick's theorem for simple polygons,
``interior + boundary = (2A + B) / 2 + 1`` with ``2A`` the absolute shoelace sum and ``B`` the
boundary lattice points, and the rasterised sum otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from math import ceil, floor, gcd

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import (DifferencedKernel, differenced_kernel, edge_direction,
                             rasterize_polygon)

__all__ = ["PolygonTerms", "polygon_terms", "is_simple", "to_differenced_kernel"]


@dataclass(frozen=True)
class PolygonTerms:
    """Sparse directional differences of one rasterised polygon and its pixel count.

    Attributes
    ----------
    direction, dx, dy, value : ndarray of int32, shape (nnz,)
        Index into the direction list, pixel offset (``dy`` down) and integer value per term,
        sorted by direction, then ``dy``, then ``dx``.
    area : int
        Pixels whose centre lies in the closed polygon (the rasterised kernel's sum).
    simple : bool
        Whether the O(vertices) construction was used (else ``differenced_kernel``).
    """

    direction: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    value: np.ndarray
    area: int
    simple: bool

    @property
    def nnz(self) -> int:
        """Number of terms."""
        return int(self.value.size)


def _cross(ox, oy, ax, ay, bx, by) -> int:
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


def _segments_touch(p, q, r, s) -> bool:
    """Whether closed integer segments ``pq`` and ``rs`` share a point."""
    d1, d2 = _cross(*r, *s, *p), _cross(*r, *s, *q)
    d3, d4 = _cross(*p, *q, *r), _cross(*p, *q, *s)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True

    def on(a, b, c):  # c on segment ab, given collinear
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    return ((d1 == 0 and on(r, s, p)) or (d2 == 0 and on(r, s, q))
            or (d3 == 0 and on(p, q, r)) or (d4 == 0 and on(p, q, s)))


def is_simple(vertices) -> bool:
    """Whether the closed integer polygon is simple: >= 3 distinct vertices, non-zero area, edges
    meeting only at the vertex two neighbours share (no spikes, touching or crossing)."""
    v = [tuple(int(c) for c in p) for p in np.asarray(vertices, np.int64)]
    n = len(v)
    if n < 3 or len(set(v)) != n:
        return False
    edges = [(v[i], v[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        (p, q), (_, r) = edges[i], edges[(i + 1) % n]
        if _cross(*p, *q, *r) == 0 and (q[0] - p[0]) * (r[0] - q[0]) + (q[1] - p[1]) * (r[1] - q[1]) < 0:
            return False  # the next edge folds back over this one
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            if _segments_touch(*edges[i], *edges[j]):
                return False
    twice_area = sum(p[0] * q[1] - q[0] * p[1] for p, q in edges)
    return twice_area != 0


def _edge_rows(top: bool, ly: int, j: int, a: int, b: int) -> int:
    """Row of the K1 term of an edge ``j`` columns right of its left end ``(., ly)``."""
    return ly - ((-j * b) // a) if top else ly + (j * b) // a + 1


def _column_k1(v: list, x: int) -> dict:
    """Exact vertical difference of the closed polygon's indicator in column ``x``."""
    n = len(v)
    points, spans, crossings = set(), [], []
    for i in range(n):
        (px, py), (qx, qy) = v[i], v[(i + 1) % n]
        if px == qx:
            if px == x:
                spans.append((min(py, qy), max(py, qy)))
                points.update((Fraction(py), Fraction(qy)))
            continue
        if min(px, qx) <= x <= max(px, qx):
            y = Fraction(py * (qx - px) + (x - px) * (qy - py), qx - px)
            points.add(y)
            if min(px, qx) <= x < max(px, qx):
                crossings.append((y, 1 if qx > px else -1))
    ys = sorted(points)
    out: dict = {}
    lo = None
    for i, y in enumerate(ys):
        if lo is None:
            lo = y
        if i + 1 < len(ys):
            nxt = ys[i + 1]
            winding = sum(s for yc, s in crossings if yc <= y)
            covered = any(s0 <= y and nxt <= s1 for s0, s1 in spans)
            if winding != 0 or covered:
                continue
        top, bottom = ceil(lo), floor(y) + 1
        out[top] = out.get(top, 0) + 1
        out[bottom] = out.get(bottom, 0) - 1
        lo = None
    return {y: c for y, c in out.items() if c}


def polygon_terms(vertices, directions) -> PolygonTerms:
    """Directional differences (MHU21 eq. 1-5) of the rasterised polygon, O(vertices) if simple.

    Parameters
    ----------
    vertices : array_like of int, shape (n, 2)
        Integer vertices (pixel offsets, ``y`` down), either orientation, as returned by
        :func:`runtime_cl.polygon.kernel.scale_polygon`.
    directions : array_like of int, shape (m, 2)
        The buffer directions ``(a, b)``, ``a >= 1``, primitive; every non-vertical edge must run
        along one of them.

    Returns
    -------
    PolygonTerms
    """
    dirs = [tuple(int(c) for c in d) for d in np.asarray(directions, np.int64).reshape(-1, 2)]
    if not dirs or any(a < 1 or gcd(a, b) != 1 for a, b in dirs):
        raise InputError(f"directions: {dirs} must be primitive (a >= 1, b) pairs; normalise them "
                         "with runtime_cl.polygon.kernel.edge_direction")
    w = np.asarray(vertices, np.int64).reshape(-1, 2)
    if not is_simple(w):
        return _fallback(w, dirs)
    v = [(int(x), int(y)) for x, y in w]
    n = len(v)
    twice = sum(v[i][0] * v[(i + 1) % n][1] - v[(i + 1) % n][0] * v[i][1] for i in range(n))
    orient = 1 if twice > 0 else -1
    terms: dict = {}

    def add(k, x, y, c):
        key = (k, x, y)
        terms[key] = terms.get(key, 0) + c

    edge_k1 = []  # (lx, rx, top, ly, a, b) for evaluating edge terms in vertex columns
    boundary = 0
    for i in range(n):
        (px, py), (qx, qy) = v[i], v[(i + 1) % n]
        ex, ey = qx - px, qy - py
        boundary += gcd(abs(ex), abs(ey))
        if ex == 0:
            continue
        a, b = edge_direction(ex, ey)
        if (a, b) not in dirs:
            raise InputError(f"directions: edge {v[i]} -> {v[(i + 1) % n]} runs along {(a, b)}, "
                             f"not in {dirs}; pass every non-vertical edge direction")
        k = dirs.index((a, b))
        lx, ly = (px, py) if ex > 0 else (qx, qy)
        periods = abs(ex) // a
        top = (1 if ex > 0 else -1) == orient
        sign = 1 if top else -1
        for j in range(a):
            y = _edge_rows(top, ly, j, a, b)
            add(k, lx + j, y, sign)
            add(k, lx + j + periods * a, y + periods * b, -sign)
        edge_k1.append((lx, lx + periods * a, top, ly, a, b))

    fix_dir = min(range(len(dirs)), key=lambda k: (dirs[k][0], abs(dirs[k][1])))
    for x in sorted({p[0] for p in v}):
        want = _column_k1(v, x)
        for lx, rx, top, ly, a, b in edge_k1:
            if lx <= x < rx:
                y = _edge_rows(top, ly, x - lx, a, b)
                want[y] = want.get(y, 0) - (1 if top else -1)
        for y, c in sorted(want.items()):
            if c == 0:
                continue
            k = next((k for k in range(len(dirs)) if terms.get((k, x, y), 0) == -c), fix_dir)
            add(k, x, y, c)
            add(k, x + dirs[k][0], y + dirs[k][1], -c)

    keys = sorted((k, y, x) for (k, x, y), c in terms.items() if c)
    arr = np.array([(k, x, y, terms[(k, x, y)]) for k, y, x in keys], np.int64).reshape(-1, 4)
    area = (abs(twice) + boundary) // 2 + 1
    return PolygonTerms(*(arr[:, i].astype(np.int32) for i in range(4)), area=int(area), simple=True)


def _fallback(w: np.ndarray, dirs: list) -> PolygonTerms:
    """Degenerate or self-touching polygons: the O(area) definition and the rasterised sum."""
    dk = differenced_kernel(w, dirs)
    kdir = np.repeat(np.arange(len(dk.directions)), np.diff(dk.start))
    index = [dirs.index(tuple(int(c) for c in d)) for d in dk.directions]
    kdir = np.asarray(index, np.int64)[kdir] if len(index) else kdir
    order = np.lexsort((dk.dx, dk.dy, kdir))
    area = int(rasterize_polygon(w)[0].sum())
    return PolygonTerms(kdir[order].astype(np.int32), dk.dx[order], dk.dy[order], dk.value[order],
                        area=area, simple=False)


def to_differenced_kernel(terms: PolygonTerms, directions) -> DifferencedKernel:
    """The terms as a :class:`DifferencedKernel` (for :func:`~runtime_cl.polygon.kernel.reconstruct`)."""
    dirs = np.asarray(directions, np.int32).reshape(-1, 2)
    order = np.argsort(terms.direction, kind="stable")
    start = np.searchsorted(terms.direction[order], np.arange(len(dirs) + 1)).astype(np.int64)
    return DifferencedKernel(dirs, start, terms.dx[order], terms.dy[order], terms.value[order])
