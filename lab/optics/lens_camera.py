"""A thick-lens camera: a :class:`~lab.optics.thick_lens.LensSystem` focused on a distance, with a
sensor and the pinhole camera that labels its pixels.

Focusing moves the sensor: ``"paraxial"`` puts it at the paraxial image of the focus distance at
the focus wavelength; ``"best"`` (what a photographer gets by eye) at the plane where an on-axis
point at that distance has the smallest RMS spot, found in closed form from a fixed, area-uniform
fan of real rays (with spherical aberration it lies between the paraxial and the marginal focus).

Depths are measured from the entrance pupil, the centre of perspective: a pinhole there with
focal distance ``chief_scale_mm`` (the paraxial chief-ray scale) sees an object at field tangent
tan at sensor height ``chief_scale_mm * tan`` -- the image the runtime's labelled pixels come
from, and the centre every PSF is measured from.

Light tracing from a point (:meth:`ThickLensCamera.trace_point`, Dr.Jit): the point emits
isotropically. A point q is drawn uniformly on a disc that every ray reaching the lens crosses
(the stop's opening when only flat openings precede it, else a disc on the plane in front of
the first cap) and kept with probability (r_min / |q - p|)^3: the disc's solid-angle density is
cos / r^2 = dz / r^3, so the kept directions are exactly uniform in solid angle. Openings in
front of the stop are then checked along the straight ray, the rest by Snell's law.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.llvm import Float, UInt32

from lab.errors import UserError
from lab.optics.stop_shape import StopShape
from lab.optics.thick_lens import DRJIT, NUMPY, LensSystem

__all__ = ["ThickLensCamera", "FOCUS_MODES", "best_focus_z_mm"]

FOCUS_MODES = ("best", "paraxial")
_FAN = 64  # rings and spokes of the focusing fan (4096 rays)


def best_focus_z_mm(lens: LensSystem, distance_mm: float, wavelength_nm: float) -> float:
    """z (mm) of the plane with the smallest RMS spot of the axial point ``distance_mm`` in front
    of the entrance pupil: a fan of rays area-uniform over the entrance pupil, traced exactly."""
    z_ep, r_ep = lens.entrance_pupil(wavelength_nm)
    ring = np.sqrt((np.arange(_FAN) + 0.5) / _FAN) * r_ep
    phi = 2 * np.pi * (np.arange(_FAN) + 0.5) / _FAN
    hx = (ring[:, None] * np.cos(phi)[None, :]).ravel()
    hy = (ring[:, None] * np.sin(phi)[None, :]).ravel()
    pz = z_ep - distance_mm
    start = min(0.0, lens.surfaces[0].sag(lens.surfaces[0].aperture_radius_mm)) - 1e-6
    vx, vy, vz = hx, hy, np.full_like(hx, z_ep - pz)
    norm = np.sqrt(vx * vx + vy * vy + vz * vz)
    d = (vx / norm, vy / norm, vz / norm)
    t = (start - pz) / d[2]
    o = (t * d[0], t * d[1], pz + t * d[2])
    (ox, oy, oz), (dx, dy, dz), ok = lens.trace(o, d, lens.relative_indices(wavelength_nm), NUMPY)
    if np.count_nonzero(ok) < 16:
        raise UserError("the lens passes (almost) no rays from the focus distance; check its apertures")
    ox, oy, oz, dx, dy, dz = (a[ok] for a in (ox, oy, oz, dx, dy, dz))
    a, b = dx / dz, dy / dz                      # x(z) = x0 + z a
    x0, y0 = ox - oz * a, oy - oz * b
    return float(-(x0 * a + y0 * b).sum() / (a * a + b * b).sum())


@dataclass(frozen=True)
class ThickLensCamera:
    """A lens, focused, with a sensor of ``width_px`` pixels across ``sensor_width_mm``.

    Build with :meth:`focused`. Attributes are plain floats in millimetres unless named otherwise.

    Attributes
    ----------
    lens : LensSystem
    wavelengths_nm : tuple of float
        One wavelength per colour channel.
    eta : tuple of tuple of float
        ``eta[i][c]``: relative index n_before / n_after at surface i in channel c.
    sensor_z_mm : float
        Sensor plane z.
    pupil_z_mm, pupil_radius_mm : float
        Entrance pupil (at the focus wavelength).
    chief_scale_mm : float
        Focal distance of the equivalent pinhole (sensor height per unit field tangent).
    px_per_mm : float
        Pixels per millimetre on the sensor.
    entry_z_mm, entry_radius_mm, entry_depth_mm : float
        Where light tracing draws ray points: if only flat openings in air precede the stop
        (:attr:`LensSystem.baffled_stop`), the stop's plane and radius (depth 0); otherwise the
        plane at the first cap's frontmost z, its clear radius and its axial depth |sag| (a ray
        reaching the cap crosses that plane within entry_radius + |slope| * entry_depth).
    first_traced : int
        The surface tracing starts at (behind the stop when rays are drawn on it, else 0).
    baffles : tuple of (int, float, float)
        (surface index, z, radius) of the openings in front of the stop, checked along the
        straight ray when rays are drawn on the stop.
    front_z_mm : float
        The frontmost z of the lens: objects must lie in front of it.
    stop_shape : StopShape, optional
        A shaped stop (an iris, a star) inside the stop's round opening; None: the round opening.
        Focusing ignores it (the sensor is where the round stop's smallest spot is).
    """

    lens: LensSystem
    wavelengths_nm: tuple
    eta: tuple
    sensor_z_mm: float
    pupil_z_mm: float
    pupil_radius_mm: float
    chief_scale_mm: float
    px_per_mm: float
    entry_z_mm: float
    entry_radius_mm: float
    entry_depth_mm: float
    first_traced: int
    baffles: tuple
    front_z_mm: float
    stop_shape: StopShape | None = None

    @classmethod
    def focused(cls, lens: LensSystem, focus_distance_m: float, wavelengths_nm, focus_wavelength_nm: float,
                width_px: int, sensor_width_mm: float, focus: str = "best",
                stop_shape: StopShape | None = None) -> "ThickLensCamera":
        """Place the sensor so the lens focuses at ``focus_distance_m`` from its entrance pupil.

        Parameters
        ----------
        lens : LensSystem
        focus_distance_m : float
            Distance in focus, metres from the entrance pupil (beyond the front focal point).
        wavelengths_nm : sequence of float
            Wavelength of each colour channel, nm.
        focus_wavelength_nm : float
            Wavelength the focus (and the pinhole image scale) is computed at, nm.
        width_px : int
            Image width in pixels across ``sensor_width_mm``.
        sensor_width_mm : float
            Sensor width in mm.
        focus : {"best", "paraxial"}, default "best"
            Smallest RMS spot, or the paraxial image.
        stop_shape : StopShape, optional
            The stop's shape (see the attribute).
        """
        if focus not in FOCUS_MODES:
            raise UserError(f"focus = {focus!r}: use one of {list(FOCUS_MODES)}")
        distance = focus_distance_m * 1000.0
        z_par = lens.paraxial_image(distance, focus_wavelength_nm)  # UserError if it cannot focus
        z = z_par if focus == "paraxial" else best_focus_z_mm(lens, distance, focus_wavelength_nm)
        if not z > lens.vertices_mm[-1]:
            raise UserError(f"the lens cannot focus at {focus_distance_m} m: the sensor would sit inside it")
        z_ep, r_ep = lens.entrance_pupil(focus_wavelength_nm)
        first = lens.surfaces[0]
        sag = first.sag(first.aperture_radius_mm)
        per = [lens.relative_indices(w) for w in wavelengths_nm]
        eta = tuple(tuple(p[i] for p in per) for i in range(len(lens)))
        if lens.baffled_stop:
            st = lens.stop
            entry = (lens.vertices_mm[st], lens.surfaces[st].aperture_radius_mm, 0.0, st + 1)
            baffles = tuple((i, lens.vertices_mm[i], lens.surfaces[i].aperture_radius_mm) for i in range(st))
        else:
            entry, baffles = (min(0.0, sag), first.aperture_radius_mm, abs(sag), 0), ()
        return cls(lens, tuple(float(w) for w in wavelengths_nm), eta, float(z), z_ep, r_ep,
                   lens.chief_scale_mm(z, focus_wavelength_nm), width_px / sensor_width_mm,
                   *entry, baffles, min(0.0, sag), stop_shape)

    @property
    def f_number(self) -> float:
        """Working f-number at infinity: chief_scale / entrance-pupil diameter (approximate)."""
        return self.chief_scale_mm / (2.0 * self.pupil_radius_mm)

    def min_depth_m(self) -> float:
        """Nearest object distance (m, from the entrance pupil) still in front of the lens."""
        return max(self.pupil_z_mm - self.front_z_mm, 0.0) / 1000.0

    # --- light tracing from a point (Dr.Jit) -------------------------------------------------------
    def draw_rays(self, px, pz, u_r, u_phi, u_keep):
        """Rays from the object point (px, 0, pz) (mm, Dr.Jit Floats) toward the lens.

        Returns ``(q, d, v, keep)``: start points on the entry disc and unit directions (tuples of 3
        Floats), q - p (3 Floats), and whether the draw is kept (see the module docstring).
        """
        c = dr.opaque
        dz0 = c(Float, self.entry_z_mm) - pz
        rho = c(Float, self.entry_radius_mm)
        if self.entry_depth_mm > 0:  # a ray to the cap crosses the plane within rho of the axis
            rho = rho + (dr.abs(px) + self.entry_radius_mm) / dz0 * c(Float, self.entry_depth_mm)
        r = dr.sqrt(u_r) * rho
        sin, cos = _sincos_2pi(u_phi)
        vx, vy = r * cos - px, r * sin
        dist2 = vx * vx + vy * vy + dz0 * dz0
        gap = dr.maximum(dr.abs(px) - rho, 0.0)
        low2 = dz0 * dz0 + gap * gap
        keep = u_keep * u_keep * dist2 * dist2 * dist2 < low2 * low2 * low2  # u < (r_min / r)^3
        inv = dr.rsqrt(dist2)
        return (vx + px, vy, c(Float, self.entry_z_mm)), (vx * inv, vy * inv, dz0 * inv), (vx, vy, dz0), keep

    def trace_point(self, px, pz, u_r, u_phi, u_keep, eta, status: bool = False, stop_turn=None):
        """Light-trace rays from the object point (px, 0, pz) (mm) to the sensor (Dr.Jit).

        Parameters
        ----------
        px, pz : Float
            Object point, mm (z < the lens's front).
        u_r, u_phi, u_keep : Float
            Uniform numbers in [0, 1) for the disc radius, the angle and the keep draw.
        eta : sequence of Float
            Relative index at each surface per ray (:attr:`eta` selected by channel).
        status : bool, default False
            Also return the status code (:data:`lab.optics.thick_lens.STATUS_OK` etc.).
        stop_turn : (Float, Float), optional
            (cos, sin) of the angle a shaped stop is turned by, per ray (None: not turned).

        Returns
        -------
        tuple
            ``(sx, sy, ok, code, keep)``: sensor position (mm), whether the ray got there (kept and
            unblocked), the status (None unless asked) and the keep flag.
        """
        q, d, v, keep = self.draw_rays(px, pz, u_r, u_phi, u_keep)
        mask = None if self.stop_shape is None else self.stop_shape.mask(stop_turn)
        drawn_on_stop = self.first_traced > 0
        out = self.lens.trace(q, d, eta, DRJIT, self.sensor_z_mm, status=status, first=self.first_traced,
                              stop_mask=None if drawn_on_stop else mask)
        (sx, sy, _), _, ok = out[:3]
        code = out[3] if status else None
        if drawn_on_stop and mask is not None:   # q lies on the stop's plane: test the shape there
            open_ = mask(q[0], q[1])
            if status:
                code = dr.select(ok & ~open_, UInt32(1 + self.lens.stop), code)
            ok = ok & open_
        for i, z, a in reversed(self.baffles):  # openings in front of the stop: the straight ray
            back = dr.opaque(Float, z - self.entry_z_mm) / v[2]
            bx, by = q[0] + back * v[0], q[1] + back * v[1]
            inside = bx * bx + by * by <= dr.opaque(Float, a * a)
            if status:
                code = dr.select(~inside, UInt32(1 + i), code)
            ok = ok & inside
        return sx, sy, keep & ok, code, keep

    def describe(self) -> dict:
        """Figures for reports: sensor position, pupil, pinhole focal distance, f-number."""
        return {"sensor_z_mm": self.sensor_z_mm, "pupil_z_mm": self.pupil_z_mm,
                "pupil_radius_mm": self.pupil_radius_mm, "chief_scale_mm": self.chief_scale_mm,
                "f_number": self.f_number, "wavelengths_nm": list(self.wavelengths_nm)}


def _sincos_2pi(u):
    """sin and cos of 2 pi u - pi for u in [0, 1) (Dr.Jit): polynomials of the half angle
    (|error| < 1e-6), about half the work of ``dr.sincos``'s general range reduction, which
    showed in PhysicalLens's M rays/s."""
    h = u * math.pi - 0.5 * math.pi
    h2 = h * h
    s = h * dr.fma(h2, dr.fma(h2, dr.fma(h2, dr.fma(h2, dr.fma(h2, -1 / 39916800, 1 / 362880), -1 / 5040),
                                          1 / 120), -1 / 6), 1.0)
    c = dr.fma(h2, dr.fma(h2, dr.fma(h2, dr.fma(h2, dr.fma(h2, dr.fma(h2, 1 / 479001600, -1 / 3628800),
                                                                 1 / 40320), -1 / 720), 1 / 24), -0.5), 1.0)
    return 2.0 * s * c, c * c - s * s
