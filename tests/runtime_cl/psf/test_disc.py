"""The disc PSF under both pixel rules: exact pixel areas and supersampled coverage."""
import numpy as np
import pytest

from runtime_cl.errors import InputError
from runtime_cl.psf.disc import disc_area_in_rect, disc_psf


@pytest.mark.parametrize("r", [0.7, 1.0, 3.3, 10.25])
def test_disc_sums_to_one_and_is_symmetric(r):
    p = disc_psf(r, 33, pixel="area")
    assert p.sum() == pytest.approx(1.0, abs=1e-12)
    assert p.min() >= 0
    np.testing.assert_allclose(p, p[::-1, :], atol=1e-15)
    np.testing.assert_allclose(p, p.T, atol=1e-15)


def test_disc_matches_brute_force_area():
    r, n = 4.4, 2400  # supersample 12 x 12 pixels at 200^2 points each
    xs = (np.arange(n) + 0.5) / n * 12 - 6
    x, y = np.meshgrid(xs, xs)
    inside = x * x + y * y <= r * r
    col, row = np.floor(x + 0.5).astype(int) + 8, np.floor(y + 0.5).astype(int) + 8
    h = np.zeros((17, 17))
    np.add.at(h, (row[inside], col[inside]), (12 / n) ** 2)
    np.testing.assert_allclose(h / (np.pi * r * r), disc_psf(r, 17, pixel="area"), atol=2e-5)


def test_area_pieces():
    assert disc_area_in_rect(1.0, -2, 2, -2, 2) == pytest.approx(np.pi)
    assert disc_area_in_rect(1.0, 0, 2, 0, 2) == pytest.approx(np.pi / 4)
    assert disc_area_in_rect(2.0, -0.5, 0.5, -0.5, 0.5) == pytest.approx(1.0)


@pytest.mark.parametrize("pixel", ["area", "supersampled"])
def test_small_disc_is_a_delta(pixel):
    d = disc_psf(0.4, 9, pixel=pixel)
    assert d[4, 4] == 1.0 and d.sum() == 1.0
    assert disc_psf(0.3, pixel=pixel).shape == (1, 1)


def test_fine_supersampling_converges_to_the_exact_areas():
    area, sampled = disc_psf(6.3, 17, pixel="area"), disc_psf(6.3, 17, supersample=64)
    assert sampled.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(sampled, area, atol=2e-3 * area.max())


def test_bad_input_names_the_argument():
    with pytest.raises(InputError, match="resolution >= 23"):
        disc_psf(10.0, 16, pixel="area")
    with pytest.raises(InputError, match="pixel = 'centre'"):
        disc_psf(2.0, pixel="centre")
    with pytest.raises(InputError, match="soft rim needs pixel='supersampled'"):
        disc_psf(2.0, pixel="area", edge=1.0)
    with pytest.raises(InputError, match="disc radius"):
        disc_psf(-1.0)
