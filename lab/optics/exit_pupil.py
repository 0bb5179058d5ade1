"""The rays a sensor point sends out through a thick lens, and how much of them gets through.

A camera that traces a :class:`~lab.optics.thick_lens.LensSystem` backward (the Mitsuba
reference, :mod:`lab.reference.thick_lens_sensor`) starts each ray at a sensor point s and aims
it at a point q drawn uniformly on a disc: the plane just behind the rear element (its
rearmost z), with a radius that holds every ray the lens lets through from any point of the
sensor. The ray is then traced through the reversed lens (:meth:`LensSystem.reversed`) by
Snell's law; blocked or totally reflected rays get weight 0.

Radiometry. The irradiance at s from radiance L is the integral of L cos^4(theta) / dz^2 over
the disc area the lens lets through (theta: the ray's angle to the axis, dz: the sensor's
distance to the disc). Vignetting is renormalised, as the ``physical_lens`` PSF model
normalises its PSFs: the weight of a ray is ``pass * cos^4(theta) * disc area / A(r)``, where
A(r), tabulated here over the sensor radius r (the lens is rotation symmetric), is the
cos^4-weighted area that passes from a sensor point at r. A uniform field of radiance L then
images to L at every sensor point, in focus or not, and a point's light spreads as the lens
spreads it.

The table and the disc come from one numpy (float64) trace of a stratified grid of disc points
per tabulated radius; :meth:`ExitPupil.trace` is written once for numpy and Dr.Jit (the ``ops``
of :mod:`lab.optics.thick_lens`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

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
    sensor_z_mm : float
    disc_z_mm, disc_radius_mm : float
        The disc the rays are aimed at (behind the rear element).
    radii_mm : (n,) float64
        Sensor radii of the table, 0 .. the largest sensor radius, evenly spaced.
    area_mm2 : (n,) float64
        A(r): the cos^4-weighted disc area that passes from a sensor point at each radius.
    """

    reversed_lens: LensSystem
    eta: tuple
    last_vertex_mm: float
    sensor_z_mm: float
    disc_z_mm: float
    disc_radius_mm: float
    radii_mm: np.ndarray
    area_mm2: np.ndarray

    @classmethod
    def build(cls, camera: ThickLensCamera, wavelength_nm: float, max_radius_mm: float, n_radii: int = 48,
              grid: int = 256) -> "ExitPupil":
        """Tabulate A(r) and fit the disc for a focused ``camera``.

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
            Disc points per side of the stratified grid (about 0.79 grid^2 inside the disc).

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
        disc_z = last + max(0.0, sag)
        gap = camera.sensor_z_mm - disc_z
        if not gap > 0:
            raise UserError(f"the sensor (z = {camera.sensor_z_mm:.4g} mm) would cut the rear element (it reaches "
                            f"z = {disc_z:.4g} mm); focus farther away or use a lens with a longer back focus")
        # a ray reaching the rear cap crosses the disc's plane within rho of the axis:
        # rho = a + slope * |sag|, slope <= (max_radius + rho) / gap
        k = abs(sag) / gap
        if k >= 0.5:
            raise UserError(f"the sensor is {gap:.3g} mm behind a rear element {abs(sag):.3g} mm deep; move the "
                            "sensor back (focus farther) or flatten the rear surface")
        rho = (rear.aperture_radius_mm + k * max_radius_mm) / (1.0 - k) * 1.01
        rev = lens.reversed()
        eta = rev.relative_indices(wavelength_nm)
        probe = cls(rev, eta, last, camera.sensor_z_mm, disc_z, rho, np.zeros(1), np.zeros(1))
        cell = 2.0 * rho / grid
        u = (np.arange(grid) + 0.5) * cell - rho
        qx, qy = (a.ravel() for a in np.meshgrid(u, u))
        inside = qx * qx + qy * qy <= rho * rho
        qx, qy = qx[inside], qy[inside]
        radii = np.linspace(0.0, max_radius_mm, n_radii)
        area = np.zeros(n_radii)
        reach = 0.0
        for j, r in enumerate(radii):
            _, _, ok, cos4 = probe.trace(np.full_like(qx, r), np.zeros_like(qx), qx, qy)
            area[j] = float(np.sum(np.where(ok, cos4, 0.0))) * cell * cell
            if ok.any():
                reach = max(reach, float(np.sqrt(qx[ok] ** 2 + qy[ok] ** 2).max()))
        dark = radii[area <= 0]
        if dark.size:
            raise UserError(f"no ray from the sensor {dark[0]:.3g} mm off axis gets through the lens (the "
                            f"image's half diagonal is {max_radius_mm:.3g} mm): widen the apertures, or use a "
                            "smaller sensor_width_mm")
        radius = min(rho, reach + 1.5 * math.sqrt(2.0) * cell)   # the passing points and a margin
        return cls(rev, eta, last, camera.sensor_z_mm, disc_z, radius, radii, area)

    def trace(self, sx, sy, qx, qy, ops: Ops = NUMPY):
        """Backward rays from sensor points (sx, sy) aimed at disc points (qx, qy) (mm).

        Returns
        -------
        tuple
            ``(o, d, ok, cos4)``: where the ray leaves the lens's first surface and its unit
            direction (tuples of 3 arrays, lens coordinates, d_z < 0: toward the scene), whether
            it got through, and cos^4 of its angle to the axis behind the lens.
        """
        c = ops.const
        dz = c(self.sensor_z_mm - self.disc_z_mm)
        vx, vy = qx - sx, qy - sy
        inv = 1.0 / ops.sqrt(vx * vx + vy * vy + dz * dz)
        cos = dz * inv
        o = (sx, sy, sx * 0.0 + c(self.last_vertex_mm - self.sensor_z_mm))   # reversed lens coordinates
        (ox, oy, oz), (dx, dy, dz_out), ok = self.reversed_lens.trace(o, (vx * inv, vy * inv, cos), self.eta, ops)
        cos2 = cos * cos
        return (ox, oy, c(self.last_vertex_mm) - oz), (dx, dy, -dz_out), ok, cos2 * cos2

    def weight_scale(self, radius_mm):
        """pi disc_radius^2 / A(r) at sensor radii ``radius_mm`` (numpy; linear in the table): a
        passing ray's weight is this times its cos^4."""
        return math.pi * self.disc_radius_mm ** 2 / np.interp(radius_mm, self.radii_mm, self.area_mm2)
