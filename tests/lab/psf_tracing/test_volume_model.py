"""Volume: a point light in a homogeneous medium (Woodcock tracking, Henyey-Greenstein), RGB,
checked against Beer-Lambert and the single-scattering integral."""
import math

import numpy as np
import pytest
from scipy import integrate

from lab.config import from_table
from lab.errors import UserError
from lab.optics.media import hg_pdf
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.volume import Volume, VolumeConfig


def test_registered_with_lsr18_defaults():
    m = load_model("volume", {})
    c = m.config
    assert get_model("volume") is Volume and m.channels == 3 and m.grid.ns == 1
    assert (c.medium_density, c.g, c.albedo) == (0.9, 0.8, (1.0, 1.0, 0.9))
    assert m.grid.size >= 200 and m.beta == (1.0,) and m.symmetries == ("rotation",)


@pytest.mark.parametrize("table, match", [
    ({"g": 1.0}, r"g = 1.0: .*\(-1, 1\)"),
    ({"g": -1.5}, r"g = -1.5"),
    ({"medium_density": -0.1}, "medium_density = -0.1"),
    ({"albedo": [1.0, 1.2, 0.9]}, "albedo"),
    ({"majorant_ratio": 0.5}, "majorant_ratio = 0.5"),
    ({"min_distance_m": 3.0, "max_distance_m": 2.0}, "min_distance_m < max_distance_m"),
    ({"density_medium": 0.9}, "unknown key"),
])
def test_bad_configuration_is_refused_before_tracing(table, match):
    with pytest.raises(UserError, match=match):
        from_table(VolumeConfig, table, "[psf.volume]")


@pytest.mark.parametrize("ratio", [1.0, 3.0])
def test_transmittance_of_an_absorbing_medium_is_beer_lambert(ratio):
    """Albedo 0: only unscattered photons reach the camera, all in the centre pixel, a fraction
    exp(-sigma_t d) of them, with or without null collisions."""
    m = Volume(VolumeConfig(albedo=(0.0, 0.0, 0.0), majorant_ratio=ratio, psf_resolution=33))
    n, d = 2 ** 20, 1.5
    t = m.trace_box((d,), (d,), n_rays=n, seed=2)
    expected = math.exp(-0.9 * d)
    assert t.counts.sum() == t.counts[16, 16].sum()
    assert t.counts.sum() / n == pytest.approx(expected, abs=5 * math.sqrt(expected / n))
    assert t.n_outside == 0 and t.n_blocked + t.counts.sum() == n


def single_scatter_density(alpha, d, sigma, g):
    """Expected camera crossings per emitted photon per steradian at view angle alpha, single
    scattering (albedo 1): 4 pi d^2 cos(alpha) L(alpha), L the radiance of a unit-power isotropic
    point at distance d, integrated along the view ray (scipy.quad)."""
    view = np.array([math.sin(alpha), 0.0, -math.cos(alpha)])

    def integrand(s):
        x = np.array([0.0, 0.0, d]) + s * view       # light at the origin, camera at (0, 0, d)
        r = np.linalg.norm(x)
        mu = np.dot(x / r, -view)
        return sigma * math.exp(-sigma * (s + r)) * hg_pdf(mu, g) / (2 * math.pi) / (4 * math.pi * r * r)
    near = integrate.quad(integrand, 0, 2 * d, limit=200, points=[d * math.cos(alpha)])[0]
    return 4 * math.pi * d * d * math.cos(alpha) * (near + integrate.quad(integrand, 2 * d, np.inf, limit=200)[0])


@pytest.mark.parametrize("g", [0.0, 0.8, -0.6])
def test_halo_matches_single_scattering(g):
    """Optically thin (tau = 0.05) and at most one scattering: the traced halo per ring of pixels
    equals the single-scattering integral (MC noise ~1 %); the centre pixel holds the
    unscattered exp(-tau)."""
    d, sigma, res, f = 1.0, 0.05, 101, 50.0
    m = Volume(VolumeConfig(max_distance_m=d, medium_density=sigma, g=g, albedo=(1.0, 1.0, 1.0),
                            psf_resolution=res, focal_length_mm=18.0, sensor_width_mm=36.0, width_px=100,
                            escape_mfp=50.0, max_collisions=2))
    n = 2 ** 22
    t = m.trace_box((d,), (d,), n_rays=n, seed=5)
    counts = t.counts.sum(axis=2) / n
    yy, xx = np.mgrid[:res, :res] - res // 2
    rr = np.hypot(xx, yy)
    radii = np.linspace(2.5, 75.0, 120)
    profile = [single_scatter_density(math.atan(r / f), d, sigma, g) for r in radii]
    alpha = np.arctan(rr / f)
    expected = np.interp(rr, radii, profile) * np.cos(alpha) ** 3 / f ** 2   # pixel solid angle
    for a, b in [(3, 6), (6, 12), (12, 24), (24, 50)]:
        ring = (rr >= a) & (rr < b)
        assert counts[ring].sum() == pytest.approx(expected[ring].sum(), rel=0.03), (a, b)
    assert counts[50, 50] == pytest.approx(math.exp(-sigma * d), abs=0.004)


