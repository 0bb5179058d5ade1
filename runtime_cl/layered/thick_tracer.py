"""Lens-ray tracing through layered images with a thick lens (``kernels/layered/thick.cl``).

LES10 traces lens rays through layers with a real lens: spherical aberration, curvature of field,
vignetting and chromatic aberration then come from the lens itself, which no filter gives. Each
pixel's sensor point sends ``rays`` backward rays through the lens's exit-pupil box
(:class:`runtime_cl.camera.exit_pupil.PupilBoxes`), each traced in every channel with that
channel's refractive indices (the header's ``indices``, LES10's 650/510/475 nm), by the OpenCL twin
of the lab's lens (``kernels/camera/lens_trace.cl``). A ray leaving the lens is a line q(w) = a + b w
in the pinhole image at the entrance pupil (the kernel file derives it), so the layers are searched
exactly as for the thin lens (:class:`runtime_cl.layered.tracer.LayerTracer`).
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.camera.lens_trace import TracedLens
from runtime_cl.device.opencl import event_ms
from runtime_cl.errors import InputError
from runtime_cl.layered.lens_samples import halton
from runtime_cl.layered.tracer import LayerStack, LayerTracer

__all__ = ["ThickLayerTracer", "box_samples"]


def box_samples(n: int) -> np.ndarray:
    """``n`` Halton (2, 3) points in [0, 1)^2, (n, 2) float32: the exit-pupil box's lens samples."""
    return np.stack([halton(n, 2), halton(n, 3)], axis=-1).astype(np.float32)


