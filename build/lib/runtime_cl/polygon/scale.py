"""Radius -> integer polygon as a table: scale_polygon's DP in OpenCL plus an envelope search.

Per pixel the runtime needs :func:`runtime_cl.polygon.kernel.scale_polygon` at that pixel's
radius. Its dynamic programme (~10^4-10^5 steps) is far too slow to run per pixel, but its result
is piecewise constant in the radius, so :class:`ScaleTable` finds the float32 radii where it
changes once per shape and the splatting kernel looks the polygon up by binary search.

How the table is found
----------------------
* ``kernels/polygon/scale.cl`` runs the DP for a batch of radii, mirroring the numpy code
  operation by operation (``rint`` = numpy's round-half-even, no fused multiply-adds, first
  index on ties), so :class:`ScaleOracle` returns exactly what ``scale_polygon`` returns (tested
  on thousands of radii).
* Between two consecutive radii where some ``rint(radius * v)`` changes (a *rounding interval*)
  the candidate set is fixed and every candidate's cost ``sum |w_k - r v_k|^2`` is, up to a term
  common to all, linear in ``r``: the DP returns the lower envelope of a fixed set of lines.
  The search probes both ends of every rounding interval and, where they differ, the crossing of
  the two lines; a probe that finds a third, lower line splits the interval. Each switch is then
  placed on the exact float32 where the DP's answer changes (probing the neighbouring floats).

Ties. Where two candidates cost the same up to float64 rounding (mirror-image polygons of a
symmetric shape, e.g. the star at r ~ 11.4 px), ``scale_polygon``'s answer flips with the last bit
of the costs, hundreds of times per pixel of radius. No finite table can follow that; the table
keeps the polygon it already has while it stays within ``TOLERANCE`` (px^2) of the optimum, so
there it returns one of the tied optima. Elsewhere it equals ``scale_polygon`` for every float32
radius (the tests check the regular shapes on random radii and at every switch).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime_cl.device.opencl import get_device
from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import _simplify, scale_polygon

__all__ = ["ScaleOracle", "ScaleTable", "TOLERANCE"]

TOLERANCE = 1e-9   # px^2: costs closer than this are ties
MAX_WINDOW = 5     # scale_polygon's largest candidate window (range(2, 6))
BATCH = 8192       # radii per oracle launch at most
LOCAL = 8          # fixed work-group size (PoCL compiles once per size)
SCRATCH_BYTES = 64 << 20  # global scratch per launch


class ScaleOracle:
    """``scale_polygon(vertices, directions, r)`` for many radii at once, on the OpenCL device.

    Parameters
    ----------
    vertices, directions : array_like, shape (n, 2)
        The unit polygon and its edge directions, as for ``scale_polygon``.
    device : runtime_cl.device.opencl.Device, optional
    """

    def __init__(self, vertices, directions, device=None):
        scale_polygon(vertices, directions, 0.0)  # same validation, same messages
        self.vertices = np.ascontiguousarray(vertices, np.float64)
        self.directions = np.ascontiguousarray(directions, np.int32)
        self.device = device or get_device()
        import pyopencl as cl

        self.cl = cl
        mf = cl.mem_flags
        ctx = self.device.context
        self._v = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.vertices)
        self._d = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.directions)
        self._kernels = {}

    def _kernel(self, window: int):
        """(kernel, scratch bytes per radius) for one candidate window."""
        if window not in self._kernels:
            n, ns = len(self.vertices), (2 * window + 1) ** 2
            scratch = -(-(n * ns * (8 + 4 + 4 + 2)) // 8) * 8
            prg, _ = self.device.program("polygon/scale.cl", [f"-DNV={n}", f"-DWINDOW={window}",
                                                              f"-DSCRATCH={scratch}"])
            self._kernels[window] = (self.cl.Kernel(prg, "scale_dp"), scratch)
        return self._kernels[window]

    def raw(self, radii) -> np.ndarray:
        """Chosen vertices before simplification, int64 (len(radii), n, 2)."""
        cl = self.cl
        mf = cl.mem_flags
        ctx, queue = self.device.context, self.device.queue
        r = np.ascontiguousarray(radii, np.float64).ravel()
        n = len(self.vertices)
        out = np.zeros((r.size, n, 2), np.int64)
        done = np.zeros(r.size, bool)
        for window in range(2, MAX_WINDOW + 1):
            todo = np.flatnonzero(~done)
            if todo.size == 0:
                break
            kernel, scratch = self._kernel(window)
            batch = max(LOCAL, min(BATCH, SCRATCH_BYTES // scratch) // LOCAL * LOCAL)
            scratch_buf = cl.Buffer(ctx, mf.READ_WRITE, scratch * batch)
            for s in range(0, todo.size, batch):
                idx = todo[s:s + batch]
                rr = np.ascontiguousarray(r[idx])
                w = np.empty((idx.size, n, 2), np.int32)
                ok = np.empty(idx.size, np.int32)
                rb = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=rr)
                wb = cl.Buffer(ctx, mf.WRITE_ONLY, w.nbytes)
                ob = cl.Buffer(ctx, mf.WRITE_ONLY, ok.nbytes)
                size = -(-idx.size // LOCAL) * LOCAL
                kernel(queue, (size,), (LOCAL,), self._v, self._d, rb, np.int32(idx.size), wb, ob,
                       scratch_buf)
                cl.enqueue_copy(queue, w, wb)
                cl.enqueue_copy(queue, ok, ob)
                out[idx] = w
                done[idx] = ok != 0
        if not done.all():
            raise InputError(f"vertices: no integer polygon with these edge directions fits near "
                             f"radius {r[~done][0]}; the unit polygon is degenerate")
        return out

    def __call__(self, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Same as ``scale_polygon(vertices, directions, radius)``."""
        return _simplify(self.raw([radius])[0])


