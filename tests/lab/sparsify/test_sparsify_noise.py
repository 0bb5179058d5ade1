"""Ray-histogram detection and the noise-aware importance."""
import numpy as np
import pytest

from lab.sparsify import analytic, sparsify
from lab.sparsify.laplacian import psf_laplacian, working_box
from lab.sparsify.noise import denoise, detect_quantum
from lab.sparsify.stats import similarity


def test_histograms_are_detected_with_their_ray_count(ray_histogram):
    f = analytic.prefiltered_disc(64, 15.0, 3.0)
    q = detect_quantum(ray_histogram(f, 2 ** 20))
    assert q is not None and q[0] == pytest.approx(2.0 ** -20, rel=1e-9)
    rgb = analytic.rgb_discs(64, (10.0, 12.0, 14.0))
    assert detect_quantum(ray_histogram(rgb, 10 ** 6)).tolist() == pytest.approx([1e-6] * 3)


@pytest.mark.parametrize("make", [
    lambda: analytic.prefiltered_disc(64, 15.0, 3.0), lambda: analytic.prefiltered_disc(64, 15.0, 0),
    lambda: analytic.delta(16), lambda: analytic.gaussian(64, 5.0),
    lambda: analytic.prefiltered_capsule(64, 6.0, 20.0),
])
def test_analytic_psfs_are_not_taken_for_histograms(make):
    assert detect_quantum(make()) is None


def test_denoise_blurs_only_as_much_as_the_noise_needs(ray_histogram):
    f = analytic.prefiltered_disc(96, 30.0, 3.0)
    few, many = ray_histogram(f, 2 ** 18), ray_histogram(f, 2 ** 30)
    d_few, d_many = denoise(few, detect_quantum(few)), denoise(many, detect_quantum(many))
    assert d_few.sigma > d_many.sigma
    assert d_many.sigma <= 0.75
    for d in (d_few, d_many):
        np.testing.assert_allclose(d.psf.sum(axis=(0, 1)), 1.0)
        assert not d.psf[:2].any() and not d.psf[:, -2:].any()


def test_noisy_disc_is_sparsified_like_the_clean_one(ray_histogram):
    f = analytic.prefiltered_disc(160, 60.0, 3.0)
    noisy = ray_histogram(f, 2 ** 22, seed=1)
    clean, s, off = sparsify(f), sparsify(noisy), sparsify(noisy, noise="off")
    assert s.stats["rays"] == 2 ** 22 and s.stats["denoise_sigma"] > 0
    assert clean.stats["rays"] == 0 and off.stats["rays"] == 0
    # without the noise model the points go to the noise all over the interior
    assert off.stats["n_points"] > 2 * s.stats["n_points"]
    assert s.stats["n_points"] < 1.5 * clean.stats["n_points"]
    box = working_box(f, psf_laplacian(f))
    ssim_noisy_input = similarity(f, noisy, box)[0]
    ssim_s = similarity(f, s.reconstruct(160), box)[0]
    assert ssim_s > max(ssim_noisy_input, similarity(f, off.reconstruct(160), box)[0])
    assert ssim_s > 0.9