@pytest.mark.parametrize("g", [0.999, -0.999])
def test_near_delta_phase_functions_keep_the_point_sharp(g):
    """As |g| -> 1 scattering barely turns (or exactly reverses) photons: even at tau = 2.7 the
    image stays a point, where g = 0 spreads most light out of the image."""
    def concentrated(gg):
        m = Volume(VolumeConfig(g=gg, albedo=(1.0, 1.0, 1.0), psf_resolution=65, escape_mfp=4.0))
        t = m.trace_box((3.0,), (3.0,), n_rays=2 ** 18, seed=2)
        assert np.isfinite(t.psf).all()
        rr = np.hypot(*(np.mgrid[:65, :65] - 32))
        return t.counts.sum(axis=2)[rr <= 10].sum() / t.n_rays
    assert concentrated(g) > 0.8 and concentrated(0.0) < 0.1


def test_albedo_colours_the_halo():
    """Blue has albedo .9: its scattered light is partly absorbed, so relative to the direct
    peak blue's halo is weaker and its energy in the image lower (the halo turns yellow)."""
    m = Volume(VolumeConfig(psf_resolution=101))
    t = m.trace_box((3.0,), (3.0,), n_rays=2 ** 20, seed=6)
    energy = m.window_energy(t)
    centre = t.psf[50, 50]
    assert energy[2] < 0.95 * energy[0] and centre[2] > 1.05 * centre[0]
    assert energy[0] == pytest.approx(energy[1], rel=0.03) and energy[0] > math.exp(-0.9 * 3.0)


def test_psf_is_rotation_invariant_and_outside_light_is_not_an_error():
    m = Volume(VolumeConfig(psf_resolution=33, samples=4))
    t = m.trace_checked(m.grid.size - 1, n_rays=2 ** 20)
    assert t.n_outside > 0
    p = t.psf.sum(axis=2) / 3
    yy, xx = np.mgrid[:33, :33] - 16
    mx, my = (p * xx).sum(), (p * yy).sum()
    vx, vy = (p * xx ** 2).sum(), (p * yy ** 2).sum()
    assert abs(mx) < 0.05 and abs(my) < 0.05 and vx == pytest.approx(vy, rel=0.03) and vx > 1.0


@pytest.mark.slow
def test_dropping_escaped_photons_biases_the_halo_by_at_most_two_percent():
    far = {}
    for esc in (10.0, 40.0):
        m = Volume(VolumeConfig(escape_mfp=esc, psf_resolution=129))
        far[esc] = m.window_energy(m.trace_box((5.0,), (5.0,), n_rays=2 ** 22, seed=9))
    assert np.allclose(far[10.0], far[40.0], rtol=0.02)


def test_the_psf_carries_the_media_losses():
    """model.trace (what the database stores) sums per channel to the light that reaches the
    image: Beer-Lambert exp(-sigma_t d) for an absorbing medium; more, but less than 1, once the
    medium also scatters (in-scatter adds, out-scatter and absorption of blue remove)."""
    n, d = 2 ** 20, 1.5
    absorbing = Volume(VolumeConfig(albedo=(0.0, 0.0, 0.0), psf_resolution=33, samples=4,
                                    rays_per_psf=n, min_distance_m=d, max_distance_m=d + 0.01))
    psf = absorbing.trace(0)
    expected = math.exp(-0.9 * d)
    per_channel = n / 3.0
    for c in range(3):
        assert psf[..., c].sum() == pytest.approx(expected, abs=6 * math.sqrt(expected / per_channel))
    foggy = Volume(VolumeConfig(psf_resolution=65, samples=4, rays_per_psf=n, min_distance_m=d,
                                max_distance_m=d + 0.01))
    e = foggy.trace(0).sum(axis=(0, 1))
    assert np.all(e > expected) and np.all(e < 1.0) and e[2] < e[0]
