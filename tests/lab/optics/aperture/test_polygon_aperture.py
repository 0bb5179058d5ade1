"""Polygonal iris: uniform by area (chi-square), inside the shape, area, orientation, rounding, errors."""
import math

import numpy as np
import pytest
from drjit.llvm import Array2f, Float
from scipy import stats

from lab.errors import UserError
from lab.optics.aperture import PolygonAperture, aperture_names, make_aperture

SHAPES = [PolygonAperture(6), PolygonAperture(5, rotation_deg=17.0, rounding=0.3),
          PolygonAperture(3), PolygonAperture(9, rounding=0.8)]


def sample_points(aperture, n, seed):
    rng = np.random.default_rng(seed)
    u = rng.random((2, n), dtype=np.float32)
    p = aperture.sample(Array2f(Float(u[0]), Float(u[1])))
    return p.x.numpy().astype(np.float64), p.y.numpy().astype(np.float64)


def regular_polygon_area(n):
    return 0.5 * n * math.sin(2 * math.pi / n)


@pytest.mark.parametrize("ap", SHAPES, ids=lambda a: f"{a.blades}b-{a.rounding}r")
def test_samples_are_inside_and_uniform_by_area(ap):
    n = 300_000
    x, y = sample_points(ap, n, seed=ap.blades)
    assert ap.contains(x, y).all()
    # 24 x 24 cells over [-1, 1]^2: the cells entirely inside the (convex) shape have equal area,
    # so their counts must be equal up to multinomial noise
    k = 24
    edges = np.linspace(-1, 1, k + 1)
    cx, cy = np.meshgrid(edges, edges, indexing="xy")
    corner_in = ap.contains(cx, cy)
    inside = corner_in[:-1, :-1] & corner_in[1:, :-1] & corner_in[:-1, 1:] & corner_in[1:, 1:]
    ix = np.minimum(((x + 1) / 2 * k).astype(int), k - 1)
    iy = np.minimum(((y + 1) / 2 * k).astype(int), k - 1)
    counts = np.bincount(iy * k + ix, minlength=k * k).reshape(k, k)
    assert inside.sum() > 150
    assert stats.chisquare(counts[inside]).pvalue > 1e-3
    # and the fraction landing in those cells is their share of the shape's area
    share = inside.sum() * (2 / k) ** 2 / ap.area
    assert counts[inside].sum() / n == pytest.approx(share, abs=4 * math.sqrt(share * (1 - share) / n))


@pytest.mark.parametrize("ap", SHAPES, ids=lambda a: f"{a.blades}b-{a.rounding}r")
def test_area_matches_the_indicator(ap):
    t = (np.arange(1200) + 0.5) / 1200 * 2 - 1
    covered = ap.contains(t[None, :], t[:, None]).mean() * 4
    assert ap.area == pytest.approx(covered, rel=2e-3)


def test_exact_areas_and_limits():
    for n in (3, 4, 6, 8):
        assert PolygonAperture(n).area == pytest.approx(regular_polygon_area(n), rel=1e-12)
    assert PolygonAperture(7, rounding=1.0).area == pytest.approx(math.pi, rel=1e-12)
    t = np.linspace(-1.2, 1.2, 301)
    x, y = np.meshgrid(t, t)
    np.testing.assert_array_equal(PolygonAperture(7, rounding=1.0).contains(x, y), x * x + y * y <= 1 + 1e-12)
    # rounding keeps the corners on the unit circle: samples reach radius 1 in a corner direction
    x, y = sample_points(PolygonAperture(6, rounding=0.4), 200_000, seed=3)
    assert np.hypot(x, y).max() == pytest.approx(1.0, abs=5e-3)
    assert np.hypot(x, y).max() <= 1.0 + 1e-6


@pytest.mark.parametrize("rotation, corner", [(0.0, (0.0, 1.0)), (90.0, (-1.0, 0.0)), (-30.0, (0.5, 0.866))])
def test_rotation_turns_a_corner_counter_clockwise_from_up(rotation, corner):
    ap = PolygonAperture(3, rotation_deg=rotation)
    x, y = sample_points(ap, 200_000, seed=4)
    proj = x * corner[0] + y * corner[1]
    assert proj.max() == pytest.approx(1.0, abs=5e-3)       # a corner reaches 1 in that direction
    assert (-proj).max() == pytest.approx(0.5, abs=5e-3)    # the opposite edge is at the apothem
    assert ap.contains(0.99 * corner[0], 0.99 * corner[1])
    assert not ap.contains(-0.6 * corner[0], -0.6 * corner[1])


def test_registry_and_parameters():
    assert {"circle", "polygon", "star", "heart", "image"} <= set(aperture_names())
    ap = make_aperture("polygon", blades=5, rotation_deg=10.0, rounding=0.2)
    assert (ap.blades, ap.rotation_deg, ap.rounding) == (5, 10.0, 0.2)
    assert make_aperture("polygon").blades == 6


@pytest.mark.parametrize("params, match", [
    ({"blades": 2}, "aperture_blades = 2"),
    ({"blades": 6.0}, "aperture_blades"),
    ({"blades": True}, "aperture_blades"),
    ({"blades": 65}, "aperture_blades"),
    ({"rounding": -0.1}, "aperture_rounding = -0.1"),
    ({"rounding": 1.5}, "aperture_rounding"),
    ({"rotation_deg": float("nan")}, "aperture_rotation_deg"),
    ({"petals": 3}, "bad parameters"),
])
def test_bad_parameters_are_user_errors(params, match):
    with pytest.raises(UserError, match=match):
        make_aperture("polygon", **params)


@pytest.mark.parametrize("blades,rotation,rounding", [(6, 0.0, 0.0), (5, 10.0, 0.0), (7, -20.0, 0.3), (4, 0.0, 1.0)])
def test_iris_outline_is_the_sampled_shape(blades, rotation, rounding):
    """lab.optics.iris (numpy, scene files and the polygon runtime) describes the same shape as the
    Dr.Jit sampler: its outline lies on the sampler's boundary."""
    from lab.optics.iris import Iris

    v = Iris(blades, rotation, rounding).outline()
    ap = PolygonAperture(blades=blades, rotation_deg=rotation, rounding=rounding)
    assert ap.contains(*(0.999 * v).T).all() and not ap.contains(*(1.001 * v).T).any()
    corners = np.arctan2(v[:, 1], v[:, 0])
    if rounding == 0:
        assert len(v) == blades
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0)
        assert np.degrees(corners[0]) == pytest.approx(90 + rotation)
