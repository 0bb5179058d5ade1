"""The Poisson solve inverts the 5-point Laplacian exactly for zero-border images."""
import numpy as np
import pytest

from runtime_cl.integrate.poisson import fft_friendly, laplacian5, poisson_integrate


@pytest.mark.parametrize("shape", [(17, 23), (64, 64, 3), (3, 3)])
def test_integrate_inverts_laplacian(shape):
    rng = np.random.default_rng(1)
    f = np.zeros(shape)
    f[1:-1, 1:-1] = rng.random((shape[0] - 2, shape[1] - 2) + shape[2:])
    np.testing.assert_allclose(poisson_integrate(laplacian5(f)), f, atol=1e-6)


def test_laplacian_of_linear_region_is_zero():
    y, x = np.mgrid[0:20, 0:20].astype(float)
    lap = laplacian5(3 * x + 2 * y + 1)
    assert np.all(lap[1:-1, 1:-1] == 0)


def test_large_canvas_float32_precision():
    """A 2048^2 canvas with one small disc: long sums in float64 keep the error at float32 rounding."""
    n = 2048
    y, x = np.mgrid[0:n, 0:n]
    f = (((x - 1000) ** 2 + (y - 1100) ** 2) < 30 ** 2).astype(np.float32)
    np.testing.assert_allclose(poisson_integrate(laplacian5(f)), f, atol=2e-6)


def test_too_small_canvas():
    with pytest.raises(ValueError, match="too small"):
        poisson_integrate(np.zeros((2, 5)))


def test_fft_friendly():
    assert fft_friendly(1) == 1 and fft_friendly(7) == 8 and fft_friendly(1537) == 1600
    for n in range(1, 300):
        m = fft_friendly(n)
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        assert m >= n and k == 1
