"""Aperture samplers: uniform by area (chi-square), inside the shape, registry."""
import numpy as np
import pytest
from drjit.llvm import Array2f, Float
from scipy import stats

from lab.errors import UserError
from lab.optics.aperture import CircleAperture, aperture_names, get_aperture, make_aperture, register_aperture


def sample_points(aperture, n, seed):
    rng = np.random.default_rng(seed)
    u = rng.random((2, n), dtype=np.float32)
    p = aperture.sample(Array2f(Float(u[0]), Float(u[1])))
    return p.x.numpy().astype(np.float64), p.y.numpy().astype(np.float64)


def test_circle_is_uniform_by_area():
    x, y = sample_points(make_aperture("circle"), 200_000, seed=1)
    assert CircleAperture().contains(x, y).all()
    # 10 rings of equal area x 12 sectors: equal expected counts
    ring = np.minimum((x * x + y * y) * 10, 9).astype(int)
    sector = np.minimum((np.arctan2(y, x) + np.pi) / (2 * np.pi) * 12, 11).astype(int)
    counts = np.bincount(ring * 12 + sector, minlength=120)
    assert stats.chisquare(counts).pvalue > 1e-3
    # mean of r^2 over the unit disc is 1/2
    assert np.mean(x * x + y * y) == pytest.approx(0.5, abs=3e-3)


def test_circle_fills_the_disc_up_to_its_edge():
    x, y = sample_points(CircleAperture(), 100_000, seed=2)
    assert np.sqrt(x * x + y * y).max() > 0.999
    assert CircleAperture().area == pytest.approx(np.pi)


def test_registry():
    assert "circle" in aperture_names()
    assert get_aperture("circle") is CircleAperture
    with pytest.raises(UserError, match="circle"):
        get_aperture("hexagon-ish")
    with pytest.raises(UserError, match="bad parameters"):
        make_aperture("circle", blades=6)
    with pytest.raises(ValueError, match="twice"):
        register_aperture("circle")(type("Other", (), {}))
