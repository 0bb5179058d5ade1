"""The PSF-space forward map on the device: build options for ``kernels/psf/psf_space.cl`` and a
wrapper for the stand-alone ``psf_index`` kernel.

``psf/psf_space.cl`` is prepended to every kernel that looks PSF cells up (splatting, filtering);
:class:`PsfSpaceTables` turns a :class:`~runtime_cl.psf.grid.NestedGrid` into its ``-D``
options and two small lookup tables (the kernel avoids ``pow``, which costs ~80 ns on PoCL).
With fp64 (PoCL has it) the comparisons are in double precision like numpy, so cells agree
exactly unless a grid coordinate lies within ~1e-12 of an integer (every cell boundary is at an
integer grid coordinate); without fp64 the tolerance is float32 rounding, ~1e-6 relative.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.device.opencl import Device, as_f32, event_ms, get_device
from runtime_cl.errors import InputError
from runtime_cl.psf.grid import NestedGrid


def _list(values, fmt=repr) -> str:
    # repr() round-trips doubles exactly; no spaces, so the option stays one argument
    return ",".join(fmt(v) for v in values)


class PsfSpaceTables:
    """Build options and lookup tables that ``psf/psf_space.cl`` needs for one grid.

    Parameters
    ----------
    grid : NestedGrid
        The PSF space.
    fp64 : bool
        Compute in double precision (the device must support ``cl_khr_fp64``).

    Attributes
    ----------
    options : list of str
        ``-D`` build options.
    thr : ndarray
        Per dimension, n + 1 thresholds (k/n)^beta in normalised coordinates (float64 or float32).
    bucket : ndarray, int32
        Per dimension, the first-guess floor(g) of each log-spaced bucket of s.
    """

    def __init__(self, grid: NestedGrid, fp64: bool):
        real = np.float64 if fp64 else np.float32
        n = int(grid.n)
        thr, bucket, octaves, mbits, thr_off, bucket_off = [], [], [], [], [], []
        for beta in grid.beta[:grid.nested_ns]:
            t = (np.arange(n + 1, dtype=np.float64) / n) ** beta
            t = t.astype(real)
            # enough octaves that every s below the first one has floor(g) = 0 (capped for
            # absurd beta; the correction loop stays exact, only slower)
            o = min(int(np.ceil(beta * np.log2(max(n, 1)))) + 1, 120)
            # bucket relative width 2^-mb: floor(g) changes by at most ~4 inside one bucket
            mb = int(np.clip(np.ceil(np.log2(max(n / (4.0 * beta), 1.0))), 2, 12))
            b = np.arange(o * 2 ** mb + 1)
            lower = np.ldexp(1.0 + (b % 2 ** mb) / 2.0 ** mb, b // 2 ** mb - o).astype(real)
            thr_off.append(sum(len(x) for x in thr))
            bucket_off.append(sum(len(x) for x in bucket))
            thr.append(t)
            bucket.append(np.searchsorted(t, lower, side="right") - 1)
            octaves.append(o)
            mbits.append(mb)
        self.thr = np.concatenate(thr).astype(real)
        self.bucket = np.concatenate(bucket).astype(np.int32)
        self.options = [
            f"-DPSF_NS={grid.ns}", f"-DPSF_N={n}", f"-DPSF_LEVELS={grid.levels}",
            f"-DPSF_NESTED={grid.nested_ns}", f"-DPSF_BINS={int(grid.bins)}",
            f"-DPSF_NESTED_SIZE={grid.nested_size}",
            f"-DPSF_REAL={'double' if fp64 else 'float'}", f"-DPSF_REAL_IS_DOUBLE={int(fp64)}",
            f"-DPSF_LO={_list(float(lo) for lo, _ in grid.ranges)}",
            f"-DPSF_HI={_list(float(hi) for _, hi in grid.ranges)}",
            f"-DPSF_OCTAVES={_list(octaves, str)}", f"-DPSF_MB={_list(mbits, str)}",
            f"-DPSF_THR_OFF={_list(thr_off, str)}", f"-DPSF_BUCKET_OFF={_list(bucket_off, str)}",
            "-DPSF_LEVEL_OFFSETS=" + _list(grid.level_offsets, lambda v: f"{int(v)}L"),
        ]

    def upload(self, context):
        """(thr, bucket) as read-only OpenCL buffers on ``context``."""
        import pyopencl as cl

        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        return cl.Buffer(context, flags, hostbuf=self.thr), cl.Buffer(context, flags, hostbuf=self.bucket)


def check_coords(grid: NestedGrid, coords: np.ndarray, what: str = "coords") -> None:
    """Raise InputError unless every coordinate is finite and inside the grid's ranges.

    Parameters
    ----------
    grid : NestedGrid
        The PSF space (of a database).
    coords : ndarray, (..., ns) float
        PSF coordinates per pixel.
    what : str
        Name of the argument, for the message.
    """
    if coords.shape[-1:] != (grid.ns,):
        raise InputError(f"{what}: shape {coords.shape}, need (..., {grid.ns}) for the PSF space "
                         f"{list(grid.names)}")
    for d, (name, (lo, hi)) in enumerate(zip(grid.names, grid.ranges)):
        c = coords[..., d]
        # float32 inputs are compared in float64, exactly as NestedGrid.normalise does
        cmin, cmax = float(np.min(c)), float(np.max(c))
        if np.isnan(cmin) or np.isnan(cmax) or cmin < lo or cmax > hi:
            bad = int(np.count_nonzero(~((c >= lo) & (c <= hi))))
            raise InputError(f"{what}[..., {d}] ({name}): {bad} pixel(s) outside the database range "
                             f"[{lo}, {hi}] (found min {cmin}, max {cmax}); rebuild the database with "
                             "a range that covers them")


class PsfIndexKernel:
    """The nested-grid forward map as an OpenCL kernel (``psf/psf_index.cl``).

    Parameters
    ----------
    grid : NestedGrid
        The PSF space.
    device : Device, optional
        Default :func:`~runtime_cl.device.opencl.get_device`.
    fp64 : bool, optional
        Double-precision map; default: whatever the device supports.
    """

    def __init__(self, grid: NestedGrid, device: Device | None = None, fp64: bool | None = None):
        import pyopencl as cl

        self.grid = grid
        self.device = device or get_device()
        self.fp64 = self.device.fp64 if fp64 is None else bool(fp64)
        tables = PsfSpaceTables(grid, self.fp64)
        program, self.build = self.device.program(("psf/psf_space.cl", "psf/psf_index.cl"), tables.options)
        self.thr, self.bucket = tables.upload(self.device.context)
        self.kernel = cl.Kernel(program, "psf_index")
        self.kernel.set_scalar_arg_dtypes([None, None, None, None, np.int32])

    def index(self, coords) -> tuple:
        """Cell index of each point.

        Parameters
        ----------
        coords : array_like, (n, ns) float32
            Physical PSF coordinates, inside the grid's ranges.

        Returns
        -------
        cells : ndarray, (n,) int32
        kernel_ms : float
            Kernel time from event profiling.
        """
        import pyopencl as cl

        x = as_f32(coords, "coords", 2)
        check_coords(self.grid, x)
        n = len(x)
        if n == 0:
            return np.zeros(0, np.int32), 0.0
        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        x_buf = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
        out = np.empty(n, np.int32)
        out_buf = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        ev = self.kernel(q, (n,), None, x_buf, self.thr, self.bucket, out_buf, n)
        cl.enqueue_copy(q, out, out_buf, wait_for=[ev])
        return out, event_ms(ev)
