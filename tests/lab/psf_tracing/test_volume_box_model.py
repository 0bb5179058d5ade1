"""volume_box: a point seen through a shell of medium (camera gap, length, light gap), scattered light
only; checked against Beer-Lambert (what scatters) and the single-scattering integral of the shell."""
import math

import numpy as np
import pytest
from scipy import integrate

from lab.config import from_table
from lab.errors import UserError
from lab.optics.media import hg_pdf
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.volume_box import VolumeBox, VolumeBoxConfig


def test_registered_over_three_lengths():
    m = load_model("volume_box", {"samples": 20})
    assert get_model("volume_box") is VolumeBox and m.channels == 3 and m.symmetries == ("rotation",)
    assert m.grid.names == ("camera_gap_m", "medium_length_m", "light_gap_m") and m.grid.size >= 20
    assert all(lo == 0.0 for lo, _ in m.grid.ranges)


@pytest.mark.parametrize("table, match", [
    ({"max_distance_m": 9.0}, "max_distance_m = 9.0 does not apply to volume_box"),
    ({"majorant_ratio": 2.0}, "majorant_ratio = 2.0 does not apply"),
    ({"max_medium_length_m": 0.0}, "max_medium_length_m"),
    ({"box_center": [0.0, 0.0, 1.0]}, "come together"),
    ({"albedo": [0.9, 0.0, 0.9]}, "scatters nothing"),
])
def test_bad_configuration_is_refused(table, match):
    with pytest.raises(UserError, match=match):
        from_table(VolumeBoxConfig, table, "[psf.volume_box]")


def _model(**kw) -> VolumeBox:
    base = dict(medium_density=0.8, g=0.6, albedo=(1.0, 1.0, 1.0), width_px=64, focal_length_mm=18.0,
                sensor_width_mm=36.0, psf_resolution=131)
    return VolumeBox(VolumeBoxConfig(**{**base, **kw}))


@pytest.mark.parametrize("length", [0.3, 1.5])
def test_the_scattered_light_is_what_beer_lambert_takes_from_the_direct_beam(length):
    """Albedo 1, the light at the box (light gap 0), the camera 3 m beyond: every scattered photon
    crosses the camera sphere within asin(r1 / d) < 27 deg of its normal, inside the +-63 px window
    (63 deg at f = 32 px), so the stored PSF holds exactly the 1 - exp(-sigma L) the direct beam
    loses; the unscattered photons are not in it."""
    m = _model()
    n = 2 ** 20
    t = m.trace_box((3.0, length, 0.0), (3.0, length, 0.0), n_rays=n, seed=3)
    energy = m.window_energy(t)
    expected = 1.0 - math.exp(-0.8 * length)
    # binomial noise per channel (n/3 photons): 5 sigma
    assert np.allclose(energy, expected, atol=5 * math.sqrt(expected * (1 - expected) / (n / 3)))
    assert t.n_outside == 0


def _camera_ray_length_in_shell(s, view, cam, r0, r1):
    """Medium length of the camera ray's first s metres inside r0 <= |x| <= r1."""
    def inside_ball(radius):
        b = float(np.dot(cam, view))
        disc = b * b - (float(np.dot(cam, cam)) - radius * radius)
        if disc <= 0:
            return 0.0
        lo, hi = -b - math.sqrt(disc), -b + math.sqrt(disc)
        return max(0.0, min(hi, s) - max(lo, 0.0))
    return inside_ball(r1) - inside_ball(r0)


def shell_single_scatter_density(alpha, gap_cam, length, gap_light, sigma, g):
    """Expected camera crossings per emitted photon per steradian at view angle alpha, single
    scattering (albedo 1), the medium the shell gap_light <= |x| <= gap_light + length and the camera
    at d = gap_cam + length + gap_light: 4 pi d^2 cos(alpha) times the radiance integrated along the
    view ray, each point's light attenuated over its radial path in the shell and its way back to
    the camera (scipy.quad between the ray's shell crossings)."""
    r0, r1 = gap_light, gap_light + length
    d = r0 + length + gap_cam
    cam = np.array([0.0, 0.0, d])
    view = np.array([math.sin(alpha), 0.0, -math.cos(alpha)])

    def integrand(s):
        x = cam + s * view
        r = np.linalg.norm(x)
        if not r0 <= r <= r1:
            return 0.0
        mu = np.dot(x / r, -view)
        att = math.exp(-sigma * ((r - r0) + _camera_ray_length_in_shell(s, view, cam, r0, r1)))
        return sigma * att * hg_pdf(mu, g) / (2 * math.pi) / (4 * math.pi * r * r)

    b = d * math.cos(alpha)                       # the ray's closest approach to the light
    ends = [t for radius in (r0, r1) for t in (b - math.sqrt(max(b * b - d * d + radius * radius, 0.0)),
                                               b + math.sqrt(max(b * b - d * d + radius * radius, 0.0)))]
    total = integrate.quad(integrand, 0.0, 2 * d, limit=400, points=sorted(set(ends + [b])))[0]
    return 4 * math.pi * d * d * math.cos(alpha) * total


@pytest.mark.parametrize("gaps, g", [((0.5, 0.5), 0.0), ((1.0, 0.2), 0.7), ((0.2, 1.0), 0.7)])
def test_halo_matches_the_shells_single_scattering(gaps, g):
    """Optically thin (tau = 0.05) and one scattering at most: the traced halo per ring of pixels
    equals the single-scattering integral of the shell (MC noise ~1 %). Light scattered near the
    camera spreads wider than light scattered near the light: the two gap orders differ."""
    gap_cam, gap_light = gaps
    length, sigma, res, f = 1.0, 0.05, 101, 50.0
    m = _model(medium_density=sigma, g=g, psf_resolution=res, width_px=100, max_collisions=2)
    n = 2 ** 22
    t = m.trace_box((gap_cam, length, gap_light), (gap_cam, length, gap_light), n_rays=n, seed=5)
    counts = t.counts.sum(axis=2) / n
    yy, xx = np.mgrid[:res, :res] - res // 2
    rr = np.hypot(xx, yy)
    radii = np.linspace(2.5, 75.0, 60)
    profile = [shell_single_scatter_density(math.atan(r / f), gap_cam, length, gap_light, sigma, g) for r in radii]
    expected = np.interp(rr, radii, profile) * np.cos(np.arctan(rr / f)) ** 3 / f ** 2   # pixel solid angle
    for a, b in [(3, 6), (6, 12), (12, 24), (24, 48)]:
        ring = (rr >= a) & (rr < b)
        assert counts[ring].sum() == pytest.approx(expected[ring].sum(), rel=0.04), (gaps, g, a, b)
