"""The pre-filtered exact-area disc PSF the tracer is checked against."""
import numpy as np
import pytest

from lab.psf_tracing.analytic import prefiltered_disc_psf
from runtime_cl.psf.disc import disc_psf


def test_prefilter_averages_discs():
    a, b = disc_psf(2.0, 15, pixel="area"), disc_psf(3.0, 15, pixel="area")
    two = prefiltered_disc_psf(2.0, 3.0, 15, nodes=2)  # midpoints 2.25, 2.75
    np.testing.assert_allclose(two, (disc_psf(2.25, 15, pixel="area") + disc_psf(2.75, 15, pixel="area")) / 2)
    fine = prefiltered_disc_psf(2.0, 3.0, 15, nodes=1024)
    assert fine.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all((fine > 0) <= (b > 0))  # support within the largest disc
    # the centre pixel is fully covered: its share 1 / (pi r^2) averages to 1 / (pi lo hi)
    assert b[7, 7] < fine[7, 7] < a[7, 7]
    assert fine[7, 7] == pytest.approx(1 / (np.pi * 2.0 * 3.0), rel=1e-6)
    np.testing.assert_allclose(prefiltered_disc_psf(2.0, 3.0, 15, nodes=256), fine, atol=1e-6)
