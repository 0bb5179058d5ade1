"""Tilt-shift for the thick lens: the sensor tilt that focuses a plane (Scheimpflug through the real lens).

The thin lens's tilt follows from the lens equation (:func:`runtime_cl.camera.focal_surface.
scheimpflug_tilt`). A thick lens images a plane onto a plane only paraxially, so the tilt is found
from the lens itself: each 3-D point of the focal plane is traced as a fan of rays over the
entrance pupil (exactly, at the focus wavelength) and its image is the point nearest to all the
traced rays (least squares); the sensor plane z = z0 + gx x + gy y is the least-squares plane
through the images. Its slopes (gx, gy) are the tilt, and z0 places the sensor: the focus distance
becomes the axial distance the focusing rule puts at z0 (:func:`distance_for_sensor_z`). The images
of a plane are not quite a plane (field curvature), so the points the user chose are the ones
kept sharp, not the axis.
"""
from __future__ import annotations

import math

import numpy as np

from lab.errors import UserError
from lab.optics.thick_lens import NUMPY, LensSystem

__all__ = ["distance_for_sensor_z", "image_point_mm", "sensor_plane"]

_FAN = 24   # rings and spokes of each point's fan (576 rays)


def image_point_mm(lens: LensSystem, point_mm, wavelength_nm: float) -> np.ndarray:
    """(3,) the image of the object point ``point_mm`` (lens coordinates): the point nearest, in
    least squares, to the rays of a fan area-uniform over the entrance pupil that get through."""
    z_ep, r_ep = lens.entrance_pupil(wavelength_nm)
    ring = np.sqrt((np.arange(_FAN) + 0.5) / _FAN) * r_ep
    phi = 2 * np.pi * (np.arange(_FAN) + 0.5) / _FAN
    hx = (ring[:, None] * np.cos(phi)[None, :]).ravel()
    hy = (ring[:, None] * np.sin(phi)[None, :]).ravel()
    px, py, pz = (float(v) for v in point_mm)
    v = np.stack([hx - px, hy - py, np.full_like(hx, z_ep - pz)], axis=1)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    start = min(0.0, lens.surfaces[0].sag(lens.surfaces[0].aperture_radius_mm)) - 1e-6
    t = (start - pz) / v[:, 2]
    o = (px + t * v[:, 0], py + t * v[:, 1], pz + t * v[:, 2])
    (ox, oy, oz), (dx, dy, dz), ok = lens.trace(o, (v[:, 0], v[:, 1], v[:, 2]), lens.relative_indices(wavelength_nm),
                                               NUMPY)
    if np.count_nonzero(ok) < 16:
        raise UserError(f"the lens passes (almost) no rays from the focus point {np.round(point_mm, 1).tolist()} mm; "
                        "choose focus points nearer the middle of the view")
    o = np.stack([ox, oy, oz], axis=1)[ok]
    d = np.stack([dx, dy, dz], axis=1)[ok]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    proj = np.eye(3)[None] - d[:, :, None] * d[:, None, :]          # (m, 3, 3): I - d d^T
    return np.linalg.solve(proj.sum(0), np.einsum("mij,mj->i", proj, o))


def sensor_plane(lens: LensSystem, points_m: np.ndarray, pupil_z_mm: float, wavelength_nm: float) -> tuple:
    """(z0, gx, gy): the sensor plane z = z0 + gx x + gy y (mm, lens coordinates) that focuses the
    camera-space ``points_m`` ((n, 3), metres from the entrance pupil; x image-right, y up, z depth),
    n >= 3 not collinear: the least-squares plane through their traced images (module docstring)."""
    pts = np.asarray(points_m, np.float64)
    lens_pts = np.stack([pts[:, 0] * 1000.0, pts[:, 1] * 1000.0, pupil_z_mm - pts[:, 2] * 1000.0], axis=1)
    images = np.array([image_point_mm(lens, p, wavelength_nm) for p in lens_pts])
    a = np.c_[np.ones(len(images)), images[:, 0], images[:, 1]]
    coef, *_ = np.linalg.lstsq(a, images[:, 2], rcond=None)
    z0, gx, gy = (float(v) for v in coef)
    if not all(math.isfinite(v) for v in (z0, gx, gy)):
        raise UserError("focus_points: their images fit no sensor plane; choose points spread across the view")
    return z0, gx, gy


def distance_for_sensor_z(lens: LensSystem, sensor_z_mm: float, wavelength_nm: float, focus: str = "best") -> float:
    """The axial distance (m, from the entrance pupil) the focusing rule puts at ``sensor_z_mm``
    (bisection on 1/distance: the image moves back as the object comes nearer)."""
    from scipy.optimize import brentq

    from lab.optics.lens_camera import best_focus_z_mm

    def image_z(inv_m: float) -> float:
        d = 1000.0 / inv_m
        return lens.paraxial_image(d, wavelength_nm) if focus == "paraxial" else best_focus_z_mm(lens, d, wavelength_nm)

    efl = lens.effective_focal_length_mm(wavelength_nm)
    lo, hi = 1e-3, 0.5 * 1000.0 / efl          # 1 km .. two focal lengths away
    if not image_z(lo) < sensor_z_mm < image_z(hi):
        raise UserError(f"the focus points' images need the sensor at z = {sensor_z_mm:.4g} mm, beyond what the lens "
                        f"focuses between 1 km and {2 * efl / 1000:.3g} m; choose focus points farther away")
    return 1.0 / brentq(lambda v: image_z(v) - sensor_z_mm, lo, hi, xtol=1e-12)
