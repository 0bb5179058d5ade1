"""The rays a sensor point sends out through a thick lens, and how much of them gets through.

A camera that traces a :class:`~lab.optics.thick_lens.LensSystem` backward (the Mitsuba
reference, :mod:`lab.reference.thick_lens_sensor`) starts each ray at a sensor point s and aims
it at a point q on the plane just behind the rear element (its rearmost z), drawn uniformly in
a box that holds every q whose ray the lens lets through from s (pbrt-v4's exit-pupil bounds).
The ray is then traced through the reversed lens (:meth:`LensSystem.reversed`) by Snell's law;
blocked or totally reflected rays get weight 0.

Radiometry. The irradiance at s from radiance L is the integral of L cos^4(theta) / dz^2 over
the plane's area the lens lets through (theta: the ray's angle to the axis, dz: the sensor's
distance to the plane). Vignetting is renormalised, as the ``physical_lens`` PSF model
normalises its PSFs: the weight of a ray is ``pass * cos^4(theta) * box area / A(r)``, where
A(r), tabulated over the sensor radius r (the lens is rotation symmetric), is the
cos^4-weighted area that passes from a sensor point at r. A uniform field of radiance L then
images to L at every sensor point, in focus or not, and a point's light spreads as the lens
spreads it.

Tables. A stratified grid of plane points is traced (numpy, float64) from a sensor point (r, 0)
for each tabulated radius r; A(r) is linear between them. The box of a radius between two
tabulated ones is the union of theirs, widened by two grid cells, in the frame turned to the
sensor point's azimuth. :meth:`ExitPupil.sample` and :meth:`ExitPupil.trace` are written once
for numpy and Dr.Jit (the ``ops`` of :mod:`lab.optics.thick_lens`).

Shaped stop. With an iris or a stylized stop (:class:`~lab.optics.stop_shape.StopShape`) the
lens is no longer rotation symmetric: A depends on the sensor point's azimuth too, modulo the
shape's turn period. It is tabulated over :data:`STOP_TURNS` azimuths of a period as well
(bilinear, periodic in the azimuth) by tracing from (r, 0) through the stop turned back by the
azimuth; the boxes stay the round opening's, which hold the shape's.

Tilt-shift. A tilted sensor's point (sx, sy) lies gx sx + gy sy beyond the axial sensor plane; its
rays start there and A is tabulated over five such shifts as well (linear between them), each box
the union over them.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import drjit as dr
import numpy as np
from drjit.llvm import Float, UInt32

from lab.errors import UserError
from lab.optics.lens_camera import ThickLensCamera
from lab.optics.stop_shape import StopShape
from lab.optics.thick_lens import DRJIT, NUMPY, LensSystem, Ops

__all__ = ["ExitPupil", "STOP_TURNS"]

STOP_TURNS = 24   # tabulated azimuths per turn period of a shaped stop


@dataclass(frozen=True)
class ExitPupil:
    """The backward rays of one focused lens at one wavelength.

    Build with :meth:`build`. Lengths in mm, lens coordinates (:mod:`lab.optics.thick_lens`).

    Attributes
    ----------
    reversed_lens : LensSystem
        The lens seen from the sensor.
    eta : tuple of float
        Its relative indices at the wavelength.
    last_vertex_mm : float
        z of the lens's last vertex (z of the lens = last_vertex - z of the reversed lens).
    sensor_z_mm, plane_z_mm : float
        The sensor, and the plane behind the rear element the rays are aimed at.
    radii_mm : (n,) float64
        Sensor radii of the tables, 0 .. the largest sensor radius, evenly spaced.
    area_mm2 : (n,) float64
        A(r): the cos^4-weighted plane area that passes from a sensor point at each radius.
    boxes_mm : (n - 1, 3) float64
        Per interval of radii, (x0, x1, y1): the box [x0, x1] x [-y1, y1] that holds the passing
        plane points of a sensor point (r, 0) in it.
    slopes, shifts_mm, shift_area_mm2
        A tilted sensor's slopes (gx, gy), the shifts A is tabulated at and A per (shift, radius)
        (None untilted; ``area_mm2`` is the row at shift 0).
    stop_shape, turn_area_mm2
        A shaped stop and A per (azimuth, radius), the azimuths k P / STOP_TURNS of its period P
        (None for the round stop).
    """

    reversed_lens: LensSystem
    eta: tuple
    last_vertex_mm: float
    sensor_z_mm: float
    plane_z_mm: float
    radii_mm: np.ndarray
    area_mm2: np.ndarray
    boxes_mm: np.ndarray
    slopes: tuple = (0.0, 0.0)
    shifts_mm: np.ndarray = field(default_factory=lambda: np.zeros(1))
    shift_area_mm2: np.ndarray | None = None
    stop_shape: StopShape | None = None
    turn_area_mm2: np.ndarray | None = None

    @classmethod
    def build(cls, camera: ThickLensCamera, wavelength_nm: float, max_radius_mm: float, n_radii: int = 48,
              grid: int = 256, slopes=(0.0, 0.0), shift_mm: float = 0.0) -> "ExitPupil":
        """Tabulate A(r) and the boxes for a focused ``camera``.

        Parameters
        ----------
        camera : ThickLensCamera
            The lens with its sensor placed (:meth:`ThickLensCamera.focused`).
        wavelength_nm : float
            The wavelength traced.
        max_radius_mm : float
            The largest sensor radius used (the sensor's half diagonal).
        n_radii : int, default 48
            Tabulated radii from 0 to ``max_radius_mm``.
        grid : int, default 256
            Plane points per side of the stratified grid over a disc that holds every ray that
            can reach the rear element (about 0.79 grid^2 points inside it).
        slopes : (float, float), default (0, 0)
            A tilted sensor (tilt-shift): its z grows by gx per mm of sensor x and gy per mm of y
            (:meth:`runtime_cl.camera.thick_lens.ThickLens.sensor_slopes`).
        shift_mm : float, default 0
            The tilted sensor's largest distance from its axial plane: A is tabulated over five
            shifts in [-shift_mm, shift_mm] too (linear between them), and each box holds the union.

        Raises
        ------
        UserError
            The sensor cuts the rear element, or no ray from some sensor radius gets through (the
            message names the radius and the fix).
        """
        lens = camera.lens
        rear = lens.surfaces[-1]
        last = lens.vertices_mm[-1]
        sag = rear.sag(rear.aperture_radius_mm)
        plane_z = last + max(0.0, sag)
        gap = camera.sensor_z_mm - plane_z
        if not gap - shift_mm > 2.0 * abs(sag):
            raise UserError(f"the sensor (z = {camera.sensor_z_mm:.4g} mm) sits {gap:.3g} mm behind a rear element "
                            f"{abs(sag):.3g} mm deep; focus farther away or use a lens with a longer back focus")
        # a ray reaching the rear cap crosses the plane within rho of the axis:
        # rho = a + slope * |sag|, slope <= (max_radius + rho) / gap
        k = abs(sag) / (gap - shift_mm)
        rho = (rear.aperture_radius_mm + k * max_radius_mm) / (1.0 - k) * 1.01
        rev = lens.reversed()
        probe = cls(rev, rev.relative_indices(wavelength_nm), last, camera.sensor_z_mm, plane_z,
                    np.zeros(1), np.zeros(1), np.zeros((0, 3)))
        cell = 2.0 * rho / grid
        u = (np.arange(grid) + 0.5) * cell - rho
        qx, qy = (a.ravel() for a in np.meshgrid(u, u))
        inside = qx * qx + qy * qy <= rho * rho
        qx, qy = qx[inside], qy[inside]
        radii = np.linspace(0.0, max_radius_mm, n_radii)
        shifts = np.linspace(-shift_mm, shift_mm, 5) if shift_mm > 0 else np.zeros(1)
        area, box = np.zeros((len(shifts), n_radii)), np.zeros((n_radii, 3))
        box[:, 0], box[:, 1] = np.inf, -np.inf
        for i, dz in enumerate(shifts):
            for j, r in enumerate(radii):
                _, _, ok, cos4 = probe._trace_shifted(np.full_like(qx, r), np.zeros_like(qx), qx, qy, dz, NUMPY)
                if not ok.any():
                    raise UserError(f"no ray from the sensor {r:.3g} mm off axis gets through the lens (the image's "
                                    f"half diagonal is {max_radius_mm:.3g} mm): widen the apertures, or use a smaller "
                                    "sensor_width_mm")
                area[i, j] = float(np.sum(np.where(ok, cos4, 0.0))) * cell * cell
                box[j] = min(box[j, 0], qx[ok].min()), max(box[j, 1], qx[ok].max()), max(box[j, 2], np.abs(qy[ok]).max())
        margin = 2.0 * cell
        boxes = np.stack([np.minimum(box[:-1, 0], box[1:, 0]) - margin, np.maximum(box[:-1, 1], box[1:, 1]) + margin,
                          np.maximum(box[:-1, 2], box[1:, 2]) + margin], axis=1)
        shape, turn_area = camera.stop_shape, None
        if shape is not None:
            if shift_mm > 0:
                raise UserError("a shaped stop with a tilted sensor: the tilt-shift tables assume a round stop; "
                                "remove the aperture, or the tilt")
            turn_area = np.zeros((STOP_TURNS, n_radii))
            shaped = replace(probe, stop_shape=shape)
            sx, qxx, qyy = Float(np.repeat(radii, len(qx))), Float(np.tile(qx, n_radii)), Float(np.tile(qy, n_radii))
            for k in range(STOP_TURNS):   # every radius at once, in Dr.Jit (the numpy loop took seconds)
                back = -np.radians(shape.turn_period_deg) * k / STOP_TURNS
                _, _, ok, cos4 = shaped._trace_shifted(sx, sx * 0.0, qxx, qyy, 0.0, DRJIT,
                                                       turn=(float(np.cos(back)), float(np.sin(back))))
                turn_area[k] = dr.select(ok, cos4, 0.0).numpy().reshape(n_radii, -1).astype(np.float64).sum(axis=1)
            turn_area *= cell * cell
            if not np.all(turn_area > 0):
                r = radii[np.argwhere(turn_area <= 0)[0][1]]
                raise UserError(f"no ray from the sensor {r:.3g} mm off axis gets through the lens's shaped stop: "
                                "widen the stop, or use a smaller sensor_width_mm")
        return cls(probe.reversed_lens, probe.eta, last, camera.sensor_z_mm, plane_z, radii, area[len(shifts) // 2],
                   boxes, tuple(float(g) for g in slopes), shifts, area if shift_mm > 0 else None, shape, turn_area)

    def sample(self, sx, sy, u1, u2, ops: Ops = NUMPY):
        """Plane points for sensor points (sx, sy) from uniform numbers u1, u2 in [0, 1).

        Returns
        -------
        tuple
            ``(qx, qy, scale)``: the point, uniform in the box of the sensor point's radius turned
            to its azimuth, and box area / A(r) (a passing ray's weight is this times its cos^4).
        """
        r = ops.sqrt(sx * sx + sy * sy)
        step = float(self.radii_mm[1])
        t = _clip(r * (1.0 / step), len(self.radii_mm) - 1.000001, ops)
        j = _floor(t, ops)
        f = t - _float(j, ops)
        if self.turn_area_mm2 is not None:   # a shaped stop: A also linear in the azimuth (periodic)
            n, turns = len(self.radii_mm), STOP_TURNS
            period = np.radians(self.stop_shape.turn_period_deg)
            az = np.arctan2(sy, sx) if ops is NUMPY else dr.atan2(sy, sx)
            az = az * (1.0 / period)
            az = (az - (np.floor(az) if ops is NUMPY else dr.floor(az))) * turns
            az = _clip(az, turns - 1e-6, ops)
            k = _floor(az, ops)
            g = az - _float(k, ops)
            k1 = ops.select(k + 1 < turns, k + 1, k * 0)
            flat = self.turn_area_mm2.ravel()
            a0, a1 = ((1.0 - g) * _gather(flat, k * n + jj, ops) + g * _gather(flat, k1 * n + jj, ops)
                      for jj in (j, j + 1))
        elif self.shift_area_mm2 is None:
            a0, a1 = _gather(self.area_mm2, j, ops), _gather(self.area_mm2, j + 1, ops)
        else:   # a tilted sensor: A also linear in the point's shift along the axis
            n, top = len(self.radii_mm), float(self.shifts_mm[-1])
            dz = self.slopes[0] * sx + self.slopes[1] * sy
            u = _clip((dz + top) * ((len(self.shifts_mm) - 1) / (2.0 * top)), len(self.shifts_mm) - 1.000001, ops)
            u = ops.select(u > 0.0, u, 0.0)
            i = _floor(u, ops)
            g = u - _float(i, ops)
            flat = self.shift_area_mm2.ravel()
            a0, a1 = ((1.0 - g) * _gather(flat, i * n + jj, ops) + g * _gather(flat, (i + 1) * n + jj, ops)
                      for jj in (j, j + 1))
        x0, x1, y1 = (_gather(self.boxes_mm[:, k], j, ops) for k in range(3))
        bx, by = x0 + u1 * (x1 - x0), y1 * (2.0 * u2 - 1.0)
        inv = 1.0 / ops.select(r > 0, r, 1.0)
        cos, sin = ops.select(r > 0, sx * inv, 1.0), ops.select(r > 0, sy * inv, 0.0)
        return cos * bx - sin * by, sin * bx + cos * by, 2.0 * y1 * (x1 - x0) / (a0 + f * (a1 - a0))

    def trace(self, sx, sy, qx, qy, ops: Ops = NUMPY):
        """Backward rays from sensor points (sx, sy) aimed at plane points (qx, qy) (mm).

        Returns
        -------
        tuple
            ``(o, d, ok, cos4)``: where the ray leaves the lens's first surface and its unit
            direction (tuples of 3 arrays, lens coordinates, d_z < 0: toward the scene), whether
            it got through, and cos^4 of its angle to the axis behind the lens.
        """
        shift = self.slopes[0] * sx + self.slopes[1] * sy if self.slopes != (0.0, 0.0) else 0.0
        return self._trace_shifted(sx, sy, qx, qy, shift, ops)

    def _trace_shifted(self, sx, sy, qx, qy, shift, ops: Ops, turn=None):
        """:meth:`trace` from sensor points ``shift`` mm beyond the axial sensor plane (a shaped
        stop turned by the angle whose (cos, sin) is ``turn``)."""
        c = ops.const
        dz = c(self.sensor_z_mm - self.plane_z_mm) + shift
        vx, vy = qx - sx, qy - sy
        inv = 1.0 / ops.sqrt(vx * vx + vy * vy + dz * dz)
        cos = dz * inv
        o = (sx, sy, sx * 0.0 + c(self.last_vertex_mm - self.sensor_z_mm) - shift)   # reversed lens coordinates
        mask = None if self.stop_shape is None else self.stop_shape.mask(turn)   # x, y as in the lens
        (ox, oy, oz), (dx, dy, dz_out), ok = self.reversed_lens.trace(o, (vx * inv, vy * inv, cos), self.eta, ops,
                                                                      stop_mask=mask)
        cos2 = cos * cos
        return (ox, oy, c(self.last_vertex_mm) - oz), (dx, dy, -dz_out), ok, cos2 * cos2


def _clip(t, hi: float, ops: Ops):
    return ops.select(t < hi, t, hi)


def _floor(t, ops: Ops):
    """Integer part of t >= 0 (int64 / UInt32)."""
    return t.astype(np.int64) if ops is NUMPY else UInt32(t)


def _float(i, ops: Ops):
    return i.astype(np.float64) if ops is NUMPY else Float(i)


def _gather(values: np.ndarray, index, ops: Ops):
    """``values[index]`` in the backend's arrays."""
    return values[index] if ops is NUMPY else dr.gather(Float, Float(values), index)
