"""Voronoi assignment and collapse, annealing, merge and moment matching."""
import numpy as np
import pytest

from lab.sparsify import analytic
from lab.sparsify.anneal import anneal
from lab.sparsify.cost import BoxCost
from lab.sparsify.dart import throw_darts
from lab.sparsify.laplacian import importance, psf_laplacian, working_box
from lab.sparsify.lloyd import lloyd
from lab.sparsify.merge import merge_coincident
from lab.sparsify.moments import MomentMatch, moment_basis
from lab.sparsify.voronoi import assign, collapse


def test_assign_is_brute_force_nearest_with_lowest_index_on_ties():
    rng = np.random.default_rng(0)
    py, px = rng.integers(0, 30, 40), rng.integers(0, 30, 40)
    py[5], px[5] = py[2], px[2]  # a coincident pair: the lower index wins
    sy, sx = np.nonzero(np.ones((30, 30), bool))
    lab, d2 = assign(sy, sx, py, px, (30, 30))
    all_d2 = (sy[:, None] - py[None]) ** 2 + (sx[:, None] - px[None]) ** 2
    assert np.array_equal(d2, all_d2.min(axis=1))
    assert np.array_equal(lab, all_d2.argmin(axis=1))  # argmin takes the first minimum
    assert not np.any(lab == 5)


def test_collapse_keeps_each_channels_laplacian_sum(rgb_disc):
    lap = psf_laplacian(rgb_disc)
    imp = importance(rgb_disc, lap)
    sy, sx = np.nonzero(imp > 0)
    py, px = throw_darts(sy, sx, imp[sy, sx], 0.5, np.random.default_rng(0), 1000, imp.shape)
    lab, _ = assign(sy, sx, py, px, imp.shape)
    vals = collapse(lab, lap[sy, sx], py.size)
    assert vals.shape == (py.size, 3)
    np.testing.assert_allclose(vals.sum(axis=0), lap.sum(axis=(0, 1)), atol=1e-15)
    assert np.all(np.abs(vals).sum(axis=0) > 0)


@pytest.fixture(scope="module")
def annealing_setup():
    f = analytic.prefiltered_disc(96, 30.0, 3.0).astype(np.float64)
    lap = psf_laplacian(f)
    box = working_box(f, lap)
    lap_b = box.crop(lap)
    imp = box.crop(importance(f, lap))
    sy, sx = np.nonzero(imp > 0)
    py, px = throw_darts(sy, sx, imp[sy, sx], 2.0, np.random.default_rng(0), 10_000,
                         (box.h, box.w))
    py, px = lloyd(sy, sx, imp[sy, sx], py, px, 50)
    return sy, sx, lap_b[sy, sx], py, px, BoxCost(box.crop(f)), lap_b


def test_annealing_never_returns_a_worse_cost(annealing_setup):
    sy, sx, lap_s, py, px, cost, _ = annealing_setup
    res = anneal(sy, sx, lap_s, py, px, cost, np.random.default_rng(1), 150, 0.05)
    assert res.best_costs[-1] <= res.start_cost
    assert np.all(np.diff(res.best_costs) <= 0)
    assert np.all(res.best_costs <= res.costs + 1e-15)
    assert res.best_costs[-1] < res.start_cost  # 150 steps of 5 %: it does find better
    assert 0 < res.accepted < 150
    # the returned cost is the cost of the returned state
    canvas = np.zeros(cost.target.shape)
    np.add.at(canvas, (res.py, res.px), res.values)
    assert cost(canvas) == pytest.approx(res.best_costs[-1], rel=1e-5)


def test_incremental_cells_equal_a_full_reassignment(annealing_setup):
    sy, sx, lap_s, py, px, cost, _ = annealing_setup
    res = anneal(sy, sx, lap_s, py, px, cost, np.random.default_rng(2), 100, 0.2)
    lab, _ = assign(sy, sx, res.py, res.px, cost.target.shape[:2])
    np.testing.assert_allclose(res.values, collapse(lab, lap_s, res.py.size), atol=1e-15)


def test_annealing_stays_in_bounds_and_is_seeded(annealing_setup):
    sy, sx, lap_s, py, px, cost, _ = annealing_setup
    bounds = (int(py.min()), int(py.max()), int(px.min()), int(px.max()))
    a = anneal(sy, sx, lap_s, py, px, cost, np.random.default_rng(3), 60, 0.1, bounds)
    b = anneal(sy, sx, lap_s, py, px, cost, np.random.default_rng(3), 60, 0.1, bounds)
    assert np.array_equal(a.py, b.py) and np.array_equal(a.values, b.values)
    assert a.py.min() >= bounds[0] and a.py.max() <= bounds[1]
    assert a.px.min() >= bounds[2] and a.px.max() <= bounds[3]


def test_merge_sums_coincident_points_and_drops_empty_ones():
    pts = np.array([[1, 2], [3, 4], [1, 2], [5, 5], [3, 4]], np.int16)
    vals = np.array([[1.0], [2.0], [0.5], [0.0], [-2.0]], np.float32)
    p, v = merge_coincident(pts, vals)
    assert len({tuple(x) for x in p.tolist()}) == len(p) == 1
    assert p.tolist() == [[1, 2]] and v.tolist() == [[1.5]]  # (3,4) sums to 0, (5,5) is 0
    assert p.dtype == np.int16 and v.dtype == np.float32


def test_moment_matching_restores_the_harmonic_moments(annealing_setup):
    sy, sx, lap_s, py, px, _, lap_b = annealing_setup
    nz = lap_b.any(axis=2)
    match = MomentMatch(*np.nonzero(nz), lap_b[nz])
    lab, _ = assign(sy, sx, py, px, lap_b.shape[:2])
    raw = collapse(lab, lap_s, py.size)
    fixed = match(py, px, raw)
    basis = moment_basis(py, px, match.cy, match.cx, match.scale)
    np.testing.assert_allclose(basis @ fixed, match.target, atol=1e-12)
    assert np.abs(basis @ raw - match.target).max() > 1e-6  # the collapse alone misses them
    assert np.abs(fixed - raw).max() < 0.2 * np.abs(raw).max()  # a small correction
    np.testing.assert_allclose(match(py, px, fixed), fixed, atol=1e-15)  # idempotent
