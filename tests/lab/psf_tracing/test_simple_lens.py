"""SimpleLens traced PSFs against the analytic (pre-filtered) disc and the thin-lens CoC."""
import numpy as np
import pytest
from scipy import stats

from lab.optics.thin_lens import ThinLens
from lab.psf_tracing.analytic import prefiltered_disc_psf
from lab.psf_tracing.models import load_model

R = 48
MODEL = load_model("simple_lens", {"max_coc_px": 20.0, "psf_resolution": R, "rays_per_psf": 2 ** 18})


def second_moment(psf):
    """E[x^2 + y^2] over pixel centres, pixels from the centre (R//2, R//2)."""
    k = np.arange(psf.shape[0]) - psf.shape[0] // 2
    return float((psf * (k[None, :] ** 2 + k[:, None] ** 2)).sum())


@pytest.mark.parametrize("cell", [0, 40, 75, 99])
def test_energy_sums_to_one(cell):
    psf = MODEL.trace(cell)
    assert psf.shape == (R, R, 1) and psf.dtype == np.float32
    assert psf.astype(np.float64).sum() == pytest.approx(1.0, abs=1e-6)
    assert psf.min() >= 0


def test_in_focus_point_is_an_exact_delta():
    for psf in (MODEL.trace(0), MODEL.trace_box([0.0], [0.0], n_rays=2 ** 16).psf):
        assert psf[R // 2, R // 2, 0] == 1.0 and np.count_nonzero(psf) == 1
    assert MODEL.boxes[0].hi[0] < 1e-6  # beta = 2: cell 0 is tiny


@pytest.mark.parametrize("z", [0.5, 0.9, 4.0, np.inf])
def test_radius_matches_the_thin_lens_coc(z):
    """A scene lens's CoC at depth z (numpy mirror) -> trace that |CoC| -> the disc radius back.

    A uniform disc has E[x^2 + y^2] = r^2 / 2; binning into pixels adds 1/12 per axis (Sheppard).
    """
    lens = ThinLens(50, 1.8, 1.2, 36)
    r = abs(float(lens.coc_radius_px(z, 640)))
    assert 0.5 < r < 20
    psf = MODEL.trace_box([r], [r], n_rays=2 ** 20, seed=1).psf[..., 0]
    r_est = np.sqrt(2 * (second_moment(psf) - 1 / 6))
    assert r_est == pytest.approx(r, rel=0.01)
    ys, xs = np.nonzero(psf)
    dist = np.hypot(xs - R // 2, ys - R // 2)
    assert r - 1 < dist.max() <= r + np.sqrt(0.5)  # the support edge


def test_support_of_a_prefiltered_cell():
    b = MODEL.boxes[95]
    lo, hi = b.lo[0], b.hi[0]
    psf = MODEL.trace(95)[..., 0]
    k = np.arange(R) - R // 2
    d = np.hypot(k[None, :], k[:, None])
    assert np.all(psf[d > hi + np.sqrt(0.5)] == 0)
    assert np.all(psf[d < lo - np.sqrt(0.5)] > 0)
    ref = prefiltered_disc_psf(lo, hi, R)
    assert second_moment(psf) == pytest.approx(second_moment(ref), rel=0.005)


def test_noise_falls_like_one_over_sqrt_n():
    cell = 97
    b = MODEL.boxes[cell]
    ref = prefiltered_disc_psf(b.lo[0], b.hi[0], R, nodes=1024)
    ns = 2 ** np.arange(14, 21, 2)
    rms = [np.sqrt(np.mean((MODEL.trace(cell, n_rays=int(n), seed=2)[..., 0] - ref) ** 2)) for n in ns]
    slope = np.polyfit(np.log(ns), np.log(rms), 1)[0]
    assert slope == pytest.approx(-0.5, abs=0.06)
    # and the size of the noise is multinomial: no bias floor, no correlated rays
    predicted = np.sqrt(np.mean(ref * (1 - ref) / ns[-1]))
    assert 0.85 < rms[-1] / predicted < 1.15


@pytest.mark.parametrize("cell", [62, 99])
def test_counts_are_multinomial_in_the_analytic_pixel_probabilities(cell):
    """Pearson chi-square of 40 seeds against the exact pre-filtered disc follows chi2(K)."""
    b, n = MODEL.boxes[cell], 2 ** 16
    ref = prefiltered_disc_psf(b.lo[0], b.hi[0], R, nodes=1024)
    big = n * ref >= 20  # pool the sparse edge pixels into one bin
    pool = ref[~big].sum() > 0
    expected = n * np.append(ref[big], ref[~big].sum())[:big.sum() + pool]
    chis = []
    for seed in range(40):
        c = MODEL.trace_cell(cell, n_rays=n, seed=seed).counts[..., 0]
        observed = np.append(c[big], c[~big].sum())[:big.sum() + pool]
        chis.append(((observed - expected) ** 2 / expected).sum())
    dof = len(expected) - 1
    assert stats.kstest(chis, stats.chi2(dof).cdf).pvalue > 1e-3


def test_same_seed_same_psf_bitwise():
    a, b, c = MODEL.trace(80, seed=11), MODEL.trace(80, seed=11), MODEL.trace(80, seed=12)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert not np.array_equal(MODEL.trace(81, seed=11)[R // 2], MODEL.trace(80, seed=11)[R // 2])


def test_psf_does_not_depend_on_the_canonical_lens():
    other = load_model("simple_lens", {"max_coc_px": 20.0, "psf_resolution": R, "rays_per_psf": 2 ** 18,
                                       "lens_focal_length_mm": 24.0, "lens_f_number": 1.4,
                                       "lens_focus_distance_m": 0.5, "lens_width_px": 4000})
    a, b = MODEL.trace(90, seed=4), other.trace(90, seed=4)
    # same random numbers, different float rounding: a handful of rays change pixel at most
    assert np.abs(a.astype(np.float64) - b).sum() < 1e-3
