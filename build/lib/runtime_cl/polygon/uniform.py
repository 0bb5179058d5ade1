"""Uniform-radius polygonal blur: one kernel launch, all channels at once, exact.

With one kernel for every pixel, MHU21's splat of directional differences (eq. 9) is a gather of
the kernel's few terms (16 for the built-in hexagon, 8 for MHU21's 45-degree one) from the
fixed-point image, and the directional prefix sums (eq. 10), their sum and the vertical prefix
sum (eq. 11) can all run in the same top-down walk over the rows (``kernels/polygon/uniform.cl``):
per row a worker reads the taps, updates each direction's prefix from a ring of the last
``|b|`` rows and the column sums, and writes the colour row. Only the image, a cache-sized
ring of fixed-point rows, one row of state per direction and the output go through memory: no
carries, no per-direction image buffers.

Parallelism: one worker (work item) per compute unit. The workers first share the scan for the
image's largest colour (it sets the fixed-point exponent), then the rows, in sub-bands of
``sub_rows``: a worker sweeps a region of consecutive sub-bands top down, and one with nothing
left takes the bottom half of the largest region (atomics on one word per region). A region
starts from the exact state of the row above it, computed from the same image: each
direction's prefix sum is the image convolved with the directional prefix of that direction's
terms (``itaps``, about the kernel's width), and the column sum is the blurred row itself, from
the kernel's column runs (:func:`column_events`). Both are O(kernel size) per start-up, about
as much as sweeping half the kernel's height of rows. Taking work keeps a worker that starts
late (a busy machine; an unpinned PoCL thread queued behind the other one, see
:func:`runtime_cl.device.opencl.pin_pocl_threads`) from doubling the time, as it did with fixed bands
in about a quarter of the calls at 1024^2 after 10 ms idle.

Exactness: ``q = rint(colour 2^e)`` in int32 with ``2^e max|colour| sum_t |v_t| <= 2^30`` (per
direction), so the gathered differences fit int32 and everything after them is wrapping int64:
the output is the exact integer sum of ``q`` over the kernel (the brute-force splat of
``tests/runtime_cl/polygon_reference.py``), divided by the kernel's pixel count in float64 and
rounded once to float32. Every ``q`` is off by at most half a unit, so an output is off by at
most ``2^-(e+1) <= 2^-(30 - ceil(log2 s))`` of the largest colour, ``s`` the largest
``sum_t |v_t|`` of a direction (``2^-27`` for the built-in hexagon's ``s = 8``; see
:func:`exponent_bits`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from runtime_cl.device.opencl import event_ms
from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import rasterize_polygon
from runtime_cl.polygon.terms import PolygonTerms

__all__ = ["UniformBlur", "exponent_bits", "directional_prefix_taps", "column_events",
           "non_finite_error"]

V = 16   # lanes per vector in the kernel
STREAM_BYTES = 8 << 20   # outputs at least this large are written past the caches


def vectors_per_step(device) -> int:
    """Vectors per step over the image's columns (``-DCH``: the taps' offsets are read once per
    step). Where a 16-lane vector is one register (AVX-512), 2 per step ran 1.3-1.5x faster than
    4 on a Zen 5 (sweep at 1024^2 ... 4096^2, 8 and 16 terms); 4 was tuned on an earlier
    machine and is kept for narrower vectors."""
    return 2 if int(device.native_vector_width_int) >= 16 else 4


def _aligned_empty(shape, dtype, align: int = 64) -> np.ndarray:
    """``np.empty`` starting on a cache line (numpy's own start 16 bytes into one), so the
    kernel can write whole lines without reading them first (non-temporal stores: 7-11 % off
    the uniform blur at 2048^2 and 4096^2 on a Zen 5)."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    raw = np.empty(nbytes + align, np.uint8)
    off = -raw.ctypes.data % align
    return raw[off:off + nbytes].view(dtype).reshape(shape)


def non_finite_error(image: np.ndarray) -> InputError:
    """The error for an image holding NaN or inf colours."""
    return InputError(f"image: {int((~np.isfinite(image)).sum())} non-finite value(s); "
                      "replace NaN/inf colours before blurring")


def exponent_bits(terms: PolygonTerms) -> int:
    """``ceil(log2 s)``, ``s`` the largest ``sum_t |v_t|`` of a direction of ``terms``.

    The kernel (``uniform_sweep``) takes the fixed-point exponent ``e`` from the image's largest
    ``|colour|`` ``peak``: the largest with ``2^e peak < 2^(30 - exponent_bits)``, so every
    direction's gathered sum ``sum_t v_t q`` of ``q = rint(colour 2^e)`` stays within int32
    (``e <= 126``; ``e = 0`` for a black image).
    """
    s = max(int(np.abs(terms.value[terms.direction == k]).sum())
            for k in np.unique(terms.direction))
    return (s - 1).bit_length()


def directional_prefix_taps(dx, dy, value, direction) -> np.ndarray:
    """Non-zeros ``(dx, dy, c)`` of the prefix sum along ``direction = (a, b)`` of sparse terms.

    Terms on one line ``p + i (a, b)`` must sum to zero (true of every direction's terms of a
    kernel), so the prefix has finite support, inside the terms' bounding box.
    """
    a, b = (int(v) for v in direction)
    dx, dy, value = (np.asarray(v, np.int64) for v in (dx, dy, value))
    step = np.floor_divide(dx, a)                       # position along the line
    key = np.stack([dx - step * a, dy - b * step], 1)   # (x mod a, intercept): the line
    out = []
    for line in np.unique(key, axis=0):
        on = np.all(key == line, axis=1)
        pos, val = step[on], value[on]
        order = np.argsort(pos, kind="stable")
        pos, c = pos[order], np.cumsum(val[order])
        if c[-1] != 0:
            raise RuntimeError(f"terms on the line {tuple(line)} of direction {(a, b)} sum to "
                               f"{c[-1]}, not 0: not a kernel's directional differences")
        for s0, s1, cv in zip(pos[:-1], pos[1:], c[:-1]):
            if cv:
                s = np.arange(s0, s1)
                out.append(np.stack([line[0] + s * a, line[1] + b * s, np.full(s.size, cv)], 1))
    return np.concatenate(out) if out else np.zeros((0, 3), np.int64)


def column_events(polygon) -> np.ndarray:
    """The rasterised polygon's columns as events ``(dy, dx, s)`` on sums of its rows taken
    downwards, sorted by ``dy``: each vertical run ``[dy0, dy1]`` of column ``dx`` is ``+1`` at
    ``dy1`` and ``-1`` at ``dy0 - 1``, so the kernel at ``(dx, dy)`` is the sum of ``s`` over
    its column's events at ``dy`` or below."""
    k, x0, y0 = rasterize_polygon(polygon)
    edges = np.diff(np.pad(k, ((1, 1), (0, 0))), axis=0)   # row i: k[i] - k[i - 1]
    ys, xs = np.nonzero(edges)   # +1: a run starts at row i (event at i - 1); -1: one ends at i - 1
    ev = np.stack([ys - 1 + y0, xs + x0, -edges[ys, xs]], 1)
    return ev[np.lexsort((ev[:, 1], ev[:, 0]))].astype(np.int64)


@dataclass(frozen=True)
class _Kernel:
    """Host-side data of one table entry (independent of the image)."""

    terms: PolygonTerms
    init: list            # per direction: (dx, dy, c) of the ring state taps
    events: np.ndarray    # (dy, dx, s): the column sums' start (column_events)


# uniform_sweep's arguments, in the kernel's order
_ARGS = {n: i for i, n in enumerate(
    "image W H LO q QR QL QROW0 QLAST QLANE0 nvec vc0 vc1 out_lanes ctl nslots SUB min_take dirs "
    "tinfo tdx tdy tval n_taps istart itaps events n_events scratch scratch_stride sbits area "
    "out fixed_out fixed stream".split())}
NONFINITE = 0x7FFFFFFF   # the exponent the kernel reports for an image with NaN or inf
PLANS = 8                # (kernel, image shape) set-ups kept
CTL = 5                  # control words before the region slots (see uniform_sweep)


@dataclass(frozen=True)
class _Plan:
    """Everything of a call that depends only on the kernel and the image's shape: a
    ``uniform_sweep`` kernel object with those arguments set, and the buffers they name."""

    kernel: object
    workers: int
    ctl: np.ndarray       # the kernel's control words at the start (see uniform_sweep)
    q_bytes: int
    scratch_bytes: int
    area: int
    tables: tuple         # uploaded tables (the kernel's arguments hold no reference)


class UniformBlur:
    """Blur by one polygon for every pixel, exactly (see the module docstring).

    Parameters
    ----------
    splatter : runtime_cl.polygon.splat.PolygonSplatter
        Supplies the device, the edge directions and the radius table (the same polygons,
        terms and pixel counts as its radius-map path).
    sub_rows : int, default 16
        Rows per sub-band, the unit the workers claim and share (see ``kernels/
        polygon/uniform.cl``).
    regions : int, default 1
        Regions of sub-bands at the start, region ``i`` for worker ``i`` (one per compute unit);
        workers without work take the bottom half of the largest region left. More regions
        than workers test the taking; one lets the workers split the image as they arrive.
    min_take : int or None, default None
        Fewest rows a worker takes from another's region (default: half the rows a start-up
        re-reads, about half the kernel's height).
    """

    def __init__(self, splatter, sub_rows: int = 16, regions: int = 1, min_take=None):
        self.sp = splatter
        self.ch = vectors_per_step(splatter.device.device)
        self.sub_rows = sub_rows
        self.regions = regions
        self.min_take = min_take
        self._programs: dict = {}
        self._entries: dict = {}     # table entry -> _Kernel, for the table's current scale
        self._plans: dict = {}       # (entry, shape, sharing) -> _Plan, the same scale
        self._scale = None
        self._buffers: dict = {}

    def _program(self, channels: int):
        key = (channels, self.ch)
        if key not in self._programs:
            sp = self.sp
            rb = int(np.abs(sp.directions[:, 1]).max()) + 1
            pad = V * -(-sp.amax * channels // V)
            prg, _ = sp.device.program("polygon/uniform.cl", [f"-DNC={channels}",
                                       f"-DNDIR={len(sp.directions)}", f"-DRB={rb}", f"-DPAD={pad}",
                                       f"-DCH={self.ch}"])
            self._programs[key] = (prg, rb, pad)
        return self._programs[key]

    def _buffer(self, name: str, nbytes: int, what: str):
        """A device buffer of at least ``nbytes`` kept between calls (fresh memory would be
        paged in, and zeroed by the OS, on every call: ~10 ms per 64 MiB)."""
        if name not in self._buffers or self._buffers[name].size < nbytes:
            self._buffers.pop(name, None)
            self._buffers[name] = self.sp.alloc(nbytes, what)
        return self._buffers[name]

    def _entry(self, e: int, radius: float) -> _Kernel:
        if e not in self._entries:
            t = self.sp.table.terms[e]
            init = []
            for k, (a, b) in enumerate(self.sp.directions):
                on = t.direction == k
                p = directional_prefix_taps(t.dx[on], t.dy[on], t.value[on], (a, b))
                if b < 0:   # U(p) = -P(p - d): shift by d, negate
                    p = np.stack([p[:, 0] + a, p[:, 1] + b, -p[:, 2]], 1)
                init.append(p if b != 0 else p[:0])
            self._entries[e] = _Kernel(t, init, column_events(self.sp.table.scale.polygon(radius)))
        return self._entries[e]

    def _plan(self, radius: float, shape) -> _Plan:
        sp = self.sp
        if self._scale is not sp.table.scale:   # the table grew: entries renumbered
            self._entries.clear()
            self._plans.clear()
            self._scale = sp.table.scale
        e = int(sp.table.entry(np.float32(radius)))
        key = (e, shape, self.ch, self.sub_rows, self.regions, self.min_take)
        if key in self._plans:
            self._plans[key] = self._plans.pop(key)   # most recently used last
            return self._plans[key]
        kern = self._entry(e, radius)
        t = kern.terms
        h, w, c = shape
        prg, rb, pad = self._program(c)
        dirs = sp.directions

        # Region columns [x0, x1): every column where some direction's differences are non-zero
        # (b >= 0 lines are summed from the left, b < 0 from the right); x0 aligned so that
        # image lane 0 starts a vector.
        b_of = dirs[t.direction, 1]
        left = min(0, int(t.dx[b_of >= 0].min(initial=0)))
        right = max(w, w + int(t.dx[b_of < 0].max(initial=0)))
        colstep = V // math.gcd(V, c)
        x0 = -colstep * -(-(-left) // colstep)
        vc0 = -x0 * c // V
        ch = self.ch
        vc1 = vc0 + ch * -(-w * c // (V * ch))   # the image's vectors, whole steps of CH
        nvec = max(vc1, -(-(right - x0) * c // V))

        # q rows cover every tap of the sweep (rows 0..h-1), the ring start (rows >= -max|b|)
        # and the column-sum start (rows y0 - 1 - dy of the kernel's rows dy).
        init = [p for p in kern.init if len(p)]
        ev = kern.events
        ox = np.concatenate([t.dx, *(p[:, 0] for p in init), ev[:, 1], [0]])
        oy = np.concatenate([t.dy, *(p[:, 1] for p in init), ev[:, 0], [0]])
        qlane0 = int(ox.max()) * c
        step = math.lcm(V, c)   # whole pixels and whole vectors per row
        ql = step * -(-(qlane0 + V * nvec - int(ox.min()) * c) // step)
        qrow0, qlast = rb + int(oy.max()), -int(oy.min())   # rows above and below a start-up row

        # sweep taps grouped by direction, then weight +1, -1, other (branch-free inner loops)
        kind = np.where(t.value == 1, 0, np.where(t.value == -1, 1, 2))
        order = np.lexsort((kind, t.direction))
        counts = np.zeros((len(dirs), 3), np.int64)
        np.add.at(counts, (t.direction, kind), 1)
        tinfo = np.zeros((len(dirs), 4), np.int32)
        tinfo[:, 0] = np.concatenate([[0], np.cumsum(counts.sum(1))[:-1]])
        tinfo[:, 1:] = counts
        istart = np.concatenate([[0], np.cumsum([len(p) for p in kern.init])]).astype(np.int32)
        itaps = np.zeros((max(1, istart[-1]), 4), np.int32)   # (dy, lane offset, weight, 0)
        if istart[-1]:
            dx, dy, v = np.concatenate(kern.init).T
            itaps[:, 0], itaps[:, 1], itaps[:, 2] = dy, -dx * c, v
        events = np.zeros((len(ev), 4), np.int32)
        events[:, :3] = ev

        workers = int(sp.device.device.max_compute_units)
        sub = max(int(self.sub_rows), -(-h // 0xFFFF))   # sub-band numbers fit 16 bits
        n_sub = -(-h // sub)
        edges = np.linspace(0, n_sub, min(self.regions, n_sub) + 1).round().astype(np.uint32)
        ctl = np.zeros(CTL + max(workers, len(edges) - 1), np.uint32)   # slots: next | end << 16
        ctl[CTL:CTL + len(edges) - 1] = edges[:-1] | edges[1:] << 16
        # a start-up costs about as much as sweeping half the rows it re-reads (0.12 ms, ~50
        # rows, for r = 60 at 1024 wide on a Zen 5): taking fewer rows than that loses time
        take_rows = -(-(qrow0 + qlast + 1) // 2) if self.min_take is None else self.min_take
        qr = qrow0 + qlast + 1
        stride = len(dirs) * rb * (V * nvec + 2 * pad) + V * (vc1 - vc0) + ql + t.nnz
        taps = [np.asarray(a, np.int32) for a in (-t.dx[order] * c, t.dy[order], t.value[order])]
        tables = [sp.upload(a) for a in (tinfo, *taps, istart, itaps, events)]
        kernel = sp.cl.Kernel(prg, "uniform_sweep")
        i32 = np.int32
        for name, value in dict(
                W=i32(w), H=i32(h), LO=i32((int(ox.max()) - x0) * c), QR=i32(qr), QL=i32(ql),
                QROW0=i32(qrow0), QLAST=i32(qlast), QLANE0=i32(qlane0), nvec=i32(nvec),
                vc0=i32(vc0), vc1=i32(vc1), out_lanes=i32(w * c), nslots=i32(len(ctl) - CTL),
                SUB=i32(sub), min_take=i32(-(-take_rows // sub)), dirs=sp.dirs_buf,
                tinfo=tables[0], tdx=tables[1], tdy=tables[2], tval=tables[3], n_taps=i32(t.nnz),
                istart=tables[4], itaps=tables[5], events=tables[6], n_events=i32(len(ev)),
                scratch_stride=np.int64(stride), sbits=i32(exponent_bits(t)),
                area=np.float64(t.area)).items():
            kernel.set_arg(_ARGS[name], value)
        plan = _Plan(kernel, workers, ctl, workers * qr * ql * 4, workers * stride * 8, t.area,
                     tuple(tables))
        self._plans[key] = plan
        while len(self._plans) > PLANS:
            self._plans.pop(next(iter(self._plans)))
        return plan

    def render(self, img: np.ndarray, radius: float, fixed: bool = False):
        """Blur the C-contiguous float32 (H, W, C) ``img`` by the polygon at ``radius``.

        Returns ``(out, info)`` as :meth:`~runtime_cl.polygon.splat.PolygonSplatter.render`
        (``fixed``: the int64 sums in units of ``2^-e / area``).

        Raises
        ------
        InputError
            ``img`` holds NaN or inf (found on the device, with the largest ``|colour|``).
        """
        sp, cl = self.sp, self.sp.cl
        queue = sp.device.queue
        h, w, c = img.shape
        sp.table.ensure(float(radius))
        plan = self._plan(radius, img.shape)
        img_buf = cl.Buffer(sp.device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR,
                            hostbuf=img)
        out = _aligned_empty((h, w, c), np.int64 if fixed else np.float32)
        out_buf = cl.Buffer(sp.device.context, cl.mem_flags.WRITE_ONLY | cl.mem_flags.USE_HOST_PTR,
                            hostbuf=out)
        ctl_buf = sp.upload(plan.ctl)
        k = plan.kernel
        for name, value in (("image", img_buf), ("q", self._buffer("q", plan.q_bytes,
                            "fixed-point rows")), ("scratch", self._buffer(
                            "scratch", plan.scratch_bytes, "worker scratch")),
                            ("ctl", ctl_buf), ("out", out_buf), ("fixed_out", out_buf),
                            ("fixed", np.int32(fixed)),
                            ("stream", np.int32(out.nbytes >= STREAM_BYTES))):
            k.set_arg(_ARGS[name], value)
        event = cl.enqueue_nd_range_kernel(queue, k, (plan.workers,), (1,))
        e = np.zeros(2, np.int32)   # the exponent and the start-ups
        cl.enqueue_copy(queue, e, ctl_buf, is_blocking=False)
        mapped, _ = cl.enqueue_map_buffer(queue, out_buf, cl.map_flags.READ, 0, out.shape,
                                          out.dtype, is_blocking=True)   # in order: after both
        mapped.base.release(queue)
        if e[0] == NONFINITE:
            raise non_finite_error(img)
        return out, {"sweep_ms": event_ms(event),
                     "exponent": np.full(c, int(e[0])), "area": plan.area, "starts": int(e[1])}
