"""LSR18's Filter baseline (``kernels/spreadlets/gather.cl``): gather with each output pixel's own PSF."""
from __future__ import annotations

import numpy as np

from runtime_cl.device.opencl import event_ms
from runtime_cl.psf.upload import DeviceDatabase
from runtime_cl.errors import InputError


class GatherFilter:
    """Wrapper of ``filter_gather`` for one database and colour channel count.

    Parameters
    ----------
    ddb : DeviceDatabase
        The uploaded database.
    colour_channels : int
        1 or 3 channels in the colour input, or 4 (radiance and opacity, see
        :class:`~runtime_cl.spreadlets.splat.TileSplatter`).
    rotate : bool
        Turn each output pixel's PSF by its angle (``kernels/spreadlets/gather.cl``); :meth:`run` then
        needs an angle buffer. Default False: the unrotated kernel.
    """

    def __init__(self, ddb: DeviceDatabase, colour_channels: int, rotate: bool = False):
        import pyopencl as cl

        if colour_channels not in (1, 3, 4):
            raise InputError(f"colour channels = {colour_channels}: must be 1, 3 or 4")
        self.ddb, self.device = ddb, ddb.device
        self.out_channels = max(colour_channels, ddb.db.channels)
        self.rotate = bool(rotate)
        options = ddb.options + [f"-DCC={colour_channels}", f"-DOC={self.out_channels}",
                                 f"-DROTATE={int(self.rotate)}"]
        rotate = ("spreadlets/rotate.cl",) if self.rotate else ()
        files = ("psf/psf_space.cl", "prelude/pixels.cl") + rotate + ("spreadlets/gather.cl",)
        program, self.build = self.device.program(files, options)
        self.kernel = cl.Kernel(program, "filter_gather")
        self.kernel.set_scalar_arg_dtypes([None] * 12 + [np.int32] * 2)
        self._no_angle = None
        self.device.warm_up(self.build, lambda: self._warm_up(colour_channels))

    def _warm_up(self, channels: int):
        import pyopencl as cl

        ctx, grid = self.device.context, self.ddb.db.grid
        lo = np.array([r[0] for r in grid.ranges], np.float32)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        colour = cl.Buffer(ctx, flags, hostbuf=np.ones(channels, np.float32))
        coords = cl.Buffer(ctx, flags, hostbuf=lo)
        angle = cl.Buffer(ctx, flags, hostbuf=np.full(1, 0.5, np.float32)) if self.rotate else None
        self.run(colour, coords, 1, 1, angle)

    def run(self, colour_buf, coords_buf, height: int, width: int, angle_buf=None) -> tuple:
        """Filter an image already on the device.

        ``angle_buf`` (float32 (H, W) radians) is required if and only if this filter rotates.

        Returns
        -------
        image : ndarray, float32, (H, W, OC)
        kernel_ms, download_ms : float
            Event-profiled times in milliseconds.
        psf_pixels : int
            PSF pixels gathered (inside the image; rotated: pixels of the turned PSF's support).
        """
        import pyopencl as cl

        ctx, q, b = self.device.context, self.device.queue, self.ddb.buffers
        if (angle_buf is not None) != self.rotate:
            raise InputError(f"angle_buf: {'required' if self.rotate else 'not read'} by a filter "
                             f"built with rotate={self.rotate}")
        if angle_buf is None:
            if self._no_angle is None:  # the unrotated kernel never reads it
                self._no_angle = cl.Buffer(ctx, cl.mem_flags.READ_ONLY, 16)
            angle_buf = self._no_angle
        out = np.empty((height, width, self.out_channels), np.float32)
        counts = np.empty(height, np.int64)
        out_buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, out.nbytes)
        counts_buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, counts.nbytes)
        ev = self.kernel(q, (height,), (1,), colour_buf, coords_buf, angle_buf, b["psf_thr"], b["psf_bucket"],
                         b["dense_r"], b["dense_off"], b["dense_v"], b["dense_sum"], b["dense_box"], out_buf, counts_buf,
                         height, width)
        ev_down = cl.enqueue_copy(q, out, out_buf, wait_for=[ev], is_blocking=False)
        ev_counts = cl.enqueue_copy(q, counts, counts_buf, wait_for=[ev], is_blocking=False)
        ev_down.wait()
        ev_counts.wait()
        return out, event_ms(ev), event_ms(ev_down), int(counts.sum())
