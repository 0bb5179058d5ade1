"""Shared fixtures: analytic test PSFs (numpy only) small enough for fast tests."""
import numpy as np
import pytest

from lab.sparsify import analytic


@pytest.fixture(scope="session")
def disc40():
    """Pre-filtered disc, radius 40 px, 3 px ramp, in a 112^2 image."""
    return analytic.prefiltered_disc(112, 40.0, 3.0)


@pytest.fixture(scope="session")
def rgb_disc():
    """Chromatic disc: per-channel radii 18, 21, 24 px."""
    return analytic.rgb_discs(64, (18.0, 21.0, 24.0))


@pytest.fixture(scope="session")
def ray_histogram():
    """``ray_histogram(psf, rays, seed=0)``: ``psf`` light-traced with ``rays`` equal-weight rays
    (a multinomial histogram, count / rays, float32), as the PSF tracer produces it."""

    def make(psf: np.ndarray, rays: int, seed: int = 0) -> np.ndarray:
        rng = np.random.default_rng(seed)
        out = np.empty(psf.shape, np.float32)
        for c in range(psf.shape[2]):
            p = psf[..., c].astype(np.float64).ravel()
            out[..., c] = rng.multinomial(rays, p / p.sum()).reshape(psf.shape[:2]) / rays
        return out

    return make
