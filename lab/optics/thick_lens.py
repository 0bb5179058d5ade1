"""A lens as a list of surfaces (pbrt-v4 ``LensElementInterface`` style) traced by Snell's law.

Each :class:`Surface` is one interface, listed from the object side to the sensor: its signed
curvature radius, the axial thickness to the next surface, the medium behind it (``"air"`` or a
:mod:`lab.optics.glass` name) and its clear semi-aperture. A radius of 0 marks the aperture stop
(a flat iris, no refraction), ``inf`` a flat refracting face. A thick bi-convex lens with a stop
in front is three rows; more elements are more rows.

Conventions (millimetres). The optical axis is z, pointing from the scene into the camera; the
first surface's vertex is at z = 0 and objects lie at z < 0. x is right and y up as seen from the
camera (an OpenGL camera looking down -z). A positive radius puts the centre of curvature on the
sensor side (convex toward the object), as in pbrt and Zemax.

Tracing is written once for two array backends (:data:`NUMPY`: float64, for focusing, checks and
tests; :data:`DRJIT`: Dr.Jit LLVM float32, per ray while light tracing), so there is one source
of truth for the geometry. A ray that misses a surface, passes outside its clear aperture or is
totally internally reflected is blocked (weight 0); the status code says where.

Paraxial optics (y-nu ray trace, float64) gives the focal length, the entrance pupil, the sensor
position for a focus distance and the chief-ray image scale; :meth:`LensSystem.paraxial_image`
validates that a lens can focus at a distance at all.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.llvm import Float, UInt32

from lab.errors import UserError
from lab.optics.glass import get_glass

__all__ = ["Surface", "LensSystem", "Ops", "NUMPY", "DRJIT", "STATUS_OK"]

STATUS_OK = 0  # other codes: 1 + i blocked at surface i, 1 + n + i total internal reflection at i,
#                1 + 2 n: the ray does not travel toward the sensor (n = number of surfaces)


class Ops:
    """The few array operations tracing needs, for one backend.

    Parameters
    ----------
    sqrt, select : callable
        Element-wise square root and ``select(mask, a, b)``.
    const : callable
        Turns a Python float into the backend's scalar (Dr.Jit: an opaque variable, so a new lens
        reuses the compiled kernel).
    status : callable
        ``status(code, like)``: an integer array of ``code`` shaped like ``like``.
    """

    def __init__(self, sqrt, select, const, status):
        self.sqrt, self.select, self.const, self.status = sqrt, select, const, status


NUMPY = Ops(np.sqrt, np.where, float, lambda code, like: np.full(np.shape(like), code, np.int64))
DRJIT = Ops(dr.sqrt, dr.select, lambda v: dr.opaque(Float, v),
            lambda code, like: dr.full(UInt32, code, dr.width(like)))


@dataclass(frozen=True)
class Surface:
    """One interface of a lens (a row of a pbrt lens file).

    Parameters
    ----------
    radius_mm : float
        Signed curvature radius in mm (> 0: centre on the sensor side); 0 = the aperture stop;
        ``inf`` = a flat refracting face.
    thickness_mm : float
        Axial distance to the next surface in mm (>= 0); 0 for the last surface, whose distance to
        the sensor comes from focusing.
    glass : str
        Medium behind the surface (toward the sensor): ``"air"`` or a catalog glass.
    aperture_radius_mm : float
        Clear semi-aperture in mm (> 0, < |radius_mm|).
    """

    radius_mm: float
    thickness_mm: float
    glass: str
    aperture_radius_mm: float

    @property
    def is_stop(self) -> bool:
        return self.radius_mm == 0.0

    @property
    def curvature(self) -> float:
        """1 / radius in 1/mm (0 for the stop and flat faces)."""
        return 0.0 if self.is_stop or math.isinf(self.radius_mm) else 1.0 / self.radius_mm

    def sag(self, h: float) -> float:
        """Axial depth of the surface at height ``h`` mm relative to its vertex (signed, mm)."""
        c = self.curvature
        return 0.0 if c == 0.0 else (1.0 - math.sqrt(1.0 - (c * h) ** 2)) / c


class LensSystem:
    """A lens described as surfaces, object side first, with exactly one aperture stop.

    Parameters
    ----------
    surfaces : sequence of Surface or of (radius_mm, thickness_mm, glass, aperture_radius_mm)
        The interfaces; the medium in front of the first one and behind the last one is air.
    """

    def __init__(self, surfaces):
        rows = [s if isinstance(s, Surface) else Surface(*s) for s in surfaces]
        if not rows:
            raise UserError("lens surfaces = []: list at least the aperture stop and two refracting surfaces")
        for i, s in enumerate(rows):
            where = f"lens surface {i} {tuple(s.__dict__.values())}"
            for name in ("radius_mm", "thickness_mm", "aperture_radius_mm"):
                v = getattr(s, name)
                if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
                    raise UserError(f"{where}: {name} = {v!r} must be a number")
            get_glass(s.glass)
            if not (math.isfinite(s.thickness_mm) and s.thickness_mm >= 0):
                raise UserError(f"{where}: thickness_mm = {s.thickness_mm} must be finite and >= 0")
            if not (math.isfinite(s.aperture_radius_mm) and s.aperture_radius_mm > 0):
                raise UserError(f"{where}: aperture_radius_mm = {s.aperture_radius_mm} must be > 0")
            if s.curvature and s.aperture_radius_mm >= abs(s.radius_mm):
                raise UserError(f"{where}: aperture_radius_mm = {s.aperture_radius_mm} must be smaller "
                                f"than |radius_mm| = {abs(s.radius_mm)} (a spherical cap)")
            before = rows[i - 1].glass if i else "air"
            if s.is_stop and s.glass != before:
                raise UserError(f"{where}: an aperture stop (radius 0) does not refract; its glass must be "
                                f"{before!r}, the medium in front of it (use radius inf for a flat face)")
        stops = [i for i, s in enumerate(rows) if s.is_stop]
        if len(stops) != 1:
            raise UserError(f"lens surfaces: {len(stops)} aperture stops (rows with radius_mm = 0); "
                            "exactly one is needed")
        if rows[-1].glass != "air":
            raise UserError(f"lens surfaces: the last surface's glass is {rows[-1].glass!r}; the sensor "
                            "sits in air, so the last row's glass must be 'air'")
        if rows[-1].thickness_mm != 0:
            raise UserError(f"lens surfaces: the last thickness_mm = {rows[-1].thickness_mm}; it must be 0 "
                            "(the sensor distance comes from the focus distance)")
        self.surfaces = tuple(rows)
        self.stop = stops[0]
        self.vertices_mm = tuple(float(v) for v in np.concatenate([[0.0], np.cumsum(
            [s.thickness_mm for s in rows[:-1]])]))
        for i in range(len(rows) - 1):  # neighbouring caps must not cut through each other
            a, b = rows[i], rows[i + 1]
            h = min(a.aperture_radius_mm, b.aperture_radius_mm)
            if self.vertices_mm[i] + a.sag(h) > self.vertices_mm[i + 1] + b.sag(h) + 1e-9:
                raise UserError(f"lens surfaces {i} and {i + 1} intersect at height {h} mm: raise "
                                f"thickness_mm of surface {i} ({a.thickness_mm}) or reduce the apertures")

    @property
    def baffled_stop(self) -> bool:
        """True if every surface in front of the stop is a flat opening in air (a hood or baffle):
        rays from the object reach the stop along straight lines."""
        return all(s.curvature == 0.0 and s.glass == "air" for s in self.surfaces[:self.stop])

    def __len__(self) -> int:
        return len(self.surfaces)

    def reversed(self) -> "LensSystem":
        """The same lens seen from the sensor: surfaces in reverse order, radii negated, each
        followed by the medium that was in front of it. A point (x, y, z) of this lens is
        (x, y, L - z) of the reversed one (L: the last vertex), so rays traced backward from
        the sensor (a camera sensor's rays) use :meth:`trace` unchanged."""
        rows = self.surfaces
        glass = ["air"] + [s.glass for s in rows[:-1]]          # the medium in front of each row
        thick = [0.0] + [s.thickness_mm for s in rows[:-1]]     # the gap in front of each row
        return LensSystem([Surface(-s.radius_mm if s.radius_mm else 0.0, thick[i], glass[i], s.aperture_radius_mm)
                           for i, s in reversed(list(enumerate(rows)))])

    def indices(self, wavelength_nm: float) -> tuple:
        """Refractive index behind each surface at ``wavelength_nm`` (tuple of floats)."""
        return tuple(float(get_glass(s.glass).index(wavelength_nm)) for s in self.surfaces)

    # --- paraxial optics (float64) -----------------------------------------------------------------
    def _paraxial(self, y, u, wavelength_nm):
        """y-nu trace of the ray with height ``y`` at z = 0 and slope ``u`` in object space.

        Returns the heights at every vertex plane and (y, u) behind the last surface."""
        n_prev, z_prev, heights = 1.0, 0.0, []
        for s, z, n in zip(self.surfaces, self.vertices_mm, self.indices(wavelength_nm)):
            y = y + (z - z_prev) * u
            heights.append(y)
            u = (n_prev * u - y * s.curvature * (n - n_prev)) / n
            n_prev, z_prev = n, z
        return heights, y, u

    def effective_focal_length_mm(self, wavelength_nm: float) -> float:
        """Paraxial EFL in mm (from a ray parallel to the axis)."""
        _, _, u = self._paraxial(1.0, 0.0, wavelength_nm)
        return math.inf if u == 0 else -1.0 / u

    def back_focal_distance_mm(self, wavelength_nm: float) -> float:
        """Paraxial distance from the last vertex to the focus of a parallel beam, mm."""
        _, y, u = self._paraxial(1.0, 0.0, wavelength_nm)
        return math.inf if u == 0 else -y / u

    def entrance_pupil(self, wavelength_nm: float) -> tuple[float, float]:
        """(z, radius) of the entrance pupil in mm: the stop as seen from the object side."""
        a = self._paraxial(1.0, 0.0, wavelength_nm)[0][self.stop]
        b = self._paraxial(0.0, 1.0, wavelength_nm)[0][self.stop]
        return b / a, self.surfaces[self.stop].aperture_radius_mm / abs(a)

    def paraxial_image(self, distance_mm: float, wavelength_nm: float) -> float:
        """z (mm) of the paraxial image of the axial point ``distance_mm`` in front of the entrance
        pupil; UserError if that image is virtual (the lens cannot focus there)."""
        z_ep = self.entrance_pupil(wavelength_nm)[0]
        _, y, u = self._paraxial(distance_mm - z_ep, 1.0, wavelength_nm)
        t = -y / u if u < 0 else -math.inf
        if not t > 0:
            ffd = self.front_focus_distance_mm(wavelength_nm)
            raise UserError(f"the lens cannot focus at {distance_mm / 1000:.6g} m (its image would be "
                            f"virtual): focus beyond its front focal point, farther than "
                            f"{ffd / 1000:.4g} m from the entrance pupil")
        return self.vertices_mm[-1] + t

    def front_focus_distance_mm(self, wavelength_nm: float) -> float:
        """Distance from the entrance pupil to the front focal point (mm, object side)."""
        z_ep = self.entrance_pupil(wavelength_nm)[0]
        u_tilt = self._paraxial(0.0, 1.0, wavelength_nm)[2]
        u_shift = self._paraxial(1.0, 0.0, wavelength_nm)[2]
        # the ray from the axis point at z = -s (height s at z = 0, slope 1) leaves with slope
        # s * u_shift + u_tilt: parallel (imaged at infinity) for s = -u_tilt / u_shift
        return -u_tilt / u_shift + z_ep if u_shift else math.inf

    def chief_scale_mm(self, sensor_z_mm: float, wavelength_nm: float) -> float:
        """Sensor height (mm) per unit tangent of the field angle at the entrance pupil (paraxial).

        The chief ray of an object at tan(theta) = x / depth (through the pupil centre) lands at
        ``k * tan`` on the sensor, with the sign that undoes the inversion: > 0 means the image
        of a point at +x lies at -x on the sensor (k is the pinhole focal distance)."""
        z_ep = self.entrance_pupil(wavelength_nm)[0]
        _, y, u = self._paraxial(-z_ep, 1.0, wavelength_nm)
        return y + (sensor_z_mm - self.vertices_mm[-1]) * u

    # --- exact tracing (numpy or Dr.Jit) -------------------------------------------------------------
    def relative_indices(self, wavelength_nm: float) -> tuple:
        """eta_i = n(in front of surface i) / n(behind it) at ``wavelength_nm``: what Snell's law
        needs at each surface (1 for the stop)."""
        n = (1.0,) + self.indices(wavelength_nm)
        return tuple(a / b for a, b in zip(n[:-1], n[1:]))

    def trace(self, o, d, eta, ops: Ops = NUMPY, sensor_z_mm: float | None = None, status=False,
              first: int = 0, stop_mask=None):
        """Trace rays through the surfaces by Snell's law, optionally to the sensor plane.

        Parameters
        ----------
        o, d : tuple of 3 arrays
            Ray origins (mm, in front of surface ``first``) and unit directions (d_z > 0).
        eta : sequence of arrays or floats
            Relative index n_before / n_after at each surface, per ray (e.g. selected by colour
            channel; see :meth:`relative_indices`).
        ops : Ops, default NUMPY
            The array backend (:data:`NUMPY` or :data:`DRJIT`).
        sensor_z_mm : float, optional
            Intersect the plane z = sensor_z_mm at the end.
        status : bool, default False
            Also return a status code per ray (see ``STATUS_OK``).
        first : int, default 0
            Start at this surface; the caller has dealt with the earlier ones (e.g. rays drawn on
            the stop's opening, baffles in front of it checked along the straight ray).
        stop_mask : callable, optional
            ``stop_mask(x, y)``: whether the stop plane is open at (x, y) mm inside its round
            opening (a shaped stop, :meth:`lab.optics.stop_shape.StopShape.mask`).

        Returns
        -------
        tuple
            ``(o, d, ok)``: final positions and directions (tuples of 3 arrays) and whether the ray
            got through, plus the status array if ``status``.
        """
        if any(s.curvature or s.glass != "air" for s in self.surfaces[:first]):
            raise ValueError(f"trace(first={first}): only flat surfaces in air may be skipped")
        (ox, oy, oz), (dx, dy, dz) = o, d
        ok = dz > 0
        n_surf = len(self.surfaces)
        code = ops.select(ok, ops.status(STATUS_OK, ox), ops.status(1 + 2 * n_surf, ox)) if status else None
        for i in range(first, n_surf):
            s, zv = self.surfaces[i], self.vertices_mm[i]
            px, py, pz = ox, oy, oz - ops.const(zv)
            if s.curvature == 0.0:  # the stop or a flat face: the plane z = zv
                c, t = 0.0, -pz / dz
                hit = t >= 0
            else:
                # c |p + t d|^2 - 2 (p_z + t d_z) = 0, the root continuous with the flat case (c -> 0)
                c = ops.const(s.curvature)
                b = c * (px * dx + py * dy + pz * dz) - dz
                cc = c * (px * px + py * py + pz * pz) - 2.0 * pz
                disc = b * b - c * cc
                t = cc / (ops.sqrt(ops.select(disc > 0, disc, 0.0)) - b)
                hit = (disc >= 0) & (t >= 0)
            px, py, pz = px + t * dx, py + t * dy, pz + t * dz
            a = ops.const(s.aperture_radius_mm)
            inside = hit & (px * px + py * py <= a * a)
            if s.is_stop and stop_mask is not None:
                inside = inside & stop_mask(px, py)
            if status:
                code = ops.select(ok & ~inside, ops.status(1 + i, ox), code)
            ok = ok & inside
            ox, oy, oz = px, py, pz + ops.const(zv)
            if not s.is_stop:
                e = eta[i]
                nx, ny, nz = c * px, c * py, c * pz - 1.0   # unit normal on the cap, toward -z
                cos_i = -(nx * dx + ny * dy + nz * dz)
                k = 1.0 - e * e * (1.0 - cos_i * cos_i)
                tir = k < 0
                if status:
                    code = ops.select(ok & tir, ops.status(1 + n_surf + i, ox), code)
                ok = ok & ~tir
                f = e * cos_i - ops.sqrt(ops.select(tir, 0.0, k))
                dx, dy, dz = e * dx + f * nx, e * dy + f * ny, e * dz + f * nz
        if sensor_z_mm is not None:
            fwd = dz > 0
            if status:
                code = ops.select(ok & ~fwd, ops.status(1 + 2 * n_surf, ox), code)
            ok = ok & fwd
            t = (ops.const(sensor_z_mm) - oz) / dz
            ox, oy, oz = ox + t * dx, oy + t * dy, oz + t * dz
        out = ((ox, oy, oz), (dx, dy, dz), ok)
        return out + (code,) if status else out
