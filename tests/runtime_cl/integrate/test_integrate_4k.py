"""Hard case (issue 14): Poisson integration of a 4K (3840 x 2160) Laplacian canvas without drift
at the far corner, for every integrator. The reference is the image whose Laplacian is
integrated (known exactly), not another solve: a drift (a ramp growing away from where the
solve is anchored) shows as an error that grows from the near corner to the far one."""
import numpy as np
import pytest

from runtime_cl.integrate import get_integrator, integrator_names
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.synthetic import psf_sum_image

# Per integrator: the largest error allowed anywhere and in the far-corner block, relative to
# the image's largest value, with why.
TOLERANCE = {
    "exact": 2e-6,     # float64 FFTs of a float32 canvas: its rounding (2^-24 of 4 x max), summed by the solve
    "fft32": 1e-4,     # float32 FFTs over 8.3 M pixels: test_integrators bounds it at 1e-4 (issue 12)
    "pyramid": 0.03,   # the convolution pyramid's target (issue 12: max 3 % of the largest value)
}


def _image(h, w):
    """Two random PSF sums (the integrators' input: discs, sharp to blurred, zero near the
    border), one square at each end of the canvas, so both corners hold detail."""
    f = np.zeros((h, w), np.float32)
    f[:, :h] += psf_sum_image(h, seed=1, channels=1)[..., 0]
    f[:, w - h:] += psf_sum_image(h, seed=2, channels=1)[..., 0]
    return f


def _check(name, h, w):
    f = _image(h, w)
    lap = laplacian5(f.astype(np.float64)).astype(np.float32)
    out, _ = get_integrator(name)()(lap)
    err = np.abs(out.astype(np.float64) - f) / f.max()
    near, far = err[:256, :256], err[-256:, -256:]
    tol = TOLERANCE[name]
    assert err.max() <= tol, (name, err.max())
    assert far.max() <= tol, (name, near.mean(), far.mean())
    return near.mean(), far.mean()


def test_every_integrator_has_a_tolerance():
    assert set(integrator_names()) == set(TOLERANCE)


@pytest.mark.parametrize("name", ["exact", "fft32", "pyramid"])
def test_4k_integrates_without_drift_at_the_far_corner(name):
    """3840 x 2160 (about 1 s each)."""
    _check(name, 2160, 3840)

