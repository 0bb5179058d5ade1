"""LSR18's Filter baseline (``kernels/filter.cl``): gather with each output pixel's own PSF."""
from __future__ import annotations

import numpy as np

from .device import event_ms
from .device_db import DeviceDatabase
from .errors import InputError


class GatherFilter:
    """Wrapper of ``filter_gather`` for one database and colour channel count.

    Parameters
    ----------
    ddb : DeviceDatabase
        The uploaded database.
    colour_channels : int
        1 or 3 channels in the colour input.
    """

    def __init__(self, ddb: DeviceDatabase, colour_channels: int):
        import pyopencl as cl

        if colour_channels not in (1, 3):
            raise InputError(f"colour channels = {colour_channels}: must be 1 or 3")
        self.ddb, self.device = ddb, ddb.device
        self.out_channels = max(colour_channels, ddb.db.channels)
        options = ddb.options + [f"-DCC={colour_channels}", f"-DOC={self.out_channels}"]
        program, self.build = self.device.program(("psf_space.cl", "filter.cl"), options)
        self.kernel = cl.Kernel(program, "filter_gather")
        self.kernel.set_scalar_arg_dtypes([None] * 9 + [np.int32] * 2)
        self.device.warm_up(self.build, lambda: self._warm_up(colour_channels))

    def _warm_up(self, channels: int):
        import pyopencl as cl

        ctx, grid = self.device.context, self.ddb.db.grid
        lo = np.array([r[0] for r in grid.ranges], np.float32)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        colour = cl.Buffer(ctx, flags, hostbuf=np.ones(channels, np.float32))
        coords = cl.Buffer(ctx, flags, hostbuf=lo)
        self.run(colour, coords, 1, 1)

    def run(self, colour_buf, coords_buf, height: int, width: int) -> tuple:
        """Filter an image already on the device.

        Returns
        -------
        image : ndarray, float32, (H, W, OC)
        kernel_ms, download_ms : float
            Event-profiled times in milliseconds.
        psf_pixels : int
            PSF pixels gathered (inside the image).
        """
        import pyopencl as cl

        ctx, q, b = self.device.context, self.device.queue, self.ddb.buffers
        out = np.empty((height, width, self.out_channels), np.float32)
        counts = np.empty(height, np.int64)
        out_buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
        counts_buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, counts.nbytes)
        ev = self.kernel(q, (height,), (1,), colour_buf, coords_buf, b["psf_thr"], b["psf_bucket"],
                         b["dense_r"], b["dense_off"], b["dense_v"], out_buf, counts_buf, height, width)
        ev_down = cl.enqueue_copy(q, out, out_buf, wait_for=[ev], is_blocking=False)
        ev_counts = cl.enqueue_copy(q, counts, counts_buf, wait_for=[ev], is_blocking=False)
        ev_down.wait()
        ev_counts.wait()
        return out, event_ms(ev), event_ms(ev_down), int(counts.sum())
