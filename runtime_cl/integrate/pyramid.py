"""The convolution-pyramid integrator (Farbman et al. 2011) on the OpenCL device.

The operator is :mod:`runtime_cl.integrate.pyramid_model`'s (analysis with ``h1`` and halving,
one ``g`` per level, synthesis with zero insertion and ``h2``), with the fitted kernels of
``pyramid_kernels.json``. It approximates convolution with the free-space Green's function of
the 5-point Laplacian, which on a canvas whose image is zero on its border ring is what the
exact FFT solve computes.

How the kernels were fitted (``python -m lab.pyramid_fit``, whose docstring has the details):
``h1`` and ``h2`` are symmetric 7-tap filters (``h1``'s centre 1), ``g`` is a 5x5 kernel at the
finest level, a 7x7 one at the next and a 7x7 one shared by every coarser level, each with the
square's 8 symmetries (6 + 10 + 10 values). On training images that are zero near their border
-- sums of sharp discs, soft-rimmed PSF-like discs and whole bright frames, 128^2 to 256^2 --
the taps were searched by Nelder-Mead (scipy.optimize) with 3x3 ``g`` kernels above the finest
level, and the ``g`` values, linear in the output once the taps are fixed, solved by
iteratively reweighted least squares for the smallest 8-norm of the per-pixel error relative to
the image's largest value.

Error against the exact solve (``|pyramid - exact| / max|exact|`` per pixel and channel, its
mean and max over pixels and channels): ~0.1 % mean and <= 2.1 % max on random PSF sums of
64^2 to 1024^2 (the tests assert <= 1 % and <= 3 %), 0.20 % / 1.9 % at 4096^2, 0.59 % / 1.7 %
on a whole defocused frame (``splatlab bench integrate``'s ``defocus_1024``; mostly a smooth
bias at the frame's own scale). The measure's floor is the exact solve's own float32 error,
~1e-6 mean and 1e-5 max at 1024^2, 5e-5 at 4096^2. The error is largest on detail at the pixel
scale: behind a ~1 px blur, white noise comes back up to ~5 % off, so in-focus pixels belong on
the dense fast track (as a database's small PSFs are).

Kernels (``kernels/integrate/pyramid.cl``), one launch per level and step, all on the device:
the canvas mean (row sums, then their sum), the analysis levels (down the columns, then across
the rows), the synthesis from the coarsest level up (up-sampling across the rows of the coarse
level, then one kernel for the rest, row-wise), the mean of level 0's border ring (computed
from level 1 before level 0 is written, so level 0 is written once, already shifted), then one
download. The row-wise kernels work on runs of 16 floats of the interleaved channels (one
unaligned vector load per tap), so they vectorise for any channel count. On this 2-core
machine a 1200^2 RGB canvas takes ~20-24 ms when the machine is quiet (16-19 ms on the
device), 3.1-3.9x less than the exact FFT solve in the same run (``bench integrate``, medians of
two runs); 8 floats per item is ~25 % slower, two rows per synthesis item slower still.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.device.opencl import event_ms, get_device
from runtime_cl.errors import InputError
from runtime_cl.integrate.pyramid_model import PAD, PyramidKernels, level_shapes, load_kernels, ring_mean
from runtime_cl.integrate.registry import Integrator, register_integrator

__all__ = ["PyramidIntegrator"]

_I = np.int32
_GROUP_X = 64   # work items per group along a row: PoCL loops (and vectorises) over them


def _grid(width: int, height: int) -> tuple:
    """(global, local) sizes of a 2-D launch over (width, height): explicit groups along rows, so
    that a prime level width does not make PoCL run one-item groups; kernels skip the excess."""
    lx = min(_GROUP_X, -(-width // 8) * 8)
    return (-(-width // lx) * lx, height), (lx, 1)


@register_integrator("pyramid")
class PyramidIntegrator(Integrator):
    """Convolution-pyramid Poisson integration on the OpenCL device.

    Parameters
    ----------
    device : Device, optional
        Default :func:`~runtime_cl.device.opencl.get_device`.
    kernels : PyramidKernels, optional
        Default: the fitted ones (:func:`~runtime_cl.integrate.pyramid_model.load_kernels`).
    vector_width : {4, 8, 16}
        Floats per work item of the row-wise kernels (default 16).
    row_block : {1, 2}
        Rows per work item of the synthesis, which share their input rows (default 1).
    """

    summary = "convolution pyramid (Farbman et al. 2011) on the OpenCL device, fitted kernels"

    def __init__(self, device=None, kernels: PyramidKernels | None = None, vector_width: int = 16,
                 row_block: int = 1):
        if vector_width not in (4, 8, 16):
            raise InputError(f"vector_width = {vector_width!r}: must be 4, 8 or 16")
        super().__init__(device or get_device())
        if row_block not in (1, 2):
            raise InputError(f"row_block = {row_block!r}: must be 1 or 2")
        self.vector_width, self.row_block = vector_width, row_block
        self.kernels = kernels or load_kernels()
        self._programs: dict = {}
        self._pending: list = []    # builds not warmed up yet
        self._buffers: dict = {}
        self._coefficients = None

    def _program(self, channels: int, g_radius: int) -> dict:
        """The kernels for ``channels`` and a ``g`` of ``g_radius`` (built once; -D constants)."""
        import pyopencl as cl

        key = (channels, g_radius)
        if key not in self._programs:
            k = self.kernels
            options = [f"-DC={channels}", f"-DR1={len(k.h1) // 2}", f"-DR2={len(k.h2) // 2}",
                       f"-DRG={g_radius}", f"-DPAD={PAD}", f"-DVW={self.vector_width}",
                       f"-DRB={self.row_block}"]
            program, record = self.device.program(("integrate/pyramid.cl",), options)
            kernels = {n: cl.Kernel(program, n)
                       for n in ("row_sums", "finish_mean", "down_v", "down_h", "up_h", "synth", "ring_mean")}
            kernels["row_sums"].set_scalar_arg_dtypes([None, _I, _I, None])
            kernels["finish_mean"].set_scalar_arg_dtypes([None, _I, _I, None])
            kernels["down_v"].set_scalar_arg_dtypes([None, _I, _I, None, None, _I, None])
            kernels["down_h"].set_scalar_arg_dtypes([None, _I, _I, None, _I, None])
            kernels["up_h"].set_scalar_arg_dtypes([None, _I, _I, None, _I, None])
            kernels["synth"].set_scalar_arg_dtypes([None, _I, _I, None, None, _I, None, None, np.float32,
                                                    None, None])
            kernels["ring_mean"].set_scalar_arg_dtypes([None, _I, _I, None, None, None, None, None])
            self._programs[key] = kernels
            self._pending.append(record)
        return self._programs[key]

    def _kernels(self, channels: int) -> list:
        """Per ``g`` of the kernel set, its program's kernels; new builds are warmed up on a canvas
        that runs every kernel (PoCL compiles each at its first launch)."""
        kernels = [self._program(channels, g.shape[0] // 2) for g in self.kernels.g]
        while self._pending:
            record = self._pending.pop()
            self.device.warm_up(record, lambda: self(np.zeros((32, 32, channels), np.float32)))
        return kernels

    def _constants(self):
        """Device copies of h1, h2 with a 0 appended (the kernels' h2p) and every g; g's sums."""
        import pyopencl as cl

        if self._coefficients is None:
            flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
            ctx, k = self.device.context, self.kernels
            buf = lambda a: cl.Buffer(ctx, flags, hostbuf=np.ascontiguousarray(a, np.float32))  # noqa: E731
            self._coefficients = (buf(k.h1), buf(np.r_[k.h2, 0.0]), [buf(g) for g in k.g],
                                  [np.float32(np.float32(g).sum()) for g in k.g])
        return self._coefficients

    def _level_buffers(self, h: int, w: int, channels: int):
        """Per level the analysis ``a`` (level 0: the uploaded canvas) and the synthesis ``s``;
        scratch ``t`` (analysis down the columns) and ``u`` (synthesis across the rows)."""
        import pyopencl as cl

        key = (h, w, channels)
        if key not in self._buffers:
            ctx, mf = self.device.context, cl.mem_flags
            shapes = level_shapes(h, w)
            new = lambda floats: cl.Buffer(ctx, mf.READ_WRITE, 4 * (floats + 16))  # noqa: E731  (+16: vector tails)
            a = [new(hh * ww * channels) for hh, ww in shapes]
            s = [new(hh * ww * channels) for hh, ww in shapes]
            pairs = list(zip(shapes, shapes[1:]))
            t = new(max([nh * ww * channels for (_, ww), (nh, _) in pairs], default=1))
            u = new(max([ch * ww * channels for (_, ww), (ch, _) in pairs], default=1))
            table = channels * self.vector_width        # lane tables of per-channel constants
            zeros = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.zeros(table + 16, np.float32))
            small = [cl.Buffer(ctx, mf.READ_WRITE, 4 * (table + 16)) for _ in range(2)]   # mean, offset
            sums = cl.Buffer(ctx, mf.READ_WRITE, h * channels * 4)
            self._buffers = {key: (shapes, a, s, t, u, zeros, small, sums)}   # one canvas size at a time
        return self._buffers[key]

    def __call__(self, laplacian) -> tuple:
        import pyopencl as cl

        lap = np.ascontiguousarray(laplacian, dtype=np.float32)
        if lap.ndim not in (2, 3):
            raise InputError(f"laplacian: shape {lap.shape}, need (H, W) or (H, W, C)")
        h, w = lap.shape[:2]
        if h < 3 or w < 3:
            raise InputError(f"laplacian: canvas {h}x{w} is too small, need at least 3x3")
        channels = 1 if lap.ndim == 2 else lap.shape[2]
        per_g = self._kernels(channels)
        kern = per_g[0]
        h1, h2p, gs, g_sums = self._constants()
        shapes, a, s, t, u, zeros, (mean, offset), sums = self._level_buffers(h, w, channels)
        at = lambda level, items: items[min(level, len(items) - 1)]  # noqa: E731  (the last g serves the rest)
        vw = self.vector_width
        rows = lambda n_floats, n_rows: _grid(-(-n_floats // vw), n_rows)  # noqa: E731  (vw floats per item)
        q = self.device.queue
        up = cl.enqueue_copy(q, a[0], lap, is_blocking=False)
        ev = [kern["row_sums"](q, (-(-h // 16) * 16,), (16,), a[0], h, w, sums),
              kern["finish_mean"](q, (1,), None, sums, h, w, mean)]
        for level in range(len(shapes) - 1):
            (hh, ww), (nh, nw) = shapes[level], shapes[level + 1]
            ev.append(kern["down_v"](q, *rows(ww * channels, nh), a[level], hh, ww,
                                     mean if level == 0 else zeros, t, nh, h1))
            ev.append(kern["down_h"](q, *rows(2 * nw * channels, nh), t, nh, ww, a[level + 1], nw, h1))
        top = len(shapes) - 1
        th, tw = shapes[top]
        rb = self.row_block
        ev.append(at(top, per_g)["synth"](q, *rows(tw * channels, -(-th // rb)), a[top], th, tw, mean if top == 0 else zeros,
                                          a[top], 0, h2p, at(top, gs), at(top, g_sums), zeros, s[top]))
        for level in range(top - 1, -1, -1):
            (hh, ww), (ch, cw) = shapes[level], shapes[level + 1]
            ev.append(kern["up_h"](q, *_grid(ww, ch), s[level + 1], ch, cw, u, ww, h2p))
            if level == 0:   # the ring's mean first, so level 0 is written once, shifted
                ev.append(at(0, per_g)["ring_mean"](q, (1,), None, a[0], hh, ww, mean, u, h2p,
                                                    at(0, gs), offset))
            ev.append(at(level, per_g)["synth"](q, *rows(ww * channels, -(-hh // rb)), a[level], hh, ww,
                                                mean if level == 0 else zeros, u, 1, h2p, at(level, gs),
                                                at(level, g_sums), offset if level == 0 else zeros, s[level]))
        out = np.empty_like(lap)
        down = cl.enqueue_copy(q, out, s[0], is_blocking=False)
        times = {"device_ms": event_ms(*ev), "transfer_ms": event_ms(up, down)}
        if top == 0:   # at most TOP samples a side: one level, its ring mean taken here
            out -= ring_mean(out).astype(np.float32)
        return out, times
