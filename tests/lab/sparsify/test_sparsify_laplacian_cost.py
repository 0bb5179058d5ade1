"""Laplacian, importance, working box and the box cost's integration."""
import numpy as np

from lab.sparsify import analytic
from lab.sparsify.cost import BoxCost
from lab.sparsify.laplacian import Box, importance, psf_laplacian, working_box
from runtime_cl.integrate.poisson import fft_friendly, poisson_integrate


def test_laplacian_of_constant_and_linear_regions_is_exactly_zero():
    y, x = np.mgrid[0:40, 0:40]
    f = np.zeros((48, 48, 2), np.float32)
    f[4:44, 4:44, 0] = (300 + x + 2 * y) / 4096  # a tilted plane, exact in float32
    f[4:44, 4:44, 1] = np.float32(1 / 3)  # a constant (not a power of two)
    lap = psf_laplacian(f)
    assert np.all(lap[5:43, 5:43] == 0.0)  # interior: exactly zero, no rounding noise
    assert np.abs(lap[4, 5:43]).min() > 0  # the edges are not


def test_importance_is_scale_free_and_zero_where_laplacian_is():
    small = analytic.prefiltered_disc(64, 10.0, 0.0)
    lap = psf_laplacian(small)
    imp = importance(small, lap)
    assert np.array_equal(imp > 0, (lap != 0).any(axis=2))
    # the same shape at twice the height has the same importance (units of its own level)
    doubled = importance(2 * small, psf_laplacian(2 * small))
    np.testing.assert_allclose(doubled, imp, rtol=1e-12)
    # a hard disc edge stands at about 1..3 levels per pixel
    assert 0.9 < imp.max() < 3.1


def test_importance_floor_soft_thresholds():
    f = analytic.prefiltered_disc(64, 10.0, 3.0)
    lap = psf_laplacian(f)
    floor = np.full(lap.shape, 0.5 * np.abs(lap).max())
    imp = importance(f, lap, floor)
    assert (imp > 0).sum() < (importance(f, lap) > 0).sum()
    assert imp.max() < importance(f, lap).max()


def test_working_box_holds_support_with_margin_and_fft_sizes():
    f = analytic.prefiltered_disc(128, 20.0, 3.0)
    box = working_box(f, psf_laplacian(f))
    assert box.h == fft_friendly(box.h) and box.w == fft_friendly(box.w)
    rows = np.flatnonzero((f[..., 0] > 0).any(axis=1))
    assert box.y0 + 4 <= rows[0] - 1 and rows[-1] + 1 + 4 < box.y0 + box.h


def test_box_crop_pads_outside_the_image():
    img = np.arange(16.0).reshape(4, 4, 1)
    out = Box(-1, 2, 3, 3).crop(img)
    assert out.shape == (3, 3, 1)
    assert np.all(out[0] == 0) and np.all(out[:, 2] == 0)
    assert out[1, 0, 0] == img[0, 2, 0] and out[2, 1, 0] == img[1, 3, 0]


def test_box_cost_integration_is_the_runtime_operator():
    rng = np.random.default_rng(3)
    lap = np.zeros((40, 36, 2))
    lap[5:35, 5:31] = rng.normal(size=(30, 26, 2))
    lap -= lap.mean(axis=(0, 1))  # a realisable Laplacian has zero sum
    cost = BoxCost(np.zeros((40, 36, 2)))
    ref = poisson_integrate(lap)
    np.testing.assert_allclose(cost.integrate(lap), ref, atol=2e-5 * np.abs(ref).max())


def test_box_cost_is_zero_for_the_exact_laplacian():
    f = analytic.prefiltered_disc(64, 12.0, 3.0)
    lap = psf_laplacian(f)
    assert BoxCost(f)(lap) < 1e-4
    assert BoxCost(f)(np.zeros_like(lap)) == 1.0