class ThickLayerTracer(LayerTracer):
    """The layered tracer for one thick lens, image size, layer count and ray count.

    Parameters
    ----------
    camera : runtime_cl.camera.thick_lens.ThickLens
        The lens, its sensor and the channels' indices (three channels).
    shape, n_layers, rays, downsample, clamp_iters, pixel_iters, false_position, cone, cone_scale, device
        As :class:`LayerTracer`. A cone's footprint is not the thin lens's disc: the rays of its box
        sample's neighbours through the real lens give its size at the hit depth (the kernel file).
    """

    KERNEL_FILES = ("camera/lens_trace.cl", "layered/trace.cl", "layered/thick.cl")
    STATS_INTS = 4

    def __init__(self, camera, shape, n_layers: int, rays: int, *, downsample: int = 4, clamp_iters: int = 0,
                 pixel_iters: int = 3, false_position: int = 0, cone: bool = False, cone_scale: float = 1.0,
                 interpolate_hidden: bool = True, device=None):
        lens = TracedLens.from_camera(camera)
        if len(lens.eta) != 3:
            raise InputError(f"camera indices: {len(lens.eta)} channel(s); the layered tracer renders RGB, so the "
                             "thick lens needs indices at three wavelengths")
        h, w = (int(s) for s in shape)
        self.channels = len(lens.eta)
        self.mm_px = camera.sensor_width_mm / w
        self.slopes = camera.sensor_slopes() if getattr(camera, "tilted", False) else (0.0, 0.0)
        self.pupil = PupilBoxes.for_camera(camera, (h, w))
        self.f_px = camera.focal_px(w)
        self.pupil_z = float(camera.pupil_z_mm)
        self.coc_scale = float(camera.coc_scale_px(w))
        super().__init__(shape, n_layers, rays, downsample=downsample, clamp_iters=clamp_iters,
                         pixel_iters=pixel_iters, false_position=false_position, cone=cone,
                         cone_scale=cone_scale, interpolate_hidden=interpolate_hidden, device=device)
        cl = self.cl
        self._render_thick = cl.Kernel(self.program, "render_thick")
        self._thick_rays = cl.Kernel(self.program, "thick_rays")
        self._thick_cones = cl.Kernel(self.program, "thick_cones") if self.cone else None
        # the box samples' spacing: rays uniform in the unit square, 1/rays of it each
        self.spacing = math.sqrt(1.0 / self.rays)
        self.buf["boxes"] = cl.Buffer(self.device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                                      hostbuf=self.pupil.kernel_table())

    def _lens_options(self) -> list:
        pupil = self.pupil
        return pupil.lens.build_options() + [
            f"-DNCH={self.channels}", f"-DMM_PX={self.mm_px!r}f", f"-DF_PX={self.f_px!r}f",
            f"-DORIGIN_Z={pupil.origin_z_mm!r}f", f"-DLAST_Z={pupil.lens.sensor_z_mm!r}f",
            f"-DPUPIL_Z={self.pupil_z!r}f", f"-DPLANE_GAP={pupil.plane_gap_mm!r}f", f"-DNBOX={len(pupil.boxes_mm)}",
            f"-DINV_STEP={1.0 / pupil.radius_step_mm!r}f", f"-DTILT_GX={self.slopes[0]!r}f",
            f"-DTILT_GY={self.slopes[1]!r}f"]

    def _lens_samples(self) -> np.ndarray:
        """2 ``rays`` Halton points in the unit square: where in its exit-pupil box a ray aims."""
        return box_samples(2 * self.rays)

    def render(self, stack: LayerStack, thickness_px: float = 1.0, seed: int = 0) -> tuple:
        """Trace ``rays`` lens rays per pixel and channel through ``stack``.

        Returns
        -------
        image : (H, W, 3) float32
            Per channel the cos^4-weighted mean colour of its rays that hit (none: the nearest
            layer's own colour).
        info : dict
            ``kernel_ms``, ``transfer_ms`` and counts of (ray, channel) pairs: ``rays_hit``,
            ``rays_left_image``, ``rays_missed``, ``rays_blocked`` (by the lens); ``pixels_no_hit``.
        """
        if not (math.isfinite(thickness_px) and thickness_px >= 0):
            raise InputError(f"thickness_px = {thickness_px!r}: the surfel slab depth must be >= 0 pixels")
        events, wmax = self._upload(stack)
        events += self._upload_mips(stack)
        cl, q, b = self.cl, self.device.queue, self.buf
        gsize = (-(-self.w // 8) * 8, -(-self.h // 8) * 8)
        kernel = self._render_thick(q, gsize, (8, 8), b["height"], b["colour"], b["nbuf"], b["range"], b["samples"],
                                    b["boxes"], np.float32(wmax), np.float32(thickness_px / self.coc_scale),
                                    np.uint32(seed % 2**32), b["mip"], b["mip_offset"],
                                    np.float32(self.spacing), np.float32(self.cone_scale), b["out"], b["stats"])
        out = np.empty((self.h, self.w, 4), np.float32)
        stats = np.empty((self.h, self.w, 4), np.int32)
        down = [cl.enqueue_copy(q, out, b["out"], wait_for=[kernel], is_blocking=False),
                cl.enqueue_copy(q, stats, b["stats"], wait_for=[kernel], is_blocking=False)]
        transfer = event_ms(*events, *down)
        info = {"kernel_ms": event_ms(kernel, *self.nbuffer_events), "transfer_ms": transfer,
                "rays_hit": int(round(float(out[..., 3].sum()) * self.channels)), "rays_left_image": int(stats[..., 0].sum()),
                "rays_missed": int(stats[..., 1].sum()), "rays_blocked": int(stats[..., 2].sum()),
                "pixels_no_hit": int((out[..., 3] <= 0).sum())}
        return np.ascontiguousarray(out[..., :3]), info

    def ray_lines(self, pixel_u, channel) -> tuple:
        """The kernel's (a, b) and weights of rays from pixel positions with box samples (tests).

        Parameters
        ----------
        pixel_u : (n, 4) float
            Pixel position (x, y, in pixels, centres at +0.5) and box sample (u1, u2) per ray.
        channel : (n,) int

        Returns
        -------
        ab : (n, 4) float32
            ``a.x, a.y, b.x, b.y`` (0 where blocked).
        weight : (n,) float32
            cos^4 (0: blocked).
        """
        cl = self.cl
        pixel_u = np.ascontiguousarray(pixel_u, np.float32)
        ch = np.ascontiguousarray(channel, np.int32)
        n, ctx, mf = len(pixel_u), self.device.context, cl.mem_flags
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (pixel_u, ch)]
        out_b, w_b = cl.Buffer(ctx, mf.WRITE_ONLY, 16 * n), cl.Buffer(ctx, mf.WRITE_ONLY, 4 * n)
        ev = self._thick_rays(self.device.queue, (n,), None, bufs[0], bufs[1], self.buf["boxes"], np.int32(n),
                              out_b, w_b)
        ab, weight = np.empty((n, 4), np.float32), np.empty(n, np.float32)
        cl.enqueue_copy(self.device.queue, ab, out_b, wait_for=[ev])
        cl.enqueue_copy(self.device.queue, weight, w_b, wait_for=[ev])
        return ab, weight

    def cone_diameters(self, pixel_u, channel, w: float) -> np.ndarray:
        """The kernel's cone diameters (pixels) at inverse depth ``w`` (1/m) of rays from pixel
        positions with box samples, as :meth:`ray_lines` takes them (tests; needs ``cone``)."""
        cl = self.cl
        pixel_u = np.ascontiguousarray(pixel_u, np.float32)
        ch = np.ascontiguousarray(channel, np.int32)
        n, ctx, mf = len(pixel_u), self.device.context, cl.mem_flags
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (pixel_u, ch)]
        out_b = cl.Buffer(ctx, mf.WRITE_ONLY, 4 * n)
        ev = self._thick_cones(self.device.queue, (n,), None, bufs[0], bufs[1], self.buf["boxes"], np.int32(n),
                               np.float32(w), np.float32(self.spacing), out_b)
        out = np.empty(n, np.float32)
        cl.enqueue_copy(self.device.queue, out, out_b, wait_for=[ev])
        return out
