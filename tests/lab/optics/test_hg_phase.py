"""Henyey-Greenstein sampler: mean cosine = g, chi-square against the integrated density, for
g = 0, tiny g and |g| -> 1, and valid directions."""
import math

import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Array3f
from scipy import stats

from lab.errors import UserError
from lab.optics.media import check_g, hg_cdf, hg_pdf, hg_sample, scatter_direction
from lab.psf_tracing.tracer import lane_rng

N = 2 ** 20
G_VALUES = [0.0, 1e-6, 0.5, -0.5, 0.8, 0.999, -0.999]


def theta_cdf(theta, g):
    """P(angle <= theta), from the closed-form integral of the HG density, evaluated without
    cancellation near the peak (float64)."""
    s2 = np.sin(0.5 * theta) ** 2
    if g == 0.0:
        return s2
    # 1 + g^2 - 2 g cos(theta), written as a sum of same-signed terms
    q = (1.0 - g) ** 2 + 4.0 * g * s2 if g > 0 else (1.0 + g) ** 2 - 4.0 * g * (1.0 - s2)
    return (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g) - 1.0 / np.sqrt(q))


def equal_probability_edges(g, bins):
    """Angles splitting HG into ``bins`` equal parts (bisection on :func:`theta_cdf`)."""
    target = np.arange(1, bins) / bins
    lo, hi = np.zeros_like(target), np.full_like(target, math.pi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = theta_cdf(mid, g) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return np.concatenate([[0.0], 0.5 * (lo + hi), [math.pi]])


def samples(g, seed=0):
    mu, sin = hg_sample(g, lane_rng(N, seed).next_float32())
    return mu.numpy().astype(np.float64), sin.numpy().astype(np.float64)


@pytest.mark.parametrize("g", G_VALUES)
def test_mean_cosine_is_g(g):
    mu, _ = samples(g, 1)
    assert abs(mu.mean() - g) < 5.0 * mu.std() / math.sqrt(N) + 1e-6


@pytest.mark.parametrize("g", G_VALUES)
def test_chi_square_against_the_integrated_density(g):
    mu, sin = samples(g, 2)
    theta = np.arctan2(sin, mu)  # full relative precision near both peaks
    edges = equal_probability_edges(g, 64)
    observed, _ = np.histogram(theta, edges)
    assert observed.sum() == N
    p = stats.chisquare(observed).pvalue
    assert p > 1e-4, f"g = {g}: chi-square p = {p:.2e}"


def test_the_sampler_resolves_the_forward_peak_of_g_0999():
    """The peak is ~1e-3 rad wide: 1 - cos ~ 5e-7, below float32's resolution of cos near 1.
    The stable form keeps it: the median angle matches the exact one."""
    g = 0.999
    mu, sin = samples(g, 3)
    median = np.median(np.arctan2(sin, mu))
    exact = equal_probability_edges(g, 2)[1]
    assert median == pytest.approx(exact, rel=0.01) and exact < 2e-3


def test_cdf_and_pdf_agree():
    for g in (0.0, 0.7, -0.3):
        mu = np.linspace(-1, 1, 20001)
        integral = np.concatenate([[0], np.cumsum(0.5 * (hg_pdf(mu[1:], g) + hg_pdf(mu[:-1], g)) * np.diff(mu))])
        assert np.abs(integral - hg_cdf(mu, g)).max() < 1e-6 and hg_cdf(1.0, g) == pytest.approx(1.0)


def test_scattered_directions_are_unit_and_at_the_sampled_angle():
    rng = lane_rng(4096, 5)
    z = 1.0 - 2.0 * rng.next_float32()
    phi = 2.0 * math.pi * rng.next_float32()
    r = dr.sqrt(1.0 - z * z)
    w = Array3f(r * dr.cos(phi), r * dr.sin(phi), z)
    mu, sin = hg_sample(0.6, rng.next_float32())
    out = scatter_direction(w, mu, sin, rng.next_float32())
    assert np.abs(dr.norm(out).numpy() - 1.0).max() < 1e-5
    assert np.abs(dr.dot(out, w).numpy() - mu.numpy()).max() < 1e-5


@pytest.mark.parametrize("g", [1.0, -1.0, 1.5, float("nan"), True])
def test_g_outside_the_open_interval_is_an_error(g):
    with pytest.raises(UserError, match=r"\(-1, 1\)"):
        check_g(g)
