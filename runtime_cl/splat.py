"""Exact splatting with private row bands (``kernels/splat.cl``): spreadlets and dense PSFs.

PoCL has no float atomics; per-work-item row bands merged in a fixed order measured fastest
among the exact options on this stack (DESIGN.md: 648 M splats/s vs 346 M/s for a CAS loop).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .device import event_ms
from .device_db import DeviceDatabase
from .errors import InputError
from .integrate import fft_friendly


@dataclass
class SplatOutput:
    """What one splat pass produced.

    Attributes
    ----------
    canvas : ndarray, float32, (groups, Hc, Wc, OC)
        Group 0: the Laplacian (spreadlets) or, for the Splat baseline, the dense image; group 1
        (spreadlets with fast track only): the dense fast-track image. Input pixel (x, y) sits
        at canvas (x + pad, y + pad).
    pad : int
        Canvas padding.
    splat_ms, merge_ms, download_ms : float
        Event-profiled times in milliseconds.
    spreadlets, dense_pixels : int
        Spreadlets and dense PSF pixels splatted (pixels with zero colour splat nothing).
    bands : int
        Number of row bands (work items).
    """

    canvas: np.ndarray
    pad: int
    splat_ms: float
    merge_ms: float
    download_ms: float
    spreadlets: int
    dense_pixels: int
    bands: int


def canvas_shape(height: int, width: int, pad: int) -> tuple:
    """(Hc, Wc): the padded canvas, enlarged to FFT-friendly sizes for the Poisson solve."""
    return fft_friendly(height + 2 * pad), fft_friendly(width + 2 * pad)


class BandSplatter:
    """Wrapper of ``splat_bands`` + ``merge_bands`` for one database and colour channel count.

    Parameters
    ----------
    ddb : DeviceDatabase
        The uploaded database.
    colour_channels : int
        1 or 3 channels in the colour input.
    dense_all : bool
        True: LSR18's Splat baseline (every pixel splats its dense PSF); False: spreadlets, with
        fast-tracked cells splat dense into a second canvas.
    """

    def __init__(self, ddb: DeviceDatabase, colour_channels: int, dense_all: bool):
        import pyopencl as cl

        if colour_channels not in (1, 3):
            raise InputError(f"colour channels = {colour_channels}: must be 1 or 3")
        self.ddb, self.device = ddb, ddb.device
        self.dense_all = bool(dense_all)
        self.colour_channels = colour_channels
        self.out_channels = max(colour_channels, ddb.db.channels)
        has_fast = ddb.has_fast and not self.dense_all
        self.groups = 2 if has_fast else 1
        options = ddb.options + [f"-DCC={colour_channels}", f"-DOC={self.out_channels}",
                                 f"-DDENSE_ALL={int(self.dense_all)}", f"-DHAS_FAST={int(has_fast)}",
                                 f"-DGROUPS={self.groups}"]
        program, self.build = self.device.program(("psf_space.cl", "splat.cl"), options)
        self.splat_kernel = cl.Kernel(program, "splat_bands")
        self.splat_kernel.set_scalar_arg_dtypes([None] * 13 + [np.int32] * 4)
        self.merge_kernel = cl.Kernel(program, "merge_bands")
        self.merge_kernel.set_scalar_arg_dtypes([None, None] + [np.int32] * 4)
        self._scratch: dict = {}
        self.device.warm_up(self.build, self._warm_up)

    def _warm_up(self):
        import pyopencl as cl

        ctx, ns = self.device.context, self.ddb.db.grid.ns
        lo = np.array([r[0] for r in self.ddb.db.grid.ranges], np.float32)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        colour = cl.Buffer(ctx, flags, hostbuf=np.ones(self.colour_channels, np.float32))
        coords = cl.Buffer(ctx, flags, hostbuf=lo.reshape(ns))
        self.run(colour, coords, 1, 1, 1)

    def _buffer(self, name: str, nbytes: int):
        import pyopencl as cl

        buf = self._scratch.get(name)
        if buf is None or buf.size < nbytes:
            buf = cl.Buffer(self.device.context, cl.mem_flags.READ_WRITE, max(nbytes, 16))
            self._scratch[name] = buf
        return buf

    def default_bands(self, height: int) -> int:
        """Four bands per compute unit (load balance), but bands of at least 8 rows."""
        units = self.device.device.max_compute_units
        return max(1, min(4 * units, -(-height // 8)))

    def run(self, colour_buf, coords_buf, height: int, width: int, bands: int | None = None) -> SplatOutput:
        """Splat every pixel of an image already on the device.

        Parameters
        ----------
        colour_buf, coords_buf : pyopencl.Buffer
            float32 (H, W, CC) colour and (H, W, ns) PSF coordinates (validated by the caller).
        height, width : int
            Image size in pixels.
        bands : int, optional
            Row bands (work items); default :meth:`default_bands`.
        """
        import pyopencl as cl

        pad, oc = self.ddb.db.pad, self.out_channels
        hc, wc = canvas_shape(height, width, pad)
        nbands = bands or self.default_bands(height)
        band_rows = -(-height // nbands)
        nbands = -(-height // band_rows)  # drop empty bands
        pixel_floats = 4 if oc == 3 else 1  # RGB band pixels are float4
        limit = self.device.device.max_mem_alloc_size
        # fewer bands overlap less: shrink the band count until the band buffer fits the device
        while nbands > 1 and nbands * self.groups * (band_rows + 2 * pad) * wc * pixel_floats * 4 > limit:
            nbands = max(1, nbands // 2)
            band_rows = -(-height // nbands)
            nbands = -(-height // band_rows)
        band_floats = self.groups * (band_rows + 2 * pad) * wc * pixel_floats
        if nbands * band_floats * 4 > limit:
            raise InputError(f"image {height}x{width} with padding {pad}: the splat buffer needs "
                             f"{nbands * band_floats * 4 >> 20} MiB, the OpenCL device allows {limit >> 20} "
                             "MiB per buffer; render a smaller image or tiles of it")
        bands_buf = self._buffer("bands", nbands * band_floats * 4)
        counts_buf = self._buffer("counts", nbands * 16)
        canvas_buf = self._buffer("canvas", self.groups * hc * wc * oc * 4)
        b, q = self.ddb.buffers, self.device.queue
        ev_splat = self.splat_kernel(
            q, (nbands,), (1,), colour_buf, coords_buf, b["psf_thr"], b["psf_bucket"], b["C"], b["P"],
            b["V"], b["fast"], b["dense_r"], b["dense_off"], b["dense_v"], bands_buf, counts_buf,
            height, width, band_rows, wc)
        ev_merge = self.merge_kernel(q, (hc,), (1,), bands_buf, canvas_buf, nbands, band_rows, wc, hc,
                                     wait_for=[ev_splat])
        canvas = np.empty((self.groups, hc, wc, oc), np.float32)
        counts = np.empty((nbands, 2), np.int64)
        ev_down = cl.enqueue_copy(q, canvas, canvas_buf, wait_for=[ev_merge], is_blocking=False)
        ev_counts = cl.enqueue_copy(q, counts, counts_buf, wait_for=[ev_splat], is_blocking=False)
        ev_down.wait()
        ev_counts.wait()
        return SplatOutput(canvas, pad, event_ms(ev_splat), event_ms(ev_merge), event_ms(ev_down),
                           int(counts[:, 0].sum()), int(counts[:, 1].sum()), nbands)
