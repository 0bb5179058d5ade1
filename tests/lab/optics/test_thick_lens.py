"""Thick lens as a list of surfaces: Snell's law, lensmaker's equation, apertures, focusing."""
import math

import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Float

from lab.errors import UserError
from lab.optics.glass import get_glass
from lab.optics.lens_camera import ThickLensCamera, best_focus_z_mm
from lab.optics.thick_lens import DRJIT, STATUS_OK, LensSystem

LAM = 587.5618


def parallel_rays(h, z0=-1.0):
    h = np.asarray(h, dtype=np.float64)
    zero = np.zeros_like(h)
    return (h, zero, np.full_like(h, z0)), (zero, zero, np.ones_like(h))


@pytest.mark.parametrize("r1, r2, t, glass", [(50.0, -50.0, 8.0, "N-BK7"), (30.0, -120.0, 6.0, "N-SF11"),
                                              (40.0, 200.0, 5.0, "F2")])
def test_traced_paraxial_focus_matches_the_lensmakers_equation_with_thickness(r1, r2, t, glass):
    lens = LensSystem([(0.0, 2.0, "air", 5.0), (r1, t, glass, 10.0), (r2, 0.0, "air", 10.0)])
    n = get_glass(glass).index(LAM)
    f = 1.0 / ((n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * t / (n * r1 * r2)))
    bfd = f * (1.0 - (n - 1.0) * t / (n * r1))
    h = 1e-3  # paraxial: spherical aberration ~ h^2 is far below the tolerance
    (ox, _, oz), (dx, _, dz), ok = lens.trace(*parallel_rays([h]), lens.relative_indices(LAM))
    assert ok.all()
    z_cross = oz[0] - ox[0] * dz[0] / dx[0]
    assert z_cross - lens.vertices_mm[-1] == pytest.approx(bfd, rel=1e-6)
    assert -h * dz[0] / dx[0] == pytest.approx(f, rel=1e-6)           # EFL from the exit slope
    assert lens.effective_focal_length_mm(LAM) == pytest.approx(f, rel=1e-9)
    assert lens.back_focal_distance_mm(LAM) == pytest.approx(bfd, rel=1e-9)


def test_spherical_aberration_marginal_rays_focus_shorter():
    lens = LensSystem([(0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 12.0), (-50.0, 0.0, "air", 12.0)])
    (ox, _, oz), (dx, _, dz), ok = lens.trace(*parallel_rays([0.5, 2.0, 4.0, 8.0]), lens.relative_indices(LAM))
    z = oz - ox * dz / dx
    assert ok.all() and np.all(np.diff(z) < 0)


def test_flat_slab_obeys_snell_and_shifts_rays_parallel():
    lens = LensSystem([(0.0, 1.0, "air", 20.0), (math.inf, 10.0, "N-SF11", 20.0), (math.inf, 0.0, "air", 20.0)])
    theta = math.radians(30.0)
    o = (np.array([0.0]), np.array([0.0]), np.array([-0.5]))
    d = (np.array([math.sin(theta)]), np.array([0.0]), np.array([math.cos(theta)]))
    (x, _, z), (dx, dy, dz), ok = lens.trace(o, d, lens.relative_indices(LAM))
    assert ok.all() and dx[0] == pytest.approx(math.sin(theta), abs=1e-12) and dy[0] == 0.0
    n = get_glass("N-SF11").index(LAM)
    theta_in = math.asin(math.sin(theta) / n)                     # n1 sin = n2 sin inside the slab
    expected_x = 1.5 * math.tan(theta) + 10.0 * math.tan(theta_in)
    assert z[0] == pytest.approx(11.0) and x[0] == pytest.approx(expected_x, rel=1e-9)


def test_total_internal_reflection_is_blocked_and_reported():
    lens = LensSystem([(0.0, 0.5, "air", 9.0), (math.inf, 10.0, "N-SF11", 9.0), (-10.0, 0.0, "air", 9.5)])
    # inside the glass a parallel ray meets the back sphere at asin(h / 10): above the critical
    # angle asin(1 / 1.78) = 34 degrees for h > 5.6 mm
    _, _, ok, code = lens.trace(*parallel_rays([2.0, 5.0, 7.0]), lens.relative_indices(LAM), status=True)
    assert ok.tolist() == [True, True, False]
    assert code.tolist() == [STATUS_OK, STATUS_OK, 1 + 3 + 2]


