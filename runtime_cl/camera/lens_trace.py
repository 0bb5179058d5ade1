"""Exact ray tracing through a thick lens in the runtime: numpy (float64) and OpenCL (float32).

The runtime's twin of :class:`lab.optics.thick_lens.LensSystem` (which traces in numpy and
Dr.Jit): the same surfaces, the same conventions and the same formulas -- z along the optical
axis from the scene into the camera, the first vertex at z = 0, mm; a sphere intersected by the
root continuous with the flat case, Snell's law in vector form, a ray blocked outside a clear
semi-aperture, at total internal reflection, or when it does not travel towards the sensor. The
runtime has no glass catalog: the ``splatlab.camera`` header of a thick lens carries the
refractive index behind every surface at each channel's wavelength (``indices``, ``wavelengths_nm``)
and the sensor plane (``sensor_z_mm``), which the lab derives from its catalog and focusing
(:class:`runtime_cl.camera.thick_lens.ThickLens`).

``kernels/camera/lens_trace.cl`` is the same trace in OpenCL C for kernels that need lens rays
(LES09/LES10 layered tracing); :class:`LensTraceKernel` runs it on arrays, which is how the tests
hold the three versions to each other (within 1e-5 mm).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime_cl.device.opencl import Device, as_f32, get_device
from runtime_cl.errors import InputError

__all__ = ["TracedLens", "LensTraceKernel"]


@dataclass(frozen=True)
class TracedLens:
    """A lens as arrays, ready to trace (object side first).

    Attributes
    ----------
    curvature : ndarray (n,)
        1 / radius per surface in 1/mm (0: the stop or a flat face).
    vertex_mm : ndarray (n,)
        z of each surface's vertex.
    aperture_mm : ndarray (n,)
        Clear semi-aperture per surface.
    is_stop : ndarray (n,) bool
    eta : ndarray (channels, n)
        n_before / n_after at each surface, per channel (1 at the stop).
    sensor_z_mm : float
        The sensor plane.
    """

    curvature: np.ndarray
    vertex_mm: np.ndarray
    aperture_mm: np.ndarray
    is_stop: np.ndarray
    eta: np.ndarray
    sensor_z_mm: float

    @classmethod
    def from_camera(cls, camera) -> "TracedLens":
        """From a :class:`~runtime_cl.camera.thick_lens.ThickLens` (its surfaces, indices, sensor)."""
        rows = camera.surfaces
        radius = np.array([r[0] for r in rows], np.float64)
        flat = (radius == 0.0) | np.isinf(radius)
        curvature = np.where(flat, 0.0, 1.0 / np.where(flat, 1.0, radius))
        vertex = np.concatenate([[0.0], np.cumsum([r[1] for r in rows[:-1]])])
        n_after = np.asarray(camera.indices, np.float64)                  # (channels, n)
        n_before = np.concatenate([np.ones((len(n_after), 1)), n_after[:, :-1]], axis=1)
        return cls(curvature, vertex, np.array([r[3] for r in rows], np.float64), radius == 0.0,
                   n_before / n_after, float(camera.sensor_z_mm))

    def reversed(self) -> "TracedLens":
        """The lens seen from the sensor (z' = L - z, L the last vertex), for rays traced from the
        sensor into the scene; its sensor plane is where the object side was (z' = L)."""
        last = self.vertex_mm[-1]
        return TracedLens(-self.curvature[::-1].copy(), (last - self.vertex_mm)[::-1].copy(), self.aperture_mm[::-1].copy(),
                          self.is_stop[::-1].copy(), 1.0 / self.eta[:, ::-1], float(last))

    def trace(self, o, d, channel, to_sensor: bool = True) -> tuple:
        """Trace rays (numpy, float64).

        Parameters
        ----------
        o, d : array_like (m, 3)
            Origins in front of the first surface (mm) and unit directions (d_z > 0).
        channel : int or array_like (m,)
            Which row of ``eta`` each ray uses.
        to_sensor : bool
            Intersect the sensor plane at the end.

        Returns
        -------
        o, d : ndarray (m, 3)
            Final positions and directions.
        ok : ndarray (m,) bool
            The ray got through.
        """
        o = np.array(o, np.float64, copy=True)
        d = np.array(d, np.float64, copy=True)
        eta = self.eta[np.broadcast_to(np.asarray(channel), o.shape[:1])]          # (m, n)
        ok = d[:, 2] > 0
        for i, (c, zv, a) in enumerate(zip(self.curvature, self.vertex_mm, self.aperture_mm)):
            p = o - np.array([0.0, 0.0, zv])
            if c == 0.0:
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = -p[:, 2] / d[:, 2]
                hit = t >= 0
            else:
                b = c * np.einsum("ij,ij->i", p, d) - d[:, 2]
                cc = c * np.einsum("ij,ij->i", p, p) - 2.0 * p[:, 2]
                disc = b * b - c * cc
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = cc / (np.sqrt(np.maximum(disc, 0.0)) - b)
                hit = (disc >= 0) & (t >= 0)
            p = p + t[:, None] * d
            ok &= hit & (p[:, 0] ** 2 + p[:, 1] ** 2 <= a * a)
            o = p + np.array([0.0, 0.0, zv])
            if not self.is_stop[i]:
                e = eta[:, i]
                n = np.stack([c * p[:, 0], c * p[:, 1], c * p[:, 2] - 1.0], axis=1)
                cos_i = -np.einsum("ij,ij->i", n, d)
                k = 1.0 - e * e * (1.0 - cos_i * cos_i)
                ok &= k >= 0
                f = e * cos_i - np.sqrt(np.maximum(k, 0.0))
                d = e[:, None] * d + f[:, None] * n
        if to_sensor:
            ok &= d[:, 2] > 0
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (self.sensor_z_mm - o[:, 2]) / d[:, 2]
            o = o + t[:, None] * d
        return o, d, ok

    def build_options(self) -> list[str]:
        """``-D`` options that put this lens into ``kernels/camera/lens_trace.cl`` (constants:
        every kernel built for it is specialised to it)."""
        def arr(values):
            return "{" + ",".join(f"{float(v)!r}f" for v in np.ravel(values)) + "}"

        return [f"-DLENS_N={len(self.curvature)}", f"-DLENS_CHANNELS={len(self.eta)}",
                f"-DLENS_CURVATURE={arr(self.curvature)}", f"-DLENS_VERTEX={arr(self.vertex_mm)}",
                f"-DLENS_APERTURE={arr(self.aperture_mm)}", f"-DLENS_STOP={arr(self.is_stop.astype(float))}",
                f"-DLENS_ETA={arr(self.eta)}", f"-DLENS_SENSOR_Z={float(self.sensor_z_mm)!r}f"]


class LensTraceKernel:
    """:meth:`TracedLens.trace` in OpenCL (float32), one work item per ray.

    Parameters
    ----------
    lens : TracedLens
    device : Device, optional
    """

    def __init__(self, lens: TracedLens, device: Device | None = None):
        import pyopencl as cl

        self.lens = lens
        self.device = device or get_device()
        program, self.build = self.device.program("camera/lens_trace.cl", lens.build_options())
        self.kernel = cl.Kernel(program, "trace_lens_rays")
        self.kernel.set_scalar_arg_dtypes([None, None, None, None, None, None, np.int32, np.int32])

    def trace(self, o, d, channel, to_sensor: bool = True) -> tuple:
        """As :meth:`TracedLens.trace`, in float32 on the device."""
        import pyopencl as cl

        o, d = as_f32(o, "o", 2), as_f32(d, "d", 2)
        m = len(o)
        if o.shape != (m, 3) or d.shape != (m, 3):
            raise InputError(f"o, d: shapes {o.shape}, {d.shape}; need (m, 3) each")
        ch = np.ascontiguousarray(np.broadcast_to(np.asarray(channel, np.int32), (m,)))
        if m and (ch.min() < 0 or ch.max() >= len(self.lens.eta)):
            raise InputError(f"channel: values in [{ch.min()}, {ch.max()}], the lens has {len(self.lens.eta)}")
        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        out_o, out_d, ok = np.empty_like(o), np.empty_like(d), np.empty(m, np.int32)
        if m == 0:
            return out_o, out_d, ok.astype(bool)
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (o, d, ch)]
        outs = [cl.Buffer(ctx, mf.WRITE_ONLY, a.nbytes) for a in (out_o, out_d, ok)]
        ev = self.kernel(q, (m,), None, *bufs, *outs, m, int(to_sensor))
        for host, buf in zip((out_o, out_d, ok), outs):
            cl.enqueue_copy(q, host, buf, wait_for=[ev])
        return out_o, out_d, ok.astype(bool)
