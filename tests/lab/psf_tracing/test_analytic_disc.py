"""The analytic (exact pixel-area) disc PSFs the tracer is checked against."""
import numpy as np
import pytest

from lab.errors import UserError
from lab.psf_tracing.analytic import disc_area_in_rect, disc_psf, prefiltered_disc_psf


@pytest.mark.parametrize("r", [0.7, 1.0, 3.3, 10.25])
def test_disc_sums_to_one_and_is_symmetric(r):
    p = disc_psf(r, 33)
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
    np.testing.assert_allclose(h / (np.pi * r * r), disc_psf(r, 17), atol=2e-5)


def test_area_pieces():
    assert disc_area_in_rect(1.0, -2, 2, -2, 2) == pytest.approx(np.pi)
    assert disc_area_in_rect(1.0, 0, 2, 0, 2) == pytest.approx(np.pi / 4)
    assert disc_area_in_rect(2.0, -0.5, 0.5, -0.5, 0.5) == pytest.approx(1.0)


def test_small_disc_is_a_delta_and_prefilter_averages():
    d = disc_psf(0.4, 9)
    assert d[4, 4] == 1.0 and d.sum() == 1.0
    a, b = disc_psf(2.0, 15), disc_psf(3.0, 15)
    two = prefiltered_disc_psf(2.0, 3.0, 15, nodes=2)  # midpoints 2.25, 2.75
    np.testing.assert_allclose(two, (disc_psf(2.25, 15) + disc_psf(2.75, 15)) / 2)
    fine = prefiltered_disc_psf(2.0, 3.0, 15, nodes=1024)
    assert fine.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all((fine > 0) <= (b > 0))  # support within the largest disc
    # the centre pixel is fully covered: its share 1 / (pi r^2) averages to 1 / (pi lo hi)
    assert b[7, 7] < fine[7, 7] < a[7, 7]
    assert fine[7, 7] == pytest.approx(1 / (np.pi * 2.0 * 3.0), rel=1e-6)
    np.testing.assert_allclose(prefiltered_disc_psf(2.0, 3.0, 15, nodes=256), fine, atol=1e-6)


def test_too_small_image_is_a_user_error():
    with pytest.raises(UserError, match="resolution >= 23"):
        disc_psf(10.0, 16)
