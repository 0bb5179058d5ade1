"""The noise-aware importance for light-traced (ray histogram) PSFs."""
import numpy as np
import pytest

from lab.sparsify import analytic, sparsify
from lab.sparsify.laplacian import psf_laplacian, working_box
from lab.sparsify.noise import denoise
from lab.sparsify.stats import similarity


def test_denoise_blurs_only_as_much_as_the_noise_needs(ray_histogram):
    f = analytic.prefiltered_disc(96, 30.0, 3.0)
    few, many = ray_histogram(f, 2 ** 18), ray_histogram(f, 2 ** 30)
    d_few, d_many = denoise(few, np.array([2.0 ** -18])), denoise(many, np.array([2.0 ** -30]))
    assert d_few.sigma > d_many.sigma
    assert d_many.sigma <= 0.75
    for d in (d_few, d_many):
        np.testing.assert_allclose(d.psf.sum(axis=(0, 1)), 1.0)
        assert not d.psf[:2].any() and not d.psf[:, -2:].any()


def test_noisy_disc_is_sparsified_like_the_clean_one(ray_histogram):
    f = analytic.prefiltered_disc(160, 60.0, 3.0)
    noisy = ray_histogram(f, 2 ** 22, seed=1)
    clean, s, off = sparsify(f), sparsify(noisy, rays=2 ** 22), sparsify(noisy)
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


def test_a_higher_denoise_tau_keeps_a_thin_caustic_rim(ray_histogram):
    """A disc with a bright 1 px rim (a lens's caustic), 2^22 rays: the default TAU blurs the rim
    by 1.25 px and the spreadlets lose it (measured SSIM 0.88, L1 0.49); physical_lens's
    denoise_tau = 0.1 blurs by 0.5 px and keeps it (0.997, 0.036) with fewer points."""
    from lab.psf_tracing.models import get_model

    n = 64
    y, x = np.mgrid[0:n, 0:n] - n // 2
    ring = np.clip(1.0 - np.abs(np.hypot(x, y) - 19.5), 0.0, 1.0)[..., None]
    disc = analytic.prefiltered_disc(n, 20.0, 1.0)
    f = (disc / disc.sum() + 3.0 * ring / ring.sum()).astype(np.float32) / 4.0
    noisy = ray_histogram(f, 2 ** 22, seed=1)
    tau = get_model("physical_lens").denoise_tau
    soft, sharp = sparsify(noisy, rays=2 ** 22), sparsify(noisy, rays=2 ** 22, denoise_tau=tau)
    assert sharp.stats["denoise_sigma"] < soft.stats["denoise_sigma"]
    box = working_box(f, psf_laplacian(f))
    (s_soft, l1_soft), (s_sharp, l1_sharp) = (similarity(f, p.reconstruct(n), box) for p in (soft, sharp))
    assert s_sharp > 0.99 and l1_sharp < 0.06 and s_soft < s_sharp and l1_soft > 2 * l1_sharp
    assert sharp.stats["n_points"] < soft.stats["n_points"]
