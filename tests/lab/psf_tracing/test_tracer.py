"""The light tracer with hand-made ray functions: binning, channels, blocking, outside, seeds."""
import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Array2f, Float, UInt32

from lab.errors import UserError
from lab.psf_tracing.tracer import RayHits, trace_psf


def fixed(col, row):
    def rays(coords, rng):
        return RayHits(Array2f(dr.full(Float, col, dr.width(coords[0])), row))
    return rays


@pytest.mark.parametrize("offset, pixel", [((0.0, 0.0), (4, 4)), ((3.0, -2.0), (2, 7)),
                                           ((0.4999, -0.5), (4, 4)), ((0.5, 0.0), (4, 5)),
                                           ((-0.5001, 0.0), (4, 3))])
def test_box_binning_and_orientation(offset, pixel):
    r = trace_psf(fixed(*offset), [0.0], [1.0], 9, 1000)
    assert r.counts[pixel + (0,)] == 1000 and r.counts.sum() == 1000
    assert r.psf[pixel + (0,)] == 1.0


def test_outside_rays_are_counted_not_binned():
    def rays(coords, rng):  # x uniform in [-8, 8): half of it outside a 9 x 9 image
        return RayHits(Array2f(16.0 * rng.next_float32() - 8.0, 0.0))
    r = trace_psf(rays, [0.0], [0.0], 9, 2 ** 18, seed=3)
    inside = 9 / 16  # offsets in [-4.5, 4.5)
    assert r.n_outside + r.counts.sum() == r.n_rays
    assert r.n_outside / r.n_rays == pytest.approx(1 - inside, abs=0.005)
    assert r.psf.sum() == pytest.approx(1.0, abs=1e-6)


def test_nan_and_inf_land_outside():
    def rays(coords, rng):
        u = rng.next_float32()
        x = dr.select(u < 0.3, dr.nan, dr.select(u < 0.6, dr.inf, 0.0))
        return RayHits(Array2f(x, 0.0))
    r = trace_psf(rays, [0.0], [0.0], 5, 10_000)
    assert r.n_outside == r.n_rays - r.counts[2, 2, 0] and 0.55 < r.n_outside / r.n_rays < 0.65


def test_channels_and_blocked_rays():
    def rays(coords, rng):
        blocked = rng.next_float32() < 0.25
        channel = UInt32(rng.next_float32() * 3.0)
        col = Float(channel)  # channel c lands c pixels right of the centre
        return RayHits(Array2f(col, 0.0), active=~blocked, channel=channel)
    r = trace_psf(rays, [0.0], [0.0], 7, 2 ** 18, seed=1, channels=3)
    assert r.n_blocked / r.n_rays == pytest.approx(0.25, abs=0.005)
    assert r.n_blocked + r.counts.sum() == r.n_rays and r.n_outside == 0
    for c in range(3):
        assert r.psf[3, 3 + c, c] == 1.0 and r.psf[..., c].sum() == 1.0


def test_prefilter_draws_coordinates_uniformly_over_the_box():
    def rays(coords, rng):  # land at the coordinate itself: the PSF is its histogram
        return RayHits(Array2f(coords[0], coords[1]))
    r = trace_psf(rays, [-3.5, 0.5], [3.5, 1.5], 9, 7 * 2 ** 14, seed=5)
    row = r.counts[5, :, 0]  # y in [0.5, 1.5) is the row at offset +1
    assert r.counts.sum() == row.sum()
    np.testing.assert_array_equal(row[:1], 0)
    assert np.all(np.abs(row[1:8] / 2 ** 14 - 1) < 0.05)


def test_seeds_launches_and_streams():
    def rays(coords, rng):
        return RayHits(Array2f(10.0 * rng.next_float32() - 5.0, 10.0 * rng.next_float32() - 5.0))
    a = trace_psf(rays, [0.0], [1.0], 11, 100_003, seed=7, rays_per_launch=2 ** 14)
    b = trace_psf(rays, [0.0], [1.0], 11, 100_003, seed=7, rays_per_launch=2 ** 14)
    c = trace_psf(rays, [0.0], [1.0], 11, 100_003, seed=8, rays_per_launch=2 ** 14)
    d = trace_psf(rays, [0.0], [1.0], 11, 100_003, seed=7, rays_per_launch=2 ** 14, stream=1)
    assert a.counts.sum() == 100_003  # a partial last launch counts too
    np.testing.assert_array_equal(a.psf, b.psf)
    assert not np.array_equal(a.counts, c.counts) and not np.array_equal(a.counts, d.counts)


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_rays=0), "n_rays"), (dict(n_rays=1.5), "n_rays"), (dict(seed=-1), "seed"),
    (dict(resolution=0), "resolution"), (dict(lo=[2.0], hi=[1.0]), "lo <= hi"),
    (dict(rays_per_launch=2 ** 31), "rays_per_launch")])
def test_bad_arguments_are_user_errors(kwargs, match):
    args = dict(rays=fixed(0.0, 0.0), lo=[0.0], hi=[1.0], resolution=5, n_rays=10)
    args.update(kwargs)
    with pytest.raises(UserError, match=match):
        trace_psf(**args)


def test_all_rays_outside_is_an_error():
    with pytest.raises(UserError, match="no ray reached"):
        trace_psf(fixed(50.0, 0.0), [0.0], [1.0], 9, 100)
