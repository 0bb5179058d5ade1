"""A thick lens with a shaped stop (an iris, a star): the ``physical_lens`` PSF light-traced from
the point (forward) against the same lens traced backward from the sensor as the Mitsuba reference
sensor does (:class:`lab.optics.exit_pupil.ExitPupil`: pixels' rays through the reversed lens,
counting those that pass a small disc around the point). The two share only the lens surfaces and
the stop raster, so they agree only if the stop's orientation, its turn for an off-axis azimuth
(symmetry ``stop_turn``) and the pixel mapping all agree; a stop turned by 180 degrees or left
unturned off axis is rejected."""
import math

import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Float
from scipy.signal import fftconvolve

from lab.optics.exit_pupil import ExitPupil
from lab.optics.lens_camera import ThickLensCamera
from lab.optics.stop_shape import StopShape
from lab.optics.thick_lens import DRJIT
from lab.psf_tracing.models import load_model

HOODED = ((math.inf, 30.0, "air", 22.0), (0.0, 20.0, "air", 20.0), (100.0, 14.0, "N-BK7", 25.0),
          (-100.0, 0.0, "air", 25.0))            # tiny_rain's lens: rays are drawn on the stop
CEMENTED = ((120.0, 8.0, "N-BK7", 22.0), (-400.0, 6.0, "air", 22.0), (0.0, 6.0, "air", 14.0),
            (150.0, 8.0, "N-BK7", 22.0), (-150.0, 0.0, "air", 22.0))   # glass in front of the stop
WIDTH, HEIGHT, SENSOR_MM, FOCUS_M, DEPTH_M = 96, 96, 24.0, 1.0, 5.0
R, WINDOW, DISC_PX = 61, 21, 1.0      # PSF image, compared window, the light's radius in the pinhole image


def backward_psf(cam, shape, depth_m, ecc_px, azimuth_deg, size=WINDOW, rays=16000, seed=0):
    """The image of a small disc (``DISC_PX`` in radius in the pinhole image) around the point at
    ``ecc_px``, ``azimuth_deg`` about the image centre, ``depth_m`` from the entrance pupil: per
    pixel of a size^2 window around its pinhole image, rays from the sensor through the reversed
    lens (one wavelength, 587.6 nm), weighted as the reference sensor weights them; sums to 1."""
    pupil = ExitPupil.build(ThickLensCamera.focused(cam.lens, FOCUS_M, (587.5618,), 587.5618, WIDTH, SENSOR_MM,
                                                    "best", shape), 587.5618, 0.5 * math.hypot(SENSOR_MM, SENSOR_MM))
    k = WIDTH / SENSOR_MM                                   # px per mm on the sensor
    a = math.radians(azimuth_deg)
    tan_f = ecc_px / (k * cam.chief_scale_mm)
    depth = depth_m * 1000.0
    point = np.array([tan_f * depth * math.cos(a), tan_f * depth * math.sin(a), cam.pupil_z_mm - depth])
    eps = DISC_PX * depth / (k * cam.chief_scale_mm)
    col0, row0 = WIDTH / 2 + ecc_px * math.cos(a), HEIGHT / 2 - ecc_px * math.sin(a)
    rng = np.random.default_rng(seed)
    i, j = np.divmod(np.repeat(np.arange(size * size), rays), size)     # every pixel's rays at once
    col = col0 + j - size // 2 + rng.random(i.size)
    row = row0 + i - size // 2 + rng.random(i.size)
    sx, sy = Float(-(col / WIDTH - 0.5) * SENSOR_MM), Float((row / HEIGHT - 0.5) * SENSOR_MM)
    qx, qy, scale = pupil.sample(sx, sy, Float(rng.random(i.size)), Float(rng.random(i.size)), DRJIT)
    (ox, oy, oz), (dx, dy, dz), ok, cos4 = pupil.trace(sx, sy, qx, qy, DRJIT)
    t = (float(point[2]) - oz) / dz
    ex, ey = ox + t * dx - float(point[0]), oy + t * dy - float(point[1])
    w = dr.select(ok & (ex * ex + ey * ey <= eps * eps), cos4 * scale, 0.0)
    out = np.bincount(i * size + j, weights=w.numpy(), minlength=size * size).reshape(size, size)
    return out / out.sum()


