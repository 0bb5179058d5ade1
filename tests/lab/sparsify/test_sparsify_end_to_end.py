"""sparsify() end to end: quality, sparsity knob, fast track, statistics, reproducibility, errors."""
import numpy as np
import pytest

import lab.sparsify.spreadlets as spreadlets
from lab.errors import UserError
from lab.sparsify import SparsePSF, analytic, sparsify
from lab.sparsify.laplacian import psf_laplacian


@pytest.fixture(scope="module")
def disc40_result(disc40):
    return sparsify(disc40)


def test_large_disc_is_similar_at_low_sparsity(disc40, disc40_result):
    s = disc40_result
    assert not s.fast_track
    assert s.stats["ssim"] >= 0.95
    assert s.stats["sparsity"] < 0.25
    assert s.stats["l1"] < 0.03  # on the whole image: the far field is matched too
    assert s.points.dtype == np.int16 and s.values.dtype == np.float32
    assert s.points.shape == (len(s.values), 2) and s.values.shape[1] == 1


def test_statistics_are_consistent(disc40, disc40_result):
    s = disc40_result
    n_dense = int((disc40 > 0).any(axis=2).sum())
    assert s.stats["n_points"] == len(s.points) == s.stats["drawn"]
    assert s.stats["n_dense"] == n_dense
    assert s.stats["sparsity"] == pytest.approx(len(s.points) / n_dense)
    assert s.stats["cost_final"] <= s.stats["cost_lloyd"]
    rec = s.reconstruct(disc40.shape[0]).astype(np.float64)
    f = disc40.astype(np.float64)
    assert s.stats["l1"] == pytest.approx(np.abs(rec - f).sum() / f.sum(), rel=1e-6)
    assert all(isinstance(v, float) for v in s.stats.values())


def test_spreadlets_keep_the_laplacian_sum_and_are_distinct(disc40, disc40_result):
    s = disc40_result
    assert len({tuple(p) for p in s.points.tolist()}) == len(s.points)
    total = psf_laplacian(disc40).sum()  # zero for any PSF that is zero on the border
    assert abs(s.values.astype(np.float64).sum() - total) < 1e-6 * np.abs(s.values).sum()
    # points sit on the rim (where the Laplacian lives), not in the flat interior
    r = np.hypot(*s.points.T.astype(float))
    assert r.min() > 35 and r.max() < 45


def test_density_knob_orders_point_counts():
    f = analytic.prefiltered_disc(96, 30.0, 4.0)
    counts = [sparsify(f, density=d, anneal_steps=50).stats["n_points"] for d in (0.5, 1, 2)]
    assert counts[0] < counts[1] < counts[2]
    assert counts[0] < 0.8 * counts[1]


def test_delta_goes_to_the_fast_track_without_lloyd(monkeypatch):
    def no_lloyd(*args, **kwargs):
        raise AssertionError("Lloyd ran although dart throwing had decided")

    monkeypatch.setattr(spreadlets, "lloyd", no_lloyd)
    f = analytic.delta(32, channels=3)
    s = sparsify(f)
    assert s.fast_track and len(s.points) == 0 and s.values.shape == (0, 3)
    assert s.stats["n_dense"] == 1 and s.stats["n_points"] >= 1 and s.stats["ssim"] == 1.0
    np.testing.assert_array_equal(s.reconstruct(32), f)
    np.testing.assert_array_equal(s.reconstruct(9)[4, 4], [1, 1, 1])


@pytest.mark.parametrize("radius", [1.0, 2.0])
def test_tiny_discs_go_to_the_fast_track(radius):
    f = analytic.prefiltered_disc(32, radius, 1.0)
    s = sparsify(f)
    assert s.fast_track
    assert s.stats["n_points"] >= s.stats["n_dense"]
    np.testing.assert_array_equal(s.reconstruct(32), f)


def test_seeded_runs_are_reproducible():
    f = analytic.prefiltered_disc(64, 20.0, 3.0)
    a, b, c = sparsify(f, seed=4), sparsify(f, seed=4), sparsify(f, seed=5)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.values, b.values)
    assert a.stats == b.stats
    assert not (a.points.shape == c.points.shape and np.array_equal(a.points, c.points))


