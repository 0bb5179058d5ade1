"""Re-centring through a thick lens: where a stochastic sample's surface lies in the pinhole image.

Through a thin lens a sample's displacement from its pinhole position is the CoC times its disc
point. Through a real lens it is whatever the lens makes of the ray (spherical aberration, the
cat-eye of vignetting, each wavelength its own), so the sample's ray itself is traced again. For
a ``"thick"`` camera the stochastic contract's ``lens.U, lens.V`` are the ray's exit-pupil box
sample: the ray from the pixel's sensor point is aimed at :meth:`PupilBoxes.sample` of (u, v),
the same backward trace the layered tracer uses (``kernels/layered/thick.cl``), and
:func:`lab.reference.stochastic` traces the scene with exactly these rays. A ray leaving the
lens is the line ``q(w) = a + b w`` in the pinhole image at the entrance pupil (w = 1/Z, Z the
planar depth from the pupil; the kernel file derives it), so a sample whose ray hit depth Z has
its surface at ``a + b / Z``. Each channel is traced with its own refractive indices (the
header's ``indices``): its samples return to their own positions, which undoes lateral colour.
A ray the lens blocks is no sample.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.stochastic.samples import film_points

__all__ = ["backward_rays", "is_thick", "ray_lines", "thick_positions"]


def is_thick(camera) -> bool:
    """Whether ``camera`` re-centres through its lens (:func:`thick_positions`)."""
    return getattr(camera, "lens", None) == "thick"


def backward_rays(camera, boxes: PupilBoxes, shape, film_xy, uv, channel) -> tuple:
    """Backward rays through the lens from film positions aimed at exit-pupil box samples.

    Parameters
    ----------
    camera : ThickLens
    boxes : PupilBoxes
        :meth:`PupilBoxes.for_camera` of the camera and ``shape``.
    shape : (H, W)
    film_xy : (m, 2)
        Film positions in pixels (x right, y down; pixel centres at i + 0.5).
    uv : (m, 2)
        Exit-pupil box samples in [0, 1).
    channel : int
        Which of the camera's wavelengths.

    Returns
    -------
    o, d : (m, 3) float64
        Where each ray leaves the lens and its unit direction towards the scene (lens
        coordinates, mm: x right and y up as seen from the camera, z from the scene into it).
    ok : (m,) bool
        The lens lets the ray through.
    """
    h, w = (int(s) for s in shape)
    mm_px = camera.sensor_width_mm / w
    film = np.asarray(film_xy, np.float64)
    sx, sy = -(film[:, 0] - 0.5 * w) * mm_px, (film[:, 1] - 0.5 * h) * mm_px   # the sensor sees the image inverted
    gx, gy = camera.sensor_slopes() if camera.tilted else (0.0, 0.0)
    uv = np.asarray(uv, np.float64)
    qx, qy = boxes.sample(sx, sy, uv[:, 0], uv[:, 1])
    o, d, ok, _ = boxes.trace(sx, sy, qx, qy, channel, dz=gx * sx + gy * sy)
    return o, d, ok & (d[:, 2] < 0)


def ray_lines(camera, boxes: PupilBoxes, shape, film_xy, uv, channel) -> tuple:
    """The pinhole-image lines of :func:`backward_rays` (same parameters): ``(a, b, ok)``, (m, 2)
    float64 each and (m,) bool; a ray's image position is ``a + b / Z`` at planar depth Z (m) from
    the entrance pupil (NaN where the lens blocks it)."""
    h, w = (int(s) for s in shape)
    f_px = camera.focal_px(w)
    o, d, ok = backward_rays(camera, boxes, shape, film_xy, uv, channel)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx, ty = d[:, 0] / -d[:, 2], d[:, 1] / -d[:, 2]   # slopes towards the scene
    zo = camera.pupil_z_mm - o[:, 2]                       # the exit point's depth from the pupil (mm)
    # image x runs with lens x, image y against lens y
    a = np.stack([0.5 * w + f_px * tx, 0.5 * h - f_px * ty], axis=1)
    b = np.stack([f_px * 1e-3 * (o[:, 0] - zo * tx), -f_px * 1e-3 * (o[:, 1] - zo * ty)], axis=1)
    a[~ok], b[~ok] = np.nan, np.nan
    return a, b, ok


def thick_positions(depth, samples, camera, channel: int, boxes: PupilBoxes | None = None) -> np.ndarray:
    """(H, W, 2) float64 pinhole positions y' (as :func:`~runtime_cl.stochastic.recentre.
    pinhole_positions`) of every pixel's surface through ``camera`` in ``channel``: each pixel's
    ray from its sample's film point (its centre without ``subpixel.X, subpixel.Y``) through its
    box sample (``samples[..., :2]``), at its depth; NaN where the lens blocks the ray."""
    h, w = np.shape(depth)
    boxes = boxes or PupilBoxes.for_camera(camera, (h, w))
    film = film_points(samples).reshape(-1, 2)
    a, b, _ = ray_lines(camera, boxes, (h, w), film, np.asarray(samples, np.float64)[..., :2].reshape(-1, 2), channel)
    z = np.asarray(depth, np.float64).reshape(-1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = a + np.where(np.isinf(z), 0.0, b / z)     # the sky: where the ray goes at infinity
    return pos.reshape(h, w, 2)
