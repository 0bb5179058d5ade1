"""The tracer's integer multiplicities (RayHits.weight) and its public per-lane generators."""
import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Array2f, UInt32

from lab.psf_tracing.tracer import RayHits, lane_rng, trace_psf


def test_weights_multiply_counts_and_blocked_rays_count_once():
    def rays(coords, rng):
        u = rng.next_float32()
        blocked = u < 0.2
        weight = UInt32(dr.select(u < 0.6, 1, 3))                   # 40 % of the rays weigh 3
        col = dr.select(u < 0.6, 0.0, dr.select(u < 0.9, 1.0, 100.0))  # 10 % land outside
        return RayHits(Array2f(col, 0.0), active=~blocked, weight=weight)
    n = 2 ** 18
    r = trace_psf(rays, [0.0], [0.0], 5, n, seed=2)
    assert r.n_blocked / n == pytest.approx(0.2, abs=0.005)
    assert r.counts[2, 2, 0] / n == pytest.approx(0.4, abs=0.005)       # weight 1
    assert r.counts[2, 3, 0] / n == pytest.approx(3 * 0.3, abs=0.01)    # weight 3
    assert r.n_outside / n == pytest.approx(3 * 0.1, abs=0.005)
    assert r.psf[2, 3, 0] == pytest.approx(0.9 / 1.3, abs=0.005) and r.psf.sum() == pytest.approx(1.0)


def test_squared_weights_give_the_histograms_effective_ray_count():
    """sq_weights sums w^2 of the rays counted in the image, per channel (blocked and outside rays
    left out), so effective_rays = (sum w)^2 / sum w^2: exact for these counts."""
    def rays(coords, rng):
        u = rng.next_float32()
        ch = UInt32(dr.select(u < 0.5, 0, 1))
        weight = UInt32(dr.select(u < 0.25, 1, dr.select(u < 0.5, 4, dr.select(u < 0.9, 2, 8))))
        col = dr.select(u < 0.95, 0.0, 100.0)                           # channel 1's weight-8 rays: half outside
        return RayHits(Array2f(col, 0.0), active=u > 0.05, channel=ch, weight=weight)
    n = 2 ** 16
    r = trace_psf(rays, [0.0], [0.0], 3, n, seed=4, channels=2)
    u = lane_rng(n, 4)
    u.next_float32()                                                    # the PSF coordinate
    u = u.next_float32().numpy()
    w = np.where(u < 0.25, 1, np.where(u < 0.5, 4, np.where(u < 0.9, 2, 8))).astype(np.float64)
    landed = (u > 0.05) & (u < 0.95)
    for ch, sel in enumerate((u < 0.5, u >= 0.5)):
        m = landed & sel
        assert r.counts[..., ch].sum() == w[m].sum() and r.sq_weights[ch] == (w[m] ** 2).sum()
        assert r.effective_rays[ch] == pytest.approx(w[m].sum() ** 2 / (w[m] ** 2).sum(), rel=1e-12)
    assert r.effective_rays[0] < r.counts[..., 0].sum()                  # unequal weights: fewer


def test_without_weights_the_balance_is_exact():
    def rays(coords, rng):
        u = rng.next_float32()
        return RayHits(Array2f(8.0 * u - 4.0, 0.0), active=u > 0.1)
    r = trace_psf(rays, [0.0], [0.0], 5, 100_000, seed=3)
    assert r.n_blocked + r.n_outside + r.counts.sum() == r.n_rays


def test_lane_rng_is_the_tracers_and_lanes_are_independent():
    n = 4096
    a = lane_rng(n, 5, stream=2).next_float32().numpy()
    b = lane_rng(n, 5, stream=2).next_float32().numpy()
    c = lane_rng(n, 5, stream=3).next_float32().numpy()
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    # neighbouring lanes are uncorrelated (consecutive PCG32 seeds would form a lattice)
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < 0.05

    seen = []

    def rays(coords, rng):
        seen.append(rng.next_float32().numpy())
        return RayHits(Array2f(0.0, 0.0))
    trace_psf(rays, [0.0], [0.0], 1, n, seed=5, stream=2)
    first = lane_rng(n, 5, stream=2)
    first.next_float32()  # the tracer's first number is the PSF coordinate
    assert np.array_equal(seen[0], first.next_float32().numpy())