@dataclass(frozen=True)
class ScaleTable:
    """Integer polygons of a unit polygon for every float32 radius in ``[0, max_radius]``.

    Attributes
    ----------
    breaks : ndarray of float32, shape (m,)
        ``breaks[0] == 0``; polygon ``i`` serves radii ``breaks[i] <= r < breaks[i + 1]``.
    polygons : list of ndarray of int64
        Simplified vertices per entry (``scale_polygon``'s first return value).
    raw : ndarray of int64, shape (m, n, 2)
        The DP's vertices per entry, in unit-vertex order.
    max_radius : float
        Largest radius covered (a float32 value).
    probes : int
        Radii the oracle evaluated to build the table.
    """

    breaks: np.ndarray
    polygons: list
    raw: np.ndarray
    max_radius: float
    probes: int

    def index(self, radius) -> np.ndarray:
        """Entry index for float32 radii (as the kernel computes it)."""
        r = np.asarray(radius, np.float32)
        return np.searchsorted(self.breaks, r, side="right") - 1

    def polygon(self, radius: float) -> np.ndarray:
        """Integer vertices used at ``radius`` (rounded to float32)."""
        return self.polygons[int(self.index(radius))]

    @classmethod
    def build(cls, oracle: ScaleOracle, max_radius: float) -> "ScaleTable":
        """Find every switch of ``oracle`` over ``[0, max_radius]`` (see the module docstring)."""
        if not (np.isfinite(max_radius) and max_radius >= 0):
            raise InputError(f"max_radius: {max_radius!r} is not a finite number >= 0")
        return _Search(oracle, float(np.float32(max_radius))).run()


def _f32_next(x, n=1):
    x = np.asarray(x, np.float32)
    for _ in range(abs(n)):
        x = np.nextafter(x, np.float32(np.inf if n > 0 else -np.inf), dtype=np.float32)
    return x


def _rounding_switches(v: np.ndarray, r_max: float) -> np.ndarray:
    """Float32 radii where some ``rint(r * v[k, c])`` changes, in (0, r_max]."""
    c = np.abs(v.ravel())
    c = c[c > 0]
    counts = np.floor(r_max * c + 0.5).astype(np.int64)
    comp = np.repeat(c, counts)
    m = np.concatenate([np.arange(k) for k in counts]) if counts.sum() else np.zeros(0)
    guess = np.float32((m + 0.5) / comp) if comp.size else np.zeros(0, np.float32)
    offs = np.arange(-16, 17)
    cand = np.stack([_f32_next(guess, int(o)) if o else guess for o in offs], axis=1)
    val = np.rint(cand.astype(np.float64) * comp[:, None])
    change = val != val[:, :1]
    if not change.any(axis=1).all() or (val[:, :1] == val[:, -1:]).any():
        raise RuntimeError("rounding switch not bracketed; widen the search")  # pragma: no cover
    out = cand[np.arange(cand.shape[0]), np.argmax(change, axis=1)]
    return np.unique(out[(out > 0) & (out <= np.float32(r_max))])