def forward_psf(surfaces, blades, rotation_deg, ecc_px, azimuth_deg):
    """The physical_lens PSF of the same point (green channel), drawn as the runtime draws it:
    traced at azimuth 0 through the stop turned by minus the azimuth, turned by the azimuth
    (a multiple of 90 degrees here, so np.rot90 turns it exactly)."""
    m = load_model("physical_lens", {"surfaces": surfaces, "focus_distance_m": FOCUS_M, "width_px": WIDTH,
                                     "sensor_width_mm": SENSOR_MM, "sensor_height_mm": SENSOR_MM,
                                     "near_m": 0.5, "far_m": 8.0, "psf_resolution": R, "samples": 4,
                                     "aperture": "polygon", "aperture_blades": blades,
                                     "aperture_rotation_deg": rotation_deg, "wavelengths_nm": (587.5618,) * 3})
    point = [DEPTH_M, ecc_px, azimuth_deg % m.camera.stop_shape.turn_period_deg]
    psf = m.trace_box(point, point, n_rays=2 ** 21, seed=2).psf[..., 1].astype(np.float64)
    psf = np.rot90(psf, int(azimuth_deg // 90))
    # the light's disc, as the backward trace sees it: its pinhole image blurs the PSF
    sub = (np.arange(8) + 0.5) / 8 - 0.5
    disc = np.array([[np.mean((x + sub[None, :]) ** 2 + (y + sub[:, None]) ** 2 <= DISC_PX ** 2)
                      for x in range(-3, 4)] for y in range(-3, 4)])
    psf = fftconvolve(psf, disc / disc.sum(), mode="same")
    c, h = R // 2, WINDOW // 2
    psf = psf[c - h:c + h + 1, c - h:c + h + 1]
    return psf / psf.sum(), m.camera


@pytest.mark.parametrize("surfaces", [HOODED, CEMENTED], ids=["stop-drawn", "glass-in-front"])
@pytest.mark.parametrize("ecc, azimuth", [(0.0, 0.0), (30.0, 90.0)])
def test_forward_psf_matches_the_backward_trace_through_a_pentagon_stop(surfaces, ecc, azimuth):
    forward, cam = forward_psf(surfaces, 5, 0.0, ecc, azimuth)
    radius = cam.lens.surfaces[cam.lens.stop].aperture_radius_mm
    iris = StopShape.from_params({"aperture": "polygon", "blades": 5, "rotation_deg": 0.0, "rounding": 0.0}, radius)
    backward = backward_psf(cam, iris, DEPTH_M, ecc, azimuth)
    flipped = backward_psf(cam, StopShape.from_params({"aperture": "polygon", "blades": 5, "rotation_deg": 180.0,
                                                       "rounding": 0.0}, radius), DEPTH_M, ecc, azimuth)
    err = np.abs(forward - backward).sum()
    turn, turn_flipped = (pentagon_turn(forward) - pentagon_turn(b) for b in (backward, flipped))
    assert err < 0.35, err                  # 0.24-0.27 measured: the backward trace's noise
    # a pentagon turned by 180 degrees is turned by 36 (mod 72): 0.63 rad
    assert abs(turn) < 0.1 and abs(turn_flipped) > 0.8 * math.pi / 5, (turn, turn_flipped)


def pentagon_turn(psf) -> float:
    """The orientation of a five-fold shape in radians (modulo 72 degrees, in (-36, 36]): the phase
    of its fifth angular moment about the centroid, divided by 5 (image x right, y up)."""
    rows, cols = np.mgrid[:psf.shape[0], :psf.shape[1]]
    p = psf / psf.sum()
    z = (cols - (p * cols).sum()) - 1j * (rows - (p * rows).sum())
    return float(np.angle((p * z ** 5).sum())) / 5
