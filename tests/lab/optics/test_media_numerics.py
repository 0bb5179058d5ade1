"""The fast numerics of the photon walk (lab.optics.media): the azimuth's sin/cos, ln on (0, 1],
the scattered direction's length over many scatterings, its azimuth's uniformity."""
import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Array3f, Float, UInt32
from scipy import stats

from lab.optics.media import frame, hg_sample, log_unit, scatter_direction, unit_circle
from lab.psf_tracing.tracer import lane_rng


def test_unit_circle_is_cos_and_sin_of_two_pi_u():
    """Against float64 numpy on an even grid (quarter turns and their ends included) and random u:
    within 2e-7 (dr.sincos(2 pi u) is off by up to 4e-7, from rounding 2 pi u)."""
    u = np.concatenate([np.linspace(0.0, 1.0, 2 ** 20 + 1, dtype=np.float32),
                        np.random.default_rng(1).random(2 ** 20, dtype=np.float32)])
    c, s = unit_circle(Float(u))
    phi = 2.0 * np.pi * u.astype(np.float64)
    assert np.abs(c.numpy() - np.cos(phi)).max() < 2e-7 and np.abs(s.numpy() - np.sin(phi)).max() < 2e-7


def test_log_unit_is_within_an_ulp_of_ln_on_the_flight_grid():
    """Every float a free flight passes (1 - u, u on the 2^-24 grid) and random (0, 1] values."""
    x = np.concatenate([(np.arange(1, 2 ** 24 + 1) * 2.0 ** -24).astype(np.float32),
                        np.random.default_rng(2).random(2 ** 18, dtype=np.float32) + np.float32(1e-30)])
    got = log_unit(Float(x)).numpy().astype(np.float64)
    exact = np.log(x.astype(np.float64))
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    nonzero = exact != 0
    assert np.all(got[~nonzero] == 0.0) and np.max(np.abs(got - exact)[nonzero] / ulp[nonzero]) < 1.0


@pytest.mark.parametrize("g", [0.0, 0.8, 0.999, -0.999])
def test_directions_stay_unit_over_many_scatterings(g):
    """Each scattering's Newton step keeps |w| = 1 to float precision over 10^4 scatterings (the
    formula alone drifts by ~1e-5 at g = +-0.999)."""
    n = 2 ** 12
    rng = lane_rng(n, 3)

    def body(i, w, rng):
        mu, sin = hg_sample(g, rng.next_float32())
        return i + 1, scatter_direction(w, mu, sin, rng.next_float32()), rng
    _, w, _ = dr.while_loop((dr.zeros(UInt32, n), Array3f(0.0, 0.0, 1.0) + dr.zeros(Array3f, n), rng),
                            lambda i, w, rng: i < 10_000, body)
    assert np.abs(dr.norm(w).numpy() - 1.0).max() < 3e-7


def test_the_azimuth_about_the_old_direction_is_uniform():
    """The fused form of scatter_direction puts the new direction at azimuth 2 pi phi_u in
    frame(w)'s basis: recovered from the output, it is uniform (chi-square, 64 bins, p > 1e-4)
    and equal to 2 pi phi_u."""
    n = 2 ** 18
    rng = lane_rng(n, 4)
    z = 1.0 - 2.0 * rng.next_float32()
    c, s = unit_circle(rng.next_float32())
    r = dr.sqrt(1.0 - z * z)
    w = Array3f(r * c, r * s, z)
    mu, sin = hg_sample(0.3, rng.next_float32())
    phi_u = rng.next_float32()
    out = scatter_direction(w, mu, sin, phi_u)
    t, b = frame(w)
    phi = np.arctan2(dr.dot(out, b).numpy(), dr.dot(out, t).numpy()) % (2 * np.pi)
    expected = 2 * np.pi * phi_u.numpy()
    err = np.angle(np.exp(1j * (phi - expected)))
    assert np.abs(err[sin.numpy() > 1e-3]).max() < 1e-3
    assert stats.chisquare(np.histogram(phi, 64, (0, 2 * np.pi))[0]).pvalue > 1e-4