def test_rgb_psf_shares_points_and_fits_each_channel(rgb_disc):
    s = sparsify(rgb_disc)
    assert not s.fast_track and s.values.shape == (len(s.points), 3)
    assert s.stats["ssim"] > 0.93
    rec = s.reconstruct(64)
    for c in range(3):  # each channel's own rim is reproduced
        err = np.abs(rec[..., c] - rgb_disc[..., c]).sum()
        assert err < 0.06


@pytest.mark.parametrize("make, min_ssim", [
    (lambda: analytic.gaussian(96, 8.0), 0.95),
    (lambda: analytic.prefiltered_capsule(96, 12.0, 30.0), 0.93),
])
def test_other_psf_shapes(make, min_ssim):
    s = sparsify(make())
    assert not s.fast_track and s.stats["ssim"] >= min_ssim and s.stats["sparsity"] < 0.5


def test_steps_can_be_switched_off():
    f = analytic.prefiltered_disc(64, 20.0, 3.0)
    s = sparsify(f, lloyd_iterations=0, anneal_steps=0)
    assert not s.fast_track and s.stats["cost_lloyd"] == s.stats["cost_final"]
    full = sparsify(f)
    assert full.stats["cost_final"] < s.stats["cost_final"]  # Lloyd + annealing help


def test_reconstruct_checks_its_resolution(disc40_result):
    with pytest.raises(UserError, match="resolution"):
        disc40_result.reconstruct(40)
    with pytest.raises(UserError, match="resolution"):
        disc40_result.reconstruct(2)


@pytest.mark.parametrize("bad, match", [
    (np.zeros((16, 16)), "shape"),
    (np.zeros((16, 16, 2), np.float32), "shape"),
    (np.zeros((16, 12, 1), np.float32), "shape"),
    ([[0.0]], "numpy array"),
    (np.zeros((16, 16, 1), np.int32), "dtype"),
    (np.zeros((16, 16, 1), np.float32), "sums"),
])
def test_bad_psfs_are_user_errors(bad, match):
    with pytest.raises(UserError, match=match):
        sparsify(bad)


def test_bad_values_are_user_errors():
    f = analytic.prefiltered_disc(32, 5.0, 1.0)
    g = f.copy()
    g[16, 16, 0] = np.nan
    with pytest.raises(UserError, match="NaN"):
        sparsify(g)
    g = f.copy()
    g[16, 16, 0] = -1e-3
    g[16, 17, 0] += 1e-3
    with pytest.raises(UserError, match="negative"):
        sparsify(g)
    g = np.zeros_like(f)
    g[1, 16, 0] = 1.0
    with pytest.raises(UserError, match="border"):
        sparsify(g)


@pytest.mark.parametrize("kwargs, match", [
    (dict(density=0.0), "density"), (dict(density=float("nan")), "density"),
    (dict(seed=-1), "seed"), (dict(seed=1.5), "seed"),
    (dict(dart_failures=0), "dart_failures"), (dict(lloyd_iterations=-1), "lloyd_iterations"),
    (dict(anneal_steps=2.0), "anneal_steps"), (dict(anneal_fraction=0.0), "anneal_fraction"),
    (dict(anneal_fraction=1.5), "anneal_fraction"), (dict(rays=0), "rays"),
])
def test_bad_parameters_are_user_errors(kwargs, match):
    with pytest.raises(UserError, match=match):
        sparsify(analytic.prefiltered_disc(32, 5.0, 1.0), **kwargs)


def test_sparse_psf_is_frozen(disc40_result):
    with pytest.raises(AttributeError):
        disc40_result.fast_track = True
    assert isinstance(disc40_result, SparsePSF)


@pytest.mark.slow
@pytest.mark.parametrize("radius", [100.0, 250.0])
def test_simple_lens_sized_discs(radius):
    f = analytic.prefiltered_disc(512, radius, 3.0)
    s = sparsify(f)
    assert not s.fast_track
    assert s.stats["ssim"] >= 0.96 and s.stats["sparsity"] < 0.08 and s.stats["l1"] < 0.01


def test_psf_filling_its_image_keeps_spreadlets_inside():
    f = analytic.prefiltered_disc(61, 27.0, 1.0)  # 2 px of empty border, no more
    s = sparsify(f)
    assert not s.fast_track and s.stats["ssim"] > 0.97
    pos = 30 + s.points.astype(int)
    assert pos.min() >= 1 and pos.max() <= 59  # off the border ring of the runtime canvas
