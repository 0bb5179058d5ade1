"""Dr.Jit thin lens against the runtime's numpy mirror and first principles."""
import math

import numpy as np
import pytest
from drjit.llvm import Array2f, Float, Float64

from lab.errors import UserError
from lab.optics.thin_lens import ThinLens
from runtime_cl.camera.thin_lens import ThinLens as NumpyThinLens

LENSES = [ThinLens(50, 2.0, 3.0, 36), ThinLens(35, 1.4, 0.6, 24), ThinLens(200, 5.6, 50.0, 36)]
W = 1920


def depths(lens):
    """Many depths: log-spaced, the focus plane, infinity, and just beyond the focal length."""
    f = lens.focal_length_m
    z = np.geomspace(f * 1.0001, 1e4, 2000)
    return np.concatenate([z, [lens.focus_distance_m, np.inf, f * (1 + 1e-6), f * (1 + 1e-3)]])


@pytest.mark.parametrize("lens", LENSES)
def test_coc_float32_matches_numpy_mirror(lens):
    z = depths(lens)
    want = NumpyThinLens(lens.focal_length_mm, lens.f_number, lens.focus_distance_m,
                         lens.sensor_width_mm).coc_radius_px(z, W)
    got = lens.coc_radius_px_dr(Float(z), W).numpy().astype(np.float64)
    # float32: a few ulp of the larger of the two terms scale/F and scale/z
    tol = 4e-7 * lens.coc_scale_px(W) * (1 / lens.focus_distance_m + 1 / z) + 1e-6
    assert np.all(np.abs(got - want) <= tol)
    assert got[-4] == 0.0  # focus plane: exactly in focus
    assert got[-3] == pytest.approx(lens.max_far_coc_px(W), rel=1e-6)


@pytest.mark.parametrize("lens", LENSES)
def test_coc_float64_matches_numpy_mirror(lens):
    z = depths(lens)
    got = lens.coc_radius_px_dr(Float64(z), W).numpy()
    np.testing.assert_allclose(got, lens.coc_radius_px(z, W), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("lens", LENSES)
def test_inverse_depth_inverts_coc(lens):
    r = np.linspace(-500, lens.max_far_coc_px(W), 101)
    inv_z = lens.inv_depth_for_coc_px(Float64(r), W).numpy()
    assert inv_z[-1] == pytest.approx(0.0, abs=1e-12)  # the far limit is infinity
    np.testing.assert_allclose(lens.coc_radius_px(1.0 / inv_z[:-1], W), r[:-1], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("lens", LENSES)
@pytest.mark.parametrize("z", [0.3, 1.0, 7.0, np.inf])
def test_ray_transfer_lands_on_the_coc(lens, z):
    """Lens point h lands at (h / a) r(z) in image axes (x right, y up; rows = -y)."""
    if z <= lens.focal_length_m:
        pytest.skip("no real image")
    a = lens.aperture_radius_m
    angle = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    h = Array2f(Float(a * np.cos(angle)), Float(a * np.sin(angle)))
    off = lens.psf_offset_px(h, Float(1.0 / z), W)
    r = float(lens.coc_radius_px(z, W))
    np.testing.assert_allclose(off.x.numpy(), r * np.cos(angle), atol=2e-3 + 1e-5 * abs(r))
    np.testing.assert_allclose(off.y.numpy(), -r * np.sin(angle), atol=2e-3 + 1e-5 * abs(r))


def test_sensor_is_at_image_distance_focus_plane_is_sharp():
    lens = LENSES[0]
    a = lens.aperture_radius_m
    h = Array2f(Float([a, -a, 0.3 * a]), Float([0.0, 0.5 * a, -a]))
    hit = lens.trace_to_sensor(h, Float(1.0 / lens.focus_distance_m))
    assert np.abs(hit.x.numpy()).max() < 1e-9 and np.abs(hit.y.numpy()).max() < 1e-9
    assert lens.image_distance_m == pytest.approx(1 / (1 / 0.05 - 1 / 3.0))


def test_chief_ray_of_an_off_axis_point_is_depth_independent():
    lens = LENSES[0]
    slope = Array2f(0.1, -0.05)
    for inv_z in (0.0, 0.2, 1.5):
        hit = lens.trace_to_sensor(Array2f(0.0, 0.0), Float(inv_z), slope)
        assert hit.x[0] == pytest.approx(-lens.image_distance_m * 0.1, rel=1e-6)
        assert hit.y[0] == pytest.approx(lens.image_distance_m * 0.05, rel=1e-6)


def test_refraction_is_slope_minus_height_over_f():
    lens = LENSES[1]
    out = lens.refract(Array2f(0.01, -0.002), Array2f(0.1, 0.0))
    assert out.x[0] == pytest.approx(0.1 - 0.01 / 0.035, rel=1e-6)
    assert out.y[0] == pytest.approx(0.002 / 0.035, rel=1e-6)


def test_bad_lens_is_a_user_error():
    with pytest.raises(UserError, match="focus_distance_m"):
        ThinLens(50, 2.0, 0.04, 36)
    with pytest.raises(UserError, match="f_number"):
        ThinLens(50, -2.0, 3.0, 36)
    assert math.isclose(LENSES[0].pixels_per_metre(1000), 1000 / 0.036)
