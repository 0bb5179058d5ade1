"""Woodcock (delta) tracking: the transmittance over d is exp(-sigma_t d) for any majorant."""
import numpy as np
import pytest

from lab.errors import UserError
from lab.optics.media import woodcock_distance
from lab.psf_tracing.tracer import lane_rng


@pytest.mark.parametrize("sigma_t, ratio", [(0.9, 1.0), (0.9, 2.5), (2.0, 8.0)])
def test_transmittance_matches_beer_lambert(sigma_t, ratio):
    n = 2 ** 20
    t = woodcock_distance(sigma_t, sigma_t * ratio, lane_rng(n, 7)).numpy()
    for d in (0.1, 0.5, 1.0, 2.0, 4.0):
        expected = np.exp(-sigma_t * d)
        assert (t > d).mean() == pytest.approx(expected, abs=5 * np.sqrt(expected * (1 - expected) / n) + 1e-6)


def test_null_collisions_do_not_change_the_mean_free_path():
    n = 2 ** 20
    t = woodcock_distance(0.5, 3.0, lane_rng(n, 8)).numpy()
    assert t.mean() == pytest.approx(2.0, rel=5 / np.sqrt(n) * 1.0 + 1e-3)


def test_majorant_below_sigma_t_is_refused():
    with pytest.raises(UserError, match="majorant"):
        woodcock_distance(1.0, 0.5, lane_rng(4, 0))
