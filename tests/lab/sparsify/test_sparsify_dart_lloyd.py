"""Dart throwing (Poisson disks with importance-driven radii) and Lloyd relaxation."""
import math

import numpy as np
import pytest

from lab.sparsify import analytic
from lab.sparsify.dart import throw_darts
from lab.sparsify.laplacian import importance, psf_laplacian
from lab.sparsify.lloyd import lloyd, quantisation_energy


@pytest.fixture(scope="module")
def rim():
    f = analytic.prefiltered_disc(96, 30.0, 3.0)
    imp = importance(f, psf_laplacian(f))
    sy, sx = np.nonzero(imp > 0)
    return sy, sx, imp[sy, sx], imp.shape


def test_dart_throwing_respects_each_candidates_radius(rim):
    sy, sx, w, shape = rim
    mass = 1.0
    py, px = throw_darts(sy, sx, w, mass, np.random.default_rng(0), 2000, shape)
    r2 = dict(zip(zip(sy.tolist(), sx.tolist()), (mass / (math.pi * w)).tolist()))
    for i in range(1, py.size):  # each point was checked against all earlier ones
        d2 = (py[:i] - py[i]) ** 2 + (px[:i] - px[i]) ** 2
        assert d2.min() > 0 and d2.min() >= r2[(py[i], px[i])] - 1e-9


def test_dart_points_are_support_pixels_and_cover_it(rim):
    sy, sx, w, shape = rim
    mass = 1.0
    py, px = throw_darts(sy, sx, w, mass, np.random.default_rng(1), 10_000, shape)
    support = set(zip(sy.tolist(), sx.tolist()))
    assert all((y, x) in support for y, x in zip(py.tolist(), px.tolist()))
    # 10 000 failures in a row: (nearly) every pixel's disk already holds a point (maximality)
    d2 = ((sy[:, None] - py[None]) ** 2 + (sx[:, None] - px[None]) ** 2).min(axis=1)
    covered = d2 < mass / (math.pi * w)
    assert np.sum(w[covered]) >= 0.99 * w.sum()


def test_dart_throwing_stops_and_is_seeded(rim):
    sy, sx, w, shape = rim
    a = throw_darts(sy, sx, w, 1.0, np.random.default_rng(5), 50, shape)
    b = throw_darts(sy, sx, w, 1.0, np.random.default_rng(5), 50, shape)
    c = throw_darts(sy, sx, w, 1.0, np.random.default_rng(6), 50, shape)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not (np.array_equal(a[0], c[0]) and np.array_equal(a[1], c[1]))


def test_dart_count_follows_the_mass(rim):
    sy, sx, w, shape = rim
    counts = [throw_darts(sy, sx, w, m, np.random.default_rng(0), 10_000, shape)[0].size
              for m in (4.0, 2.0, 1.0)]
    assert counts[0] < counts[1] < counts[2]
    assert 1.4 < counts[2] / counts[1] < 2.6  # area per disk ~ mass: about twice the points


def test_lloyd_reduces_weighted_quantisation_energy(rim):
    sy, sx, w, shape = rim
    py, px = throw_darts(sy, sx, w, 2.0, np.random.default_rng(2), 10_000, shape)
    before = quantisation_energy(sy, sx, w, py, px, shape)
    ly, lx = lloyd(sy, sx, w, py, px, 50)
    after = quantisation_energy(sy, sx, w, ly, lx, shape)
    assert after < before
    assert len(set(zip(ly.tolist(), lx.tolist()))) == ly.size  # distinct after rounding
    assert ly.size <= py.size


def test_lloyd_spreads_clumped_points_over_a_uniform_square():
    sy, sx = np.nonzero(np.ones((32, 32), bool))
    w = np.ones(sy.size)
    py, px = np.divmod(np.arange(16), 4)  # all 16 points in one corner
    before = quantisation_energy(sy, sx, w, py, px, (32, 32))
    ly, lx = lloyd(sy, sx, w, py, px, 50)
    after = quantisation_energy(sy, sx, w, ly, lx, (32, 32))
    assert after < 0.2 * before
    assert ly.size == 16 and np.ptp(ly) > 16 and np.ptp(lx) > 16


def test_lloyd_without_iterations_keeps_the_points(rim):
    sy, sx, w, shape = rim
    py, px = throw_darts(sy, sx, w, 2.0, np.random.default_rng(2), 1000, shape)
    ly, lx = lloyd(sy, sx, w, py, px, 0)
    assert np.array_equal(ly, py) and np.array_equal(lx, px)
