"""Directionally differenced kernels of flat polygons (MHU21 section 5.1), numpy only.

The kernel definition the runtime mirrors
-----------------------------------------
Coordinates are pixel offsets ``(dx, dy)`` from the splatted pixel, ``dx`` along image columns
(right), ``dy`` along image rows (down). A polygon has integer vertices (:func:`scale_polygon`
makes them from a unit polygon and any real radius >= 0, keeping its edge directions exactly);
pixel centres are the integer points.

* **Rasterisation** ``K``: a pixel belongs to the kernel iff its centre lies in the *closed*
  polygon: on an edge or vertex (ties on edges are always inside), or of non-zero winding number.
  Radius 0 collapses every vertex to ``(0, 0)``: ``K`` is the delta, so splatting is the identity.
* **Vertical difference** ``K1(x, y) = K(x, y) - K(x, y - 1)`` (MHU21 eq. 2): +1 where a column
  enters the kernel, -1 one row below where it leaves.
* **Grouping** (eq. 3): each non-zero of ``K1`` goes to the direction ``d = (a, b)`` (primitive,
  ``a >= 1``) of the non-vertical edge that crosses its column between the two rows it compares,
  preferring an edge with the inside below it for +1 (above it for -1), then the first in
  polygon order (at a vertex both edges cross); if none crosses (radius <= 1 degeneracies) the
  nearest edge. Any grouping reconstructs exactly; this one leaves ``2 a`` non-zeros per edge of
  ``a`` or more columns, whatever its length (MHU21 Fig. 5), so the count is constant in r.
* **Directional difference** (eq. 5): ``K2_d(p) = K1_d(p) - K1_d(p - d)``. Values are small
  integers (+-1, rarely +-2); :class:`DifferencedKernel` stores them sparsely per direction.

Reconstruction (eq. 9-11, :func:`reconstruct`): per direction the prefix sum
``S_d(p) = S_d(p - d) + K2_d(p)`` running towards +x, then the sum over directions, then the
vertical prefix sum ``K(x, y) = K(x, y - 1) + S(x, y)`` running down the rows. Both sums start
from zero outside the support, so a runtime must sum over buffers that contain every splatted
term: pad the image by the support (:attr:`DifferencedKernel.bounds`: ``x`` from ``-R`` to
``R + max a``, ``y`` from ``-R + min b`` to ``R + 1 + max b`` for a kernel within radius ``R``);
a kernel larger than the image is fine then, and terms must never be clipped before summing.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import gcd

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["DifferencedKernel", "differenced_kernel", "scale_polygon", "rasterize_polygon",
           "directional_prefix_sum", "reconstruct", "edge_direction"]


def edge_direction(vx: int, vy: int) -> tuple[int, int]:
    """Primitive direction of the integer vector ``(vx, vy)``: ``a >= 1``, or ``(0, 1)``."""
    g = gcd(int(vx), int(vy))
    if g == 0:
        raise InputError("edge_direction: the vector (0, 0) has no direction; drop the empty edge")
    a, b = int(vx) // g, int(vy) // g
    return (a, b) if a > 0 or (a == 0 and b > 0) else (-a, -b)


def _integer_vertices(vertices, name: str = "vertices") -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) == 0 or not np.isfinite(v).all():
        raise InputError(f"{name}: expected a finite (n, 2) array of pixel positions, got shape "
                         f"{v.shape}; pass one (x, y) row per vertex")
    if np.any(v != np.round(v)):
        bad = v[v != np.round(v)][:3]
        raise InputError(f"{name}: vertices must be integer pixel positions, got {bad}; scale "
                         "the unit polygon with scale_polygon(...)")
    return v.astype(np.int64)


@dataclass(frozen=True)
class DifferencedKernel:
    """Sparse directional kernel differences ``K2_d`` of one rasterised polygon.

    Attributes
    ----------
    directions : ndarray of int32, shape (n_dir, 2)
        The directions ``d = (a, b)`` with ``a >= 1``, one prefix-sum buffer each.
    start : ndarray of int64, shape (n_dir + 1,)
        Terms of direction ``k`` are ``dx, dy, value`` at ``[start[k], start[k + 1])``.
    dx, dy, value : ndarray of int32
        Offsets (pixels; ``dy`` down) and integer values of the non-zero terms.
    """

    directions: np.ndarray
    start: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    value: np.ndarray

    @property
    def nnz(self) -> int:
        """Number of non-zero terms over all directions (MHU21 Table 1, "Ours")."""
        return int(self.value.size)

    def terms(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(dx, dy, value)`` of direction ``k``."""
        s = slice(int(self.start[k]), int(self.start[k + 1]))
        return self.dx[s], self.dy[s], self.value[s]

    @property
    def bounds(self) -> tuple[int, int, int, int]:
        """``(x_min, x_max, y_min, y_max)`` of all terms (inclusive); (0, 0, 0, 0) if empty."""
        if self.nnz == 0:
            return 0, 0, 0, 0
        return (int(self.dx.min()), int(self.dx.max()), int(self.dy.min()), int(self.dy.max()))