def test_apertures_block_and_say_where():
    lens = LensSystem([(0.0, 5.0, "air", 4.0), (50.0, 8.0, "N-BK7", 6.0), (-50.0, 0.0, "air", 6.0)])
    o, d = parallel_rays([3.9, 4.1])
    _, _, ok, code = lens.trace(o, d, lens.relative_indices(LAM), status=True)
    assert ok.tolist() == [True, False] and code.tolist() == [STATUS_OK, 1]
    # through the stop's centre at slope 1.5: 7.5 mm high at the lens (rim 6 mm) -> blocked there
    steep = (np.array([1.5 / math.hypot(1.5, 1.0)]), np.array([0.0]), np.array([1.0 / math.hypot(1.5, 1.0)]))
    _, _, ok, code = lens.trace((np.array([0.0]), np.array([0.0]), np.array([0.0])), steep,
                                lens.relative_indices(LAM), status=True)
    assert not ok[0] and code[0] == 2


def test_drjit_and_numpy_trace_agree():
    lens = LensSystem([(math.inf, 15.0, "air", 11.5), (0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 12.0),
                       (-50.0, 0.0, "air", 12.0)])
    rng = np.random.default_rng(4)
    n = 20_000
    o = (rng.uniform(-9, 9, n), rng.uniform(-9, 9, n), np.full(n, -1.0))
    d = np.stack([rng.normal(0, 0.2, n), rng.normal(0, 0.2, n), np.ones(n)])
    d /= np.linalg.norm(d, axis=0)
    eta = lens.relative_indices(475.0)
    (x, y, _), _, ok = lens.trace(o, tuple(d), eta, sensor_z_mm=66.0)
    (xj, yj, _), _, okj = lens.trace(tuple(Float(v) for v in o), tuple(Float(v) for v in d),
                                     [dr.opaque(Float, e) for e in eta], DRJIT, 66.0)
    okj = okj.numpy()
    both = ok & okj
    assert 0.3 < ok.mean() < 0.9 and (ok != okj).mean() < 1e-3
    assert np.abs(xj.numpy()[both] - x[both]).max() < 2e-3 and np.abs(yj.numpy()[both] - y[both]).max() < 2e-3


@pytest.mark.parametrize("rows, match", [
    ([(0.0, 5.0, "air", 4.0), (50.0, 8.0, "BK7", 6.0), (-50.0, 0.0, "air", 6.0)], "N-BK7"),
    ([(50.0, 8.0, "N-BK7", 6.0), (-50.0, 0.0, "air", 6.0)], "exactly one is needed"),
    ([(0.0, 5.0, "N-BK7", 4.0), (-50.0, 0.0, "air", 6.0)], "does not refract"),
    ([(0.0, 5.0, "air", 4.0), (50.0, 0.0, "N-BK7", 6.0)], "must be 'air'"),
    ([(0.0, 5.0, "air", 4.0), (50.0, 8.0, "N-BK7", 6.0), (-50.0, 3.0, "air", 6.0)], "last thickness_mm"),
    ([(0.0, 5.0, "air", 4.0), (5.0, 8.0, "N-BK7", 6.0), (-50.0, 0.0, "air", 6.0)], "spherical cap"),
    ([(0.0, 5.0, "air", 4.0), (20.0, 1.0, "N-BK7", 12.0), (-20.0, 0.0, "air", 12.0)], "intersect"),
    ([(0.0, -1.0, "air", 4.0), (50.0, 8.0, "N-BK7", 6.0), (-50.0, 0.0, "air", 6.0)], "thickness_mm"),
])
def test_bad_lens_rows_are_clear_errors(rows, match):
    with pytest.raises(UserError, match=match):
        LensSystem(rows)


def test_focusing_inside_the_front_focal_point_is_an_error_that_says_where():
    lens = LensSystem([(0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 12.0), (-50.0, 0.0, "air", 12.0)])
    ffd = lens.front_focus_distance_mm(LAM)
    assert lens.paraxial_image(ffd * 1.01, LAM) > 1000.0       # just beyond: a far image
    with pytest.raises(UserError, match="cannot focus") as e:
        lens.paraxial_image(ffd * 0.99, LAM)
    assert f"{ffd / 1000:.4g} m" in str(e.value)


def test_best_focus_lies_between_marginal_and_paraxial_focus():
    lens = LensSystem([(0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 12.0), (-50.0, 0.0, "air", 12.0)])
    paraxial = lens.paraxial_image(1e9, LAM)
    (ox, _, oz), (dx, _, dz), _ = lens.trace(*parallel_rays([8.8]), lens.relative_indices(LAM))
    marginal = oz[0] - ox[0] * dz[0] / dx[0]
    best = best_focus_z_mm(lens, 1e9, LAM)
    assert marginal < best < paraxial
    cam = ThickLensCamera.focused(lens, 1e6, (650.0, 510.0, 475.0), LAM, 1024, 36.0, "paraxial")
    assert cam.sensor_z_mm == pytest.approx(paraxial, abs=1e-3)
    assert cam.chief_scale_mm == pytest.approx(lens.effective_focal_length_mm(LAM), rel=1e-3)
