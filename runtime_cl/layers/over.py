"""The "over" of one depth layer with its re-weighting, on the device (``layers/over.cl``).

:func:`runtime_cl.layers.composite.render_layers` composites each layer onto the layers behind
it on the box of what the layer drew. In numpy that was five passes over the box with their
temporaries (~45 ms a frame for the demo's 4 layers at 1024^2 on 2 cores); this kernel does it in
one pass, a pixel per work item in work-groups along a row, on the host's own arrays (PoCL's CPU
device reads and writes them in place), with the same float32 operations in the same order: the
image is the same to the last bit. It also returns the layer's coverage before and after the
re-weighting (summed per work-group: a work item per row ran 2x slower, its rows vectorised
across work items).
"""
from __future__ import annotations

import numpy as np

from runtime_cl.device.opencl import Device, event_ms
from runtime_cl.masks import box_shape, inner_box

__all__ = ["OverKernel", "over_kernel"]

GROUP = 64   # pixels of a row per work-group (the coverage sums reduce within one)


class OverKernel:
    """``over_layer`` for ``channels`` colour channels on ``device``."""

    def __init__(self, device: Device, channels: int):
        import pyopencl as cl

        self.device, self.channels = device, int(channels)
        prg, _ = device.program("layers/over.cl", [f"-DNC={self.channels}", f"-DGROUP={GROUP}"])
        self.kernel = cl.Kernel(prg, "over_layer")
        self.kernel.set_scalar_arg_dtypes([None] * 4 + [np.int32] * 9 + [np.float32])
        self._dummy = cl.Buffer(device.context, cl.mem_flags.READ_ONLY, 4)

    def __call__(self, out: np.ndarray, layer: np.ndarray, box: tuple, blurred, region: tuple,
                 has_hidden: bool, has_own: bool, min_known: float) -> tuple:
        """Composite ``layer`` (the box's (h, w, C + 1) colour and alpha, C-contiguous float32)
        over ``out`` ((H, W, C) float32, C-contiguous, updated in place). ``blurred``: the
        (rh, rw, K) blurs on ``region`` (a box holding ``box``): the nearer layers' coverage if
        ``has_hidden``, then the layer's own sites if ``has_own``; None if neither. Returns
        ``(covered, total, device_ms)``: the layer's coverage after the re-weighting (before the
        own-sites bound) and before it."""
        import pyopencl as cl

        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        bh, bw = layer.shape[:2]
        groups = -(-bw // GROUP)
        sums = np.empty((bh, groups, 2), np.float32)
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=layer),
                self._dummy if blurred is None else
                cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=np.ascontiguousarray(blurred)),
                cl.Buffer(ctx, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=out),
                cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=sums)]
        at = inner_box(box, region)   # where the box lies in the blurs' region
        event = self.kernel(q, (groups * GROUP, bh), (GROUP, 1), *bufs, out.shape[1], box[0].start,
                            box[1].start, bw, box_shape(region)[1], at[0].start, at[1].start, has_hidden,
                            has_own, min_known)
        # mapping makes the host's arrays current (a no-op copy where PoCL used them in place)
        for buf, a in ((bufs[2], out), (bufs[3], sums)):
            mapped, _ = cl.enqueue_map_buffer(q, buf, cl.map_flags.READ, 0, a.shape, a.dtype, is_blocking=True)
            mapped.base.release(q)
        covered, total = sums.reshape(-1, 2).sum(axis=0, dtype=np.float64)
        return float(covered), float(total), event_ms(event)


_KERNELS: dict = {}


def over_kernel(device: Device, channels: int) -> OverKernel:
    """The :class:`OverKernel` of ``device`` for ``channels``, made once per process."""
    key = (id(device), int(channels))
    if key not in _KERNELS or _KERNELS[key].device is not device:
        _KERNELS[key] = OverKernel(device, channels)
    return _KERNELS[key]