def rasterize_polygon(vertices) -> tuple[np.ndarray, int, int]:
    """Brute-force reference rasterisation: test every pixel centre against every edge.

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Integer vertices ``(x, y)`` in either orientation; ``n = 1`` is a single point.

    Returns
    -------
    K : ndarray of int64, shape (h, w)
        1 where the pixel centre is in the closed polygon (boundary or non-zero winding), else 0.
    x0, y0 : int
        Pixel offset of ``K[0, 0]`` (the polygon's bounding box corner).
    """
    v = _integer_vertices(vertices)
    x0, y0 = v.min(axis=0)
    x1, y1 = v.max(axis=0)
    y, x = np.mgrid[y0:y1 + 1, x0:x1 + 1]
    on_edge = np.zeros(x.shape, bool)
    winding = np.zeros(x.shape, np.int64)
    for (px, py), (qx, qy) in zip(v, np.roll(v, -1, axis=0)):
        cross = (qx - px) * (y - py) - (qy - py) * (x - px)
        inside_box = ((x - px) * (x - qx) <= 0) & ((y - py) * (y - qy) <= 0)
        on_edge |= (cross == 0) & inside_box
        up = (py <= y) & (qy > y) & (cross > 0)      # crossing number with a ray towards +x
        down = (qy <= y) & (py > y) & (cross < 0)
        winding += up.astype(np.int64) - down
    return (on_edge | (winding != 0)).astype(np.int64), int(x0), int(y0)