class _Search:
    """The envelope search of :meth:`ScaleTable.build`."""

    def __init__(self, oracle: ScaleOracle, r_max: float):
        self.oracle, self.r_max = oracle, r_max
        self.v = oracle.vertices
        self.probes = 0
        self.keys = {}

    def eval(self, radii) -> np.ndarray:
        r = np.asarray(radii, np.float32).astype(np.float64)
        self.probes += r.size
        return self.oracle.raw(r) if r.size else np.zeros((0, len(self.v), 2), np.int64)

    def cost(self, w: np.ndarray, r) -> np.ndarray:
        r = np.asarray(r, np.float64)
        return (((w - r[..., None, None] * self.v) ** 2).sum(-1)).sum(-1)

    def key(self, w: np.ndarray) -> bytes:
        """The simplified polygon (what the table stores), memoised on the raw vertices."""
        raw = w.tobytes()
        if raw not in self.keys:
            self.keys[raw] = _simplify(w)[0].tobytes()
        return self.keys[raw]

    def run(self) -> ScaleTable:
        starts = np.concatenate([[np.float32(0)], _rounding_switches(self.v, self.r_max)])
        ends = np.concatenate([_f32_next(starts[1:], -1), [np.float32(self.r_max)]])
        w_lo, w_hi = self.eval(starts), self.eval(ends)
        pieces = [(float(s), w) for s, w in zip(starts, w_lo)]   # (from radius, polygon)
        todo = [(float(lo), float(hi), a, b) for lo, hi, a, b in zip(starts, ends, w_lo, w_hi)
                if lo < hi and self.switches(a, b, hi)]
        while todo:
            todo = self.round(todo, pieces)
        pieces.sort(key=lambda p: p[0])
        breaks, polys, raws, last = [], [], [], None
        for start, w in pieces:
            k = self.key(w)
            if k != last:
                breaks.append(start)
                polys.append(_simplify(w)[0])
                raws.append(w)
                last = k
        return ScaleTable(np.asarray(breaks, np.float32), polys, np.asarray(raws, np.int64),
                          self.r_max, self.probes)

    def switches(self, a, b, r) -> bool:
        """Whether polygon ``a`` (optimal at the left) must give way to ``b`` (optimal at ``r``)."""
        return self.key(a) != self.key(b) and self.cost(a, r) > self.cost(b, r) + TOLERANCE

    def round(self, todo, pieces):
        """One batch of probes: crossing points of every pending segment."""
        probes = []
        for lo, hi, a, b in todo:
            alpha = float((a * a).sum() - (b * b).sum())
            beta = float(-2.0 * ((a - b) * self.v).sum())
            x = -alpha / beta if beta != 0 else (lo + hi) / 2
            xf = np.float32(min(max(x, lo), hi))
            if xf <= np.float32(lo):
                xf = _f32_next(np.float32(lo))
            probes.append(min(xf, np.float32(hi)))
        found = self.eval(probes)
        nxt, switches = [], []
        for (lo, hi, a, b), xf, w in zip(todo, probes, found):
            xf = float(xf)
            floor = min(self.cost(a, xf), self.cost(b, xf))
            if xf == hi or self.cost(w, xf) >= floor - TOLERANCE:
                switches.append((lo, hi, a, b, xf))
                continue
            pieces.append((xf, w))     # a new, lower line: split
            if self.switches(a, w, xf):
                nxt.append((lo, xf, a, w))
            if self.switches(w, b, hi):
                nxt.append((xf, hi, w, b))
        self.place(switches, pieces)
        return nxt

    def place(self, switches, pieces):
        """Put each switch on the float32 where the DP's answer becomes the right polygon."""
        offs = np.arange(-3, 4)
        radii = [_f32_next(np.float32(x), int(o)) if o else np.float32(x)
                 for (*_, x) in switches for o in offs]
        found = self.eval(radii).reshape(len(switches), len(offs), -1, 2) if switches else []
        for (lo, hi, a, b, x), ws in zip(switches, found):
            rs = [float(_f32_next(np.float32(x), int(o)) if o else np.float32(x)) for o in offs]
            kb = self.key(b)
            at = x
            for r, w in zip(reversed(rs), reversed(list(ws))):
                if not (lo < r <= hi) or self.key(w) != kb:
                    break
                at = r
            pieces.append((at, b))
