"""Hard cases of the optics (issue 14): Sellmeier near a resonance, zero and very dense media,
thick-lens rays that miss a surface or reflect totally, in the lab and in the runtime's numpy and
OpenCL tracers. References: the Sellmeier sum in float64 by hand, Beer-Lambert, Snell's law."""
import math

import numpy as np
import pytest
from scipy import stats

from lab.errors import UserError
from lab.medium import Medium
from lab.optics.glass import GLASSES, get_glass
from lab.optics.media import woodcock_distance
from lab.optics.thick_lens import LensSystem
from lab.psf_tracing.tracer import lane_rng
from runtime_cl.camera.lens_trace import LensTraceKernel, TracedLens

LAM = 587.5618


@pytest.mark.parametrize("name", sorted(n for n in GLASSES if n != "air"))
def test_sellmeier_at_the_ends_of_its_fit_near_the_uv_resonance(name):
    """At 300 nm (the fit's short end, closest to the UV resonance sqrt(C2) ~ 0.14-0.25 um) and
    2500 nm: the index is the Sellmeier sum (float64, 1e-15 relative), finite and > 1, and the
    dispersion dn/dlambda is negative (normal) and steepest at the UV end."""
    g = get_glass(name)
    assert max(math.sqrt(c) for c in g.c[:2]) < 0.3          # the UV resonances lie below the fit
    for lam_nm in (300.0, 300.0 + 1e-9, 2500.0):
        l2 = (lam_nm / 1000.0) ** 2
        want = math.sqrt(1.0 + sum(b * l2 / (l2 - c) for b, c in zip(g.b, g.c)))
        n = g.index(lam_nm)
        assert math.isfinite(n) and n > 1.0 and n == pytest.approx(want, rel=1e-15)
    lam = np.array([300.0, 301.0, 1000.0, 1001.0, 2499.0, 2500.0])
    n = g.index(lam)
    slope = np.diff(n)[::2]
    assert np.all(slope < 0) and abs(slope[0]) > abs(slope[1]) > 0


@pytest.mark.parametrize("lam_nm", [299.999, 140.0, 100.0, 10_000.0, 2500.001])
def test_sellmeier_at_or_past_a_resonance_is_refused_not_a_nan(lam_nm):
    """Below 300 nm the sum passes its UV pole (n^2 -> +-inf, then < 0: NaN); at 10 um its IR
    pole: both outside the fit, refused with the range named."""
    with pytest.raises(UserError, match="300 .. 2500 nm"):
        get_glass("N-SF11").index(lam_nm)


def test_zero_medium_never_collides_and_is_refused_as_a_fog():
    """sigma_t = 0: delta tracking meets only null collisions (every lane runs to its limit,
    distance > limit), and a [medium] of 0 /m is refused (clear air is no [medium])."""
    n = 2 ** 12
    t = woodcock_distance(0.0, 1.0, lane_rng(n, 3), limit=50.0).numpy()
    assert np.all(t > 50.0)
    with pytest.raises(UserError, match="remove \\[medium\\] for clear air"):
        Medium(sigma_t=0.0)


@pytest.mark.parametrize("sigma_t", [1e4, 1e7])
def test_very_dense_media_keep_exponential_free_flights(sigma_t):
    """sigma_t = 1e4 and 1e7 per metre (free paths of 100 um and 100 nm): the distances are still
    Exp(sigma_t) (Kolmogorov-Smirnov, 2^16 lanes, p > 1e-3: a false alarm 1 run in 1000), all
    finite and > 0, the mean within 5 standard errors of 1 / sigma_t."""
    n = 2 ** 16
    t = woodcock_distance(sigma_t, sigma_t, lane_rng(n, 11)).numpy().astype(np.float64)
    assert np.all(np.isfinite(t)) and np.all(t > 0)
    assert t.mean() == pytest.approx(1.0 / sigma_t, rel=5.0 / math.sqrt(n))
    assert stats.kstest(t * sigma_t, "expon").pvalue > 1e-3
    Medium(sigma_t=sigma_t)                                   # accepted


# A plano-convex N-SF11 element, flat side first: inside the glass a ray parallel to the axis at
# height h meets the back sphere (R = -10 mm) at asin(h / 10), beyond the critical angle
# asin(1 / n) for h > 10 / n (5.6 mm). The back rim (9.9 mm) blocks h > 9.9 in the lab, which
# refuses a rim wider than the sphere; the runtime's lens gets a 12 mm rim, so rays above 10 mm
# miss the sphere altogether (no intersection) and must be blocked for that reason.
ROWS = [(0.0, 0.5, "air", 12.0), (math.inf, 10.0, "N-SF11", 12.0), (-10.0, 0.0, "air", 9.9)]
HEIGHTS = np.array([0.0, 2.0, 5.0, 5.55, 5.65, 7.0, 9.99, 10.5, 11.9])


def _runtime_lens(lab: LensSystem) -> TracedLens:
    radius = np.array([r[0] for r in ROWS])
    flat = (radius == 0.0) | np.isinf(radius)
    n_after = np.array([[1.0, get_glass("N-SF11").index(LAM), 1.0]])
    n_before = np.array([[1.0, 1.0, n_after[0, 1]]])
    return TracedLens(np.where(flat, 0.0, 1.0 / np.where(flat, 1.0, radius)), np.array(lab.vertices_mm, float),
                      np.array([12.0, 12.0, 12.0]), radius == 0.0, n_before / n_after, 40.0)


# blocked rays carry inf/NaN positions (masked by ok); numpy warns while computing them
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_thick_lens_total_reflection_and_misses_in_the_lab_and_the_runtime():
    """Which rays get through is Snell's law's answer (h < 10 / n), in the lab's float64 trace,
    the runtime's numpy trace and its OpenCL float32 trace (rays 0.05 mm either side of the
    critical height: float32 cannot flip them); no NaN leaks into a ray that got through, and the
    ones that do get through leave the back face where Snell says (1e-9 mm, float64)."""
    n = get_glass("N-SF11").index(LAM)
    critical = 10.0 / n
    want = HEIGHTS < critical
    lab = LensSystem(ROWS)
    o = np.stack([HEIGHTS, np.zeros_like(HEIGHTS), np.full_like(HEIGHTS, -1.0)], axis=1)
    d = np.tile([0.0, 0.0, 1.0], (len(HEIGHTS), 1))
    (lx, ly, lz), (dx, dy, dz), lok = lab.trace(tuple(o.T), tuple(d.T), lab.relative_indices(LAM))
    assert np.array_equal(lok, want)
    rt = _runtime_lens(lab)
    p64, d64, ok64 = rt.trace(o, d, 0, to_sensor=False)
    p32, d32, ok32 = LensTraceKernel(rt).trace(o, d, np.zeros(len(HEIGHTS), np.int32), to_sensor=False)
    assert np.array_equal(ok64, want) and np.array_equal(np.asarray(ok32, bool), want)
    assert np.all(np.isfinite(p64[want])) and np.all(np.isfinite(np.asarray(p32)[want]))
    # Snell at the back sphere (centre at z = 0.5 + 10 - 10 = 0.5 + 10 + R): exit angle from the normal
    h = HEIGHTS[want]
    theta_i = np.arcsin(h / 10.0)
    theta_t = np.arcsin(n * np.sin(theta_i))
    slope = np.tan(theta_t - theta_i)                  # the exit ray bends towards the axis
    np.testing.assert_allclose(-d64[want, 0] / d64[want, 2], slope, rtol=0, atol=1e-9)
    np.testing.assert_allclose(p64[want], np.stack([lx, ly, lz], 1)[want], rtol=0, atol=1e-9)