def _scan_indicator(v: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Same indicator as :func:`rasterize_polygon`, by column scan: O(area), no per-edge pass."""
    x0, y0 = v.min(axis=0)
    x1, y1 = v.max(axis=0)
    h, w = y1 - y0 + 2, x1 - x0 + 1
    delta = np.zeros((h, w), np.int64)
    boundary = np.zeros((h, w), bool)
    for (px, py), (qx, qy) in zip(v, np.roll(v, -1, axis=0)):
        ex, ey = qx - px, qy - py
        g = gcd(int(ex), int(ey))
        k = np.arange(g + 1)
        boundary[py - y0 + k * (ey // max(g, 1)), px - x0 + k * (ex // max(g, 1))] = True
        if ex == 0:
            continue
        sign = 1 if ex > 0 else -1
        xs = np.arange(min(px, qx), max(px, qx))                    # half-open column range
        yfloor = (py * ex + (xs - px) * ey) * sign // (ex * sign)   # floor of the edge's y
        np.add.at(delta, (yfloor + 1 - y0, xs - x0), sign)          # winding changes below it
    winding = np.cumsum(delta, axis=0)[:-1]
    return ((winding != 0) | boundary[:-1]).astype(np.int64), int(x0), int(y0)


def _group(v: np.ndarray, xs, ys, signs, directions) -> np.ndarray:
    """Direction index of each vertical-difference non-zero (see the module docstring)."""
    choice = np.full(xs.size, -1, np.int64)
    nearest = np.zeros(xs.size, np.int64)      # fallback for degenerate (tiny-radius) polygons
    best = np.full(xs.size, np.inf)
    orient = np.sign(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    for same_side_only in (True, False):       # an entry (+1) prefers an edge with the inside below
        for p, q in zip(v, np.roll(v, -1, axis=0)):
            ex, ey = int(q[0] - p[0]), int(q[1] - p[1])
            if ex == 0:
                continue
            k = directions.index(edge_direction(ex, ey))
            n = abs(ex)
            num = (p[1] * ex + (xs - p[0]) * ey) * np.sign(ex)      # edge y at column x, times n
            in_cols = (xs - p[0]) * (xs - q[0]) <= 0
            lo = np.where(signs > 0, (ys - 1) * n < num, (ys - 1) * n <= num)
            hi = np.where(signs > 0, num <= ys * n, num < ys * n)
            side = signs == np.sign(ex) * orient if same_side_only else True
            hit = in_cols & lo & hi & side & (choice < 0)
            choice[hit] = k
            t = np.clip(((xs - p[0]) * ex + (ys - p[1]) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
            dist = np.hypot(p[0] + t * ex - xs, p[1] + t * ey - ys)
            closer = dist < best
            best[closer], nearest[closer] = dist[closer], k
    return np.where(choice >= 0, choice, nearest)


def differenced_kernel(vertices, directions=None) -> DifferencedKernel:
    """Differenced kernels ``K2_d`` of the rasterised polygon (MHU21 eq. 1-5).

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Integer vertices (pixel offsets from the splatted pixel, ``y`` down), closed implicitly,
        either orientation; degenerate polygons (a point, a segment) are allowed.
    directions : array_like, shape (m, 2), optional
        Directions to emit buffers for, in this order (each normalised to ``a >= 1``; vertical
        ones are ignored). Default: the polygon's non-vertical edge directions in edge order.
        Give a fixed set so every radius of one shape uses the same buffers.

    Returns
    -------
    DifferencedKernel
        Terms per direction; a direction without terms has an empty slice.

    Raises
    ------
    InputError
        Non-integer vertices, or an edge direction missing from ``directions``.
    """
    v = _integer_vertices(vertices)
    keep = np.any(v != np.roll(v, 1, axis=0), axis=1)
    v = v[keep] if keep.any() else v[:1]
    edge_dirs = [edge_direction(*(q - p)) for p, q in zip(v, np.roll(v, -1, axis=0))
                 if q[0] != p[0]]
    if directions is None:
        dirs = list(dict.fromkeys(edge_dirs)) or [(1, 0)]
    else:
        dirs = [edge_direction(a, b) for a, b in np.asarray(directions, np.int64).reshape(-1, 2)]
        dirs = [d for d in dict.fromkeys(dirs) if d[0] > 0]
        missing = sorted(set(edge_dirs) - set(dirs))
        if missing or not dirs:
            raise InputError(f"directions: the polygon has edge directions {missing or edge_dirs} "
                             f"not in {dirs}; pass every non-vertical edge direction")
    k_img, x0, y0 = _scan_indicator(v)
    k1 = np.diff(np.pad(k_img, ((1, 1), (0, 0))), axis=0)            # rows y0 .. y1 + 1
    ys, xs = np.nonzero(k1)
    signs = k1[ys, xs]
    xs, ys = xs + x0, ys + y0
    group = _group(v, xs, ys, signs, dirs)
    out_d, starts, out_x, out_y, out_v = [], [0], [], [], []
    for k, (a, b) in enumerate(dirs):
        sel = group == k
        px = np.concatenate([xs[sel], xs[sel] + a])
        py = np.concatenate([ys[sel], ys[sel] + b])
        pv = np.concatenate([signs[sel], -signs[sel]])
        span = 1 << 21                                                # offsets stay < 2**20
        keys, inv = np.unique((px + span // 2) * span + (py + span // 2), return_inverse=True)
        val = np.bincount(inv, weights=pv, minlength=len(keys)).astype(np.int64)
        nz = val != 0
        out_d.append((a, b))
        out_x.append(keys[nz] // span - span // 2)
        out_y.append(keys[nz] % span - span // 2)
        out_v.append(val[nz])
        starts.append(starts[-1] + int(nz.sum()))
    cat = lambda parts: np.concatenate(parts).astype(np.int32)  # noqa: E731
    return DifferencedKernel(np.asarray(out_d, np.int32).reshape(-1, 2),
                             np.asarray(starts, np.int64), cat(out_x), cat(out_y), cat(out_v))


def directional_prefix_sum(values: np.ndarray, direction) -> np.ndarray:
    """``S(x, y) = S(x - a, y - b) + values(x, y)`` over a ``[y, x]`` array, zero outside it.

    Parameters
    ----------
    values : ndarray, shape (h, w)
        Rows are ``y`` (down), columns ``x`` (right).
    direction : (int, int)
        ``(a, b)`` with ``a >= 1``, or ``(0, 1)`` for the vertical prefix sum (MHU21 eq. 10, 11).
    """
    a, b = (int(c) for c in direction)
    out = np.array(values, copy=True)
    if a == 0:
        if b != 1:
            raise InputError(f"direction: {direction!r} is not (0, 1) or (a >= 1, b); normalise it")
        return np.cumsum(out, axis=0)
    if a < 0:
        raise InputError(f"direction: {direction!r} has a < 0; use (-a, -b), the same line")
    h = out.shape[0]
    for x in range(a, out.shape[1]):
        src = out[max(0, -b):h - max(0, b), x - a]
        out[max(0, b):h - max(0, -b), x] += src
    return out


def reconstruct(kernel: DifferencedKernel) -> tuple[np.ndarray, int, int]:
    """Rebuild ``K`` from its differences: eq. 10 per direction, eq. 9's sum, eq. 11.

    Returns
    -------
    K : ndarray of int64, shape (h, w)
        The kernel over the bounding box of all terms.
    x0, y0 : int
        Pixel offset of ``K[0, 0]``.
    """
    x0, x1, y0, y1 = kernel.bounds
    total = np.zeros((y1 - y0 + 1, x1 - x0 + 1), np.int64)
    for k, d in enumerate(kernel.directions):
        dx, dy, val = kernel.terms(k)
        buf = np.zeros_like(total)
        np.add.at(buf, (dy - y0, dx - x0), val)
        total += directional_prefix_sum(buf, d)
    return directional_prefix_sum(total, (0, 1)), x0, y0


def scale_polygon(vertices, directions, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The integer polygon at ``radius`` whose edges keep the unit polygon's exact directions.

    Among integer polygons ``w_0 .. w_{n-1}`` with ``w_{k+1} - w_k = m_k directions[k]``,
    ``m_k >= 0`` integer, it takes the one with least ``sum |w_k - radius * vertices[k]|^2``
    (a dynamic programme over lattice points near each target; ties go to the first
    candidate). Edges of length 0 are dropped, so radius 0 gives the single point (0, 0).

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Unit polygon (pixels per unit radius; ``y`` down), e.g. a rectified shape of
        circumradius 1 centred on the origin.
    directions : array_like of int, shape (n, 2)
        Edge ``k`` runs from vertex ``k`` to ``k + 1`` along ``+directions[k]``.
    radius : float
        Scale in pixels, >= 0.

    Returns
    -------
    vertices : ndarray of int64, shape (m, 2)
    directions : ndarray of int64, shape (m, 2)
        Edge directions of the scaled polygon (primitive; ``m = 1`` and none for a point).
    """
    v = np.asarray(vertices, np.float64)
    d = np.asarray(directions, np.int64)
    if v.ndim != 2 or v.shape[1] != 2 or d.shape != v.shape or len(v) < 3 \
            or not np.isfinite(v).all():
        raise InputError(f"vertices/directions: need matching finite (n >= 3, 2) arrays, got "
                         f"{v.shape} and {d.shape}; pass one direction per edge")
    if not np.isfinite(radius) or radius < 0:
        raise InputError(f"radius: {radius!r} is not a finite number >= 0; pass a radius in pixels")
    edge = np.roll(v, -1, axis=0) - v
    scale = max(np.abs(v).max(), 1e-300)
    off_line = np.abs(edge[:, 0] * d[:, 1] - edge[:, 1] * d[:, 0]) > 1e-6 * scale * np.abs(d).sum(1)
    if off_line.any() or (np.einsum("ij,ij->i", edge, d) < -1e-9 * scale).any():
        raise InputError("directions: some edge does not run along +directions[k]; pass the "
                         "rectified polygon's own edge directions")
    target = radius * v
    for window in range(2, 6):
        steps = np.arange(-window, window + 1)
        grid = np.stack(np.meshgrid(steps, steps), -1).reshape(1, -1, 2)
        cand = np.round(target)[:, None, :] + grid                        # (n, S, 2)
        cost = ((cand - target[:, None, :]) ** 2).sum(-1)                # (n, S)
        allowed = [_steps(cand[k], cand[(k + 1) % len(v)], d[k]) for k in range(len(v))]
        acc = np.where(np.eye(cand.shape[1], dtype=bool), cost[0][:, None], np.inf)  # start, node
        back = []
        for k in range(1, len(v)):
            trial = acc[:, :, None] + np.where(allowed[k - 1], 0.0, np.inf)[None]   # start, i, j
            back.append(trial.argmin(axis=1))
            acc = trial.min(axis=1) + cost[k][None, :]
        close = acc + np.where(allowed[-1], 0.0, np.inf).T                       # (start, last)
        if np.isfinite(close).any():
            s, node = np.unravel_index(np.argmin(close), close.shape)
            path = [node]
            for k in range(len(v) - 2, -1, -1):
                path.append(back[k][s, path[-1]])
            w = cand[np.arange(len(v)), path[::-1]].astype(np.int64)
            return _simplify(w)
    raise InputError("vertices: no integer polygon with these edge directions fits near "
                     f"radius {radius}; the unit polygon is degenerate")


def _steps(a: np.ndarray, b: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``allowed[i, j]``: ``b[j] - a[i]`` is a non-negative integer multiple of ``d``."""
    diff = b[None, :, :] - a[:, None, :]
    cross = diff[..., 0] * d[1] - diff[..., 1] * d[0]
    along = diff[..., 0] * d[0] + diff[..., 1] * d[1]
    return (cross == 0) & (along >= 0) & (along % int(d @ d) == 0)


def _simplify(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop repeated vertices and vertices inside straight runs; report edge directions."""
    keep = np.any(w != np.roll(w, 1, axis=0), axis=1)
    w = w[keep]
    if len(w) <= 1:
        return np.zeros((1, 2), np.int64), np.zeros((0, 2), np.int64)
    changed = True
    while changed and len(w) > 2:
        e_in, e_out = w - np.roll(w, 1, axis=0), np.roll(w, -1, axis=0) - w
        parallel = e_in[:, 0] * e_out[:, 1] == e_in[:, 1] * e_out[:, 0]
        straight = parallel & ((e_in * e_out).sum(1) > 0)
        changed = bool(straight.any())
        if changed:
            w = np.delete(w, np.flatnonzero(straight)[0], axis=0)
    e = np.roll(w, -1, axis=0) - w
    g = np.gcd(e[:, 0], e[:, 1])[:, None]
    return w, e // np.maximum(g, 1)

