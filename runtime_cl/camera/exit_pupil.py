"""Where a sensor point's backward rays can get through a thick lens: the runtime's exit-pupil boxes.

The runtime's twin of the boxes of :class:`lab.optics.exit_pupil.ExitPupil` (pbrt-v4's exit-pupil
bounds), for kernels that trace lens rays from the sensor (the layered tracer's thick lens). A ray
from sensor point s is aimed at a point q on the plane just behind the rear element, drawn
uniformly in a box that holds every q whose ray the lens lets through from s. The lens is rotation
symmetric, so the box is tabulated for sensor points (r, 0) over radii r and turned to the sensor
point's azimuth; the box of a radius between two tabulated ones is the union of theirs, widened by
two grid cells. The weight of a passing ray is cos^4 of its angle to the axis; a kernel that
divides by the sum of its rays' weights renormalises vignetting as the Mitsuba reference sensor
does (its A(r) cancels), so no area table is kept here.

One table serves every channel: each radius's box is the union over the channels' indices. A
tilted sensor (``shift_mm``: its largest distance from the axial sensor plane) makes each box the
union over sensor points shifted along the axis by up to that much.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from runtime_cl.camera.lens_trace import TracedLens
from runtime_cl.errors import InputError

__all__ = ["PupilBoxes"]


@dataclass(frozen=True)
class PupilBoxes:
    """Exit-pupil boxes of a lens traced backward (lengths in mm).

    Attributes
    ----------
    lens : TracedLens
        The lens seen from the sensor (:meth:`TracedLens.reversed`), its ``sensor_z_mm`` the last
        vertex of the forward lens.
    origin_z_mm : float
        z of the sensor in the reversed lens's coordinates (< 0: behind its first surface).
    plane_gap_mm : float
        Distance from the sensor to the plane the rays are aimed at.
    radius_step_mm : float
        Spacing of the tabulated sensor radii (0, step, ...).
    boxes_mm : (n - 1, 3) float64
        Per interval of radii, (x0, x1, y1): the box [x0, x1] x [-y1, y1] of the plane points whose
        rays pass from a sensor point (r, 0) in it.
    """

    lens: TracedLens
    origin_z_mm: float
    plane_gap_mm: float
    radius_step_mm: float
    boxes_mm: np.ndarray

    @classmethod
    def build(cls, lens: TracedLens, max_radius_mm: float, n_radii: int = 32, grid: int = 160,
              shift_mm: float = 0.0) -> "PupilBoxes":
        """Tabulate the boxes of the forward ``lens`` (sensor at ``lens.sensor_z_mm``).

        Parameters
        ----------
        lens : TracedLens
            Object side first, as :meth:`TracedLens.from_camera` gives it.
        max_radius_mm : float
            The largest sensor radius used (the image's half diagonal).
        n_radii : int, default 32
            Tabulated radii from 0 to ``max_radius_mm``.
        grid : int, default 160
            Plane points per side of the stratified grid over a disc holding every ray that can
            reach the rear element.
        shift_mm : float, default 0
            A tilted sensor's largest distance from its axial plane (mm): the boxes hold the rays
            of sensor points shifted by up to that much along the axis.

        Raises
        ------
        InputError
            The sensor cuts the rear element, or no ray from some sensor radius gets through.
        """
        c, a = float(lens.curvature[-1]), float(lens.aperture_mm[-1])
        last = float(lens.vertex_mm[-1])
        sag = c * a * a / (1.0 + math.sqrt(max(1.0 - c * c * a * a, 0.0)))
        plane_z = last + max(0.0, sag)
        gap = lens.sensor_z_mm - plane_z
        if not gap - shift_mm > 2.0 * abs(sag):
            raise InputError(f"thick lens: the sensor (z = {lens.sensor_z_mm:.4g} mm) sits {gap:.3g} mm behind a rear "
                             f"element {abs(sag):.3g} mm deep; no backward ray can be aimed past it (refocus farther)")
        # a ray reaching the rear cap crosses the plane within rho of the axis
        k = abs(sag) / (gap - shift_mm)
        rho = (a + k * max_radius_mm) / (1.0 - k) * 1.01
        cell = 2.0 * rho / grid
        u = (np.arange(grid) + 0.5) * cell - rho
        qx, qy = (v.ravel() for v in np.meshgrid(u, u))
        keep = qx * qx + qy * qy <= rho * rho
        qx, qy = qx[keep], qy[keep]
        probe = cls(lens.reversed(), last - lens.sensor_z_mm, gap, 1.0, np.zeros((0, 3)))
        radii = np.linspace(0.0, max_radius_mm, n_radii)
        box = np.zeros((n_radii, 3))
        # a tilted sensor: its points lie up to shift_mm off the axial plane; each box holds the
        # union over the shifts (a sensor point's own shift only narrows what passes)
        shifts = np.linspace(-shift_mm, shift_mm, 5) if shift_mm > 0 else np.zeros(1)
        for j, r in enumerate(radii):
            ok = np.zeros(len(qx), bool)
            for ch in range(len(lens.eta)):
                for dz in shifts:
                    ok |= probe.trace(r, 0.0, qx, qy, ch, dz)[2]
            if not ok.any():
                raise InputError(f"thick lens: no ray from the sensor {r:.3g} mm off axis gets through (the image's "
                                 f"half diagonal is {max_radius_mm:.3g} mm); widen the apertures or shrink the sensor")
            box[j] = qx[ok].min(), qx[ok].max(), np.abs(qy[ok]).max()
        margin = 2.0 * cell
        boxes = np.stack([np.minimum(box[:-1, 0], box[1:, 0]) - margin, np.maximum(box[:-1, 1], box[1:, 1]) + margin,
                          np.maximum(box[:-1, 2], box[1:, 2]) + margin], axis=1)
        return cls(probe.lens, probe.origin_z_mm, gap, float(radii[1]), boxes)

    @classmethod
    def for_camera(cls, camera, shape) -> "PupilBoxes":
        """The boxes of a :class:`~runtime_cl.camera.thick_lens.ThickLens` for an (H, W) image: up
        to the sensor's half diagonal, and a tilted sensor's reach along the axis."""
        h, w = (int(s) for s in shape)
        mm_px = camera.sensor_width_mm / w
        half_w, half_h = 0.5 * mm_px * w, 0.5 * mm_px * h
        gx, gy = camera.sensor_slopes() if getattr(camera, "tilted", False) else (0.0, 0.0)
        return cls.build(TracedLens.from_camera(camera), math.hypot(half_w, half_h),
                         shift_mm=abs(gx) * half_w + abs(gy) * half_h)

    def sample(self, sx, sy, u1, u2) -> tuple:
        """Plane points for sensor points (sx, sy) from uniform u1, u2 in [0, 1) (numpy, float64):
        uniform in the box of the point's radius turned to its azimuth; (qx, qy)."""
        sx, sy = np.asarray(sx, np.float64), np.asarray(sy, np.float64)
        r = np.hypot(sx, sy)
        j = np.minimum(r / self.radius_step_mm, len(self.boxes_mm) - 1e-6).astype(np.int64)
        x0, x1, y1 = self.boxes_mm[j].T
        bx, by = x0 + u1 * (x1 - x0), y1 * (2.0 * u2 - 1.0)
        safe = np.where(r > 0, r, 1.0)
        cos, sin = np.where(r > 0, sx / safe, 1.0), np.where(r > 0, sy / safe, 0.0)
        return cos * bx - sin * by, sin * bx + cos * by

    def trace(self, sx, sy, qx, qy, channel, dz=0.0) -> tuple:
        """Backward rays from (sx, sy) aimed at (qx, qy), in the forward lens's coordinates (numpy);
        ``dz``: the sensor point's z beyond the axial sensor plane (mm, a tilted sensor's gx sx + gy sy).

        Returns
        -------
        o, d : (m, 3) float64
            Where the ray leaves the first surface and its unit direction (d_z < 0: to the scene).
        ok : (m,) bool
        cos4 : (m,) float64
            cos^4 of the sensor-side ray's angle to the axis (its weight).
        """
        sx, sy, qx, qy, dz = np.broadcast_arrays(*(np.asarray(v, np.float64) for v in (sx, sy, qx, qy, dz)))
        d = np.stack([qx - sx, qy - sy, self.plane_gap_mm + dz], axis=1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        cos = d[:, 2].copy()
        o = np.stack([sx, sy, self.origin_z_mm - dz], axis=1)   # reversed lens: z' = L - z
        o, d, ok = self.lens.trace(o, d, channel, to_sensor=False)
        last = self.lens.sensor_z_mm
        return (np.stack([o[:, 0], o[:, 1], last - o[:, 2]], axis=1), np.stack([d[:, 0], d[:, 1], -d[:, 2]], axis=1),
                ok, cos ** 4)

    def kernel_table(self) -> np.ndarray:
        """The boxes as the kernels read them: (n - 1, 4) float32 rows (x0, x1, y1, 0)."""
        out = np.zeros((len(self.boxes_mm), 4), np.float32)
        out[:, :3] = self.boxes_mm
        return out
