"""Backward rays of a thick lens (the reference sensor's): exact, unbiased, refused when impossible.

- The lens seen from the sensor (``LensSystem.reversed``) has the same focal length, and a ray
  traced backward from a sensor point, then forward from a point on it, lands on that point.
- The weights renormalise vignetting: for a uniform field the mean weight is 1 at every sensor
  radius, between the tabulated ones too (the boxes hold every passing ray, A(r) interpolates).
"""
import math

import numpy as np
import pytest

from lab.errors import UserError
from lab.optics.exit_pupil import ExitPupil
from lab.optics.lens_camera import ThickLensCamera
from lab.optics.lenses import LENSES
from lab.optics.thick_lens import LensSystem

HALF_DIAGONAL = 0.5 * math.hypot(36.0, 24.0)


def _camera(rows, focus_m=2.0):
    return ThickLensCamera.focused(LensSystem(rows), focus_m, (650.0,), 587.5618, 1024, 36.0)


@pytest.mark.parametrize("name", sorted(LENSES))
def test_the_reversed_lens_has_the_same_focal_length_and_rows(name):
    lens = LensSystem(LENSES[name])
    rev = lens.reversed()
    for nm in (475.0, 650.0):
        assert rev.effective_focal_length_mm(nm) == pytest.approx(lens.effective_focal_length_mm(nm), rel=1e-12)
    assert rev.vertices_mm[-1] == lens.vertices_mm[-1] and rev.reversed().surfaces == lens.surfaces


@pytest.mark.parametrize("name", sorted(LENSES))
def test_a_backward_ray_retraced_forward_lands_on_its_sensor_point(name):
    cam = _camera(LENSES[name])
    pupil = ExitPupil.build(cam, 650.0, HALF_DIAGONAL)
    rng = np.random.default_rng(0)
    n = 4000
    sx, sy = np.full(n, 9.0), np.full(n, -4.0)
    qx, qy, _ = pupil.sample(sx, sy, rng.random(n), rng.random(n))
    o, d, ok, _ = pupil.trace(sx, sy, qx, qy)
    assert ok.mean() > 0.5 and np.all(d[2][ok] < 0)                   # out toward the scene
    p = tuple(o[i][ok] + 100.0 * d[i][ok] for i in range(3))           # a point 100 mm out on the ray
    (x, y, _), _, back = cam.lens.trace(p, tuple(-d[i][ok] for i in range(3)), cam.lens.relative_indices(650.0),
                                        sensor_z_mm=cam.sensor_z_mm)
    assert back.all()
    np.testing.assert_allclose(x, 9.0, atol=1e-9)
    np.testing.assert_allclose(y, -4.0, atol=1e-9)


@pytest.mark.parametrize("name", sorted(LENSES))
def test_a_uniform_field_has_mean_weight_one_at_every_sensor_radius(name):
    pupil = ExitPupil.build(_camera(LENSES[name]), 650.0, HALF_DIAGONAL)
    rng = np.random.default_rng(1)
    n = 400_000
    step = pupil.radii_mm[1]
    for r in (0.0, 7.0 * step, 20.5 * step, 33.25 * step, 40.75 * step, 46.5 * step, HALF_DIAGONAL):
        a = rng.random() * 2 * math.pi
        sx, sy = np.full(n, r * math.cos(a)), np.full(n, r * math.sin(a))
        qx, qy, scale = pupil.sample(sx, sy, rng.random(n), rng.random(n))
        _, _, ok, cos4 = pupil.trace(sx, sy, qx, qy)
        w = np.where(ok, cos4 * scale, 0.0)
        assert w.mean() == pytest.approx(1.0, abs=4 * w.std() / math.sqrt(n) + 1e-3), r   # ~0.2 % here
        assert ok.mean() > 0.6                                       # the boxes fit the passing rays


def test_the_vignetting_shows_in_the_table():
    pupil = ExitPupil.build(_camera(LENSES["singlet"]), 650.0, HALF_DIAGONAL)
    assert pupil.area_mm2[-1] < 0.6 * pupil.area_mm2[0]                  # cat-eye at the corners
    assert np.all(np.diff(pupil.area_mm2[pupil.radii_mm > 12.0]) < 0)


def test_a_lens_that_lets_nothing_through_to_the_corners_is_refused():
    # a narrow tube in front of the stop: the axis sees through it, the image's corners do not
    rows = ((math.inf, 40.0, "air", 2.0), (0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 12.0),
            (-50.0, 0.0, "air", 12.0))
    with pytest.raises(UserError, match=r"no ray from the sensor .* mm off axis gets through the lens .*"
                                        r"widen the apertures"):
        ExitPupil.build(_camera(rows), 650.0, HALF_DIAGONAL)
