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
"""
from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.llvm import Float, UInt32

from lab.errors import UserError
from lab.optics.lens_camera import ThickLensCamera
from lab.optics.thick_lens import NUMPY, LensSystem, Ops

__all__ = ["ExitPupil"]


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
    """

    reversed_lens: LensSystem
    eta: tuple
    last_vertex_mm: float
    sensor_z_mm: float
    plane_z_mm: float
    radii_mm: np.ndarray
    area_mm2: np.ndarray
    boxes_mm: np.ndarray

    @classmethod
    def build(cls, camera: ThickLensCamera, wavelength_nm: float, max_radius_mm: float, n_radii: int = 48,
              grid: int = 256) -> "ExitPupil":
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
        if not gap > 2.0 * abs(sag):
            raise UserError(f"the sensor (z = {camera.sensor_z_mm:.4g} mm) sits {gap:.3g} mm behind a rear element "
                            f"{abs(sag):.3g} mm deep; focus farther away or use a lens with a longer back focus")
        # a ray reaching the rear cap crosses the plane within rho of the axis:
        # rho = a + slope * |sag|, slope <= (max_radius + rho) / gap
        k = abs(sag) / gap
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
        area, box = np.zeros(n_radii), np.zeros((n_radii, 3))
        for j, r in enumerate(radii):
            _, _, ok, cos4 = probe.trace(np.full_like(qx, r), np.zeros_like(qx), qx, qy)
            if not ok.any():
                raise UserError(f"no ray from the sensor {r:.3g} mm off axis gets through the lens (the image's "
                                f"half diagonal is {max_radius_mm:.3g} mm): widen the apertures, or use a smaller "
                                "sensor_width_mm")
            area[j] = float(np.sum(np.where(ok, cos4, 0.0))) * cell * cell
            box[j] = qx[ok].min(), qx[ok].max(), np.abs(qy[ok]).max()
        margin = 2.0 * cell
        boxes = np.stack([np.minimum(box[:-1, 0], box[1:, 0]) - margin, np.maximum(box[:-1, 1], box[1:, 1]) + margin,
                          np.maximum(box[:-1, 2], box[1:, 2]) + margin], axis=1)
        return cls(probe.reversed_lens, probe.eta, last, camera.sensor_z_mm, plane_z, radii, area, boxes)

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
        a0, a1 = _gather(self.area_mm2, j, ops), _gather(self.area_mm2, j + 1, ops)
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
        c = ops.const
        dz = c(self.sensor_z_mm - self.plane_z_mm)
        vx, vy = qx - sx, qy - sy
        inv = 1.0 / ops.sqrt(vx * vx + vy * vy + dz * dz)
        cos = dz * inv
        o = (sx, sy, sx * 0.0 + c(self.last_vertex_mm - self.sensor_z_mm))   # reversed lens coordinates
        (ox, oy, oz), (dx, dy, dz_out), ok = self.reversed_lens.trace(o, (vx * inv, vy * inv, cos), self.eta, ops)
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
