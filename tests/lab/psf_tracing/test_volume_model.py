"""Volume: a point light in a homogeneous medium (Woodcock tracking, Henyey-Greenstein), RGB,
checked against Beer-Lambert and the single-scattering integral."""
import functools
import math

import numpy as np
import pytest
from scipy import integrate

from lab.config import from_table
from lab.errors import UserError
from lab.optics.media import hg_pdf
from lab.psf_tracing import walks
from lab.psf_tracing.models import get_model, load_model, volume
from lab.psf_tracing.models.volume import Volume, VolumeConfig
from lab.psf_tracing.tracer import lane_rng


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


# --- the fast tracer against the plain reference (tests/lab/psf_tracing/volume_reference.py) ----

RINGS_PX = (0.0, 0.5, 4.0, 16.0, 48.0, 125.0)      # centre pixel, then octave-ish rings to the edge


def _rings(counts):
    """Weighted crossings per ring and channel: (len(RINGS_PX) - 1, 3)."""
    res = counts.shape[0]
    rr = np.hypot(*(np.mgrid[:res, :res] - res // 2))
    return np.array([counts[(rr >= a) & (rr < b)].sum(axis=0) for a, b in zip(RINGS_PX, RINGS_PX[1:])])


@pytest.mark.parametrize("table, distance", [
    ({}, 4.99),                                                   # the benchmark's cell: ~25 collisions
    ({"g": -0.6, "albedo": (0.3, 0.6, 1.0), "medium_density": 1.5}, 1.2),
])
def test_the_fast_tracer_matches_the_plain_reference(table, distance):
    """Persistent lanes, one absorption draw per photon, channels by ray index, the cone test and
    the 32-bit generator change how a photon is traced, not what it does: per channel and per
    ring the light in the image agrees with the textbook tracer (random channel, an albedo coin
    per collision, every crossing projected, PCG32). Counts are sums of ~Poisson events (weights
    k are 1 for all but ~1e-3 of the rays); each of the 15 comparisons may differ by 5 sigma of
    the two estimates combined (with the reference's binomial channel sizes), a false alarm
    once in ~10^5 runs."""
    from volume_reference import reference_trace
    c = VolumeConfig(**table)
    n = 2 ** 22
    fast = Volume(c).trace_box((distance,), (distance,), n_rays=n, seed=11)
    ref = reference_trace(c, distance, n, seed=12)
    a, b = _rings(fast.counts) / (n / 3), _rings(ref.counts) / (n / 3)
    sigma = np.sqrt(a / (n / 3) + b / (n / 3) + (b * np.sqrt(2.0 / n)) ** 2)
    assert np.all(np.abs(a - b) <= 5 * sigma), (a, b, (a - b) / sigma)
    assert np.all(a[1:].sum(axis=0) > 0.05 * a.sum(axis=0))       # a real halo was compared


@pytest.mark.parametrize("roulette_mfp", [0.5, 0.02])
def test_the_roulette_keeps_the_expected_psf(roulette_mfp):
    """Russian roulette changes the weights, not the expectation: per ring and channel, the mean
    over 8 seeds with roulette (the default 0.5 mean free paths, and 0.02, where most paths pass
    several shells and weights reach 2^12; at 4 mean free paths with isotropic scattering many
    crossings come after a path has left the sphere and passed shells) agrees with the mean without it, within 5 standard
    errors estimated from the seeds' own spread (heavy weights make the counts non-Poisson)."""
    def rings(rm, seed):
        m = Volume(VolumeConfig(roulette_mfp=rm, psf_resolution=129, medium_density=2.0, g=0.0))
        return _rings(m.trace_box((2.0,), (2.0,), n_rays=3 * 2 ** 18, seed=seed).counts) / 2 ** 18
    with_r = np.array([rings(roulette_mfp, s) for s in range(8)])
    without = np.array([rings(0.0, 100 + s) for s in range(8)])
    se = np.sqrt(with_r.var(axis=0, ddof=1) / 8 + without.var(axis=0, ddof=1) / 8)
    diff = with_r.mean(axis=0) - without.mean(axis=0)
    assert np.all(np.abs(diff) <= 5 * se + 1e-12), diff / se
    assert np.all(without.mean(axis=0)[1:] > 0)                      # every ring has light


def _same_trace(model, distance, n=2 ** 18, seed=4):
    return model.trace_box((distance,), (distance,), n_rays=n, seed=seed).counts


@pytest.mark.parametrize("table, distance", [({}, 4.99), ({}, 0.3), ({"focal_length_mm": 18.0, "width_px": 100,
                                                                       "psf_resolution": 101}, 2.0)])
def test_the_cone_test_never_drops_a_crossing_the_camera_sees(monkeypatch, table, distance):
    """The walk projects a crossing only if it lies within a cone around the sphere's normal
    (:func:`volume._cone`). Projecting every crossing instead gives bitwise the same PSF: the cone
    is conservative (far field, the near-distance fallback, a wide field of view)."""
    model = Volume(VolumeConfig(**table))
    fast = _same_trace(model, distance)
    monkeypatch.setattr(volume, "_cone", lambda radius_px, focal_px: (0.0, 1e30))
    assert np.array_equal(_same_trace(model, distance), fast) and fast.sum() > 0


def test_the_psf_does_not_depend_on_how_photons_are_spread_over_lanes(monkeypatch):
    """A photon's random numbers come from its ray's generator, so the lanes, the steps per loop
    iteration and the restart period change nothing, bitwise."""
    model = Volume(VolumeConfig(psf_resolution=65))
    base = _same_trace(model, 3.0)
    monkeypatch.setattr(volume, "WALK_LANES", 1000)
    monkeypatch.setattr(walks, "run_walks", functools.partial(walks.run_walks, unroll=3, period=1))
    monkeypatch.setattr(volume, "run_walks", walks.run_walks)
    assert np.array_equal(_same_trace(model, 3.0), base)


@pytest.mark.parametrize("albedo", [0.9, 0.5])
def test_one_absorption_draw_per_path_is_an_albedo_coin_per_collision(albedo):
    """Channel c of a path survives S_c real collisions, S_c = floor(ln u / ln albedo_c): P(S >=
    j) = albedo^j, as with an independent coin at each collision. Chi-square of S against the
    geometric law (bins with >= 5 expected photons, the tail pooled), p > 1e-4; albedo 1 never
    absorbs and albedo 0 at the first collision."""
    from scipy import stats
    from drjit.llvm import Float, UInt32
    from lab.psf_tracing.rng32 import Xoroshiro64
    c = VolumeConfig(albedo=(albedo, 1.0, 0.0))
    m = 2 ** 18
    lnu = volume._emitted(Xoroshiro64.from_pcg32(lane_rng(m, 8))).lnu
    cap = UInt32(c.max_collisions - 1)

    def survived(inv):
        """S_c: the float32 product floored and capped, checked against _survives at S and S + 1."""
        prod = lnu.numpy() * np.float32(inv)
        s = np.minimum(np.floor(prod), c.max_collisions - 1).astype(np.uint32)
        assert np.all(volume._survives(lnu, UInt32(s), Float(inv), cap).numpy())
        assert not np.any(volume._survives(lnu, UInt32(s + 1), Float(inv), cap).numpy())
        return s
    inv = [volume._inv_log(a) for a in c.albedo]
    assert np.all(survived(inv[1]) == c.max_collisions - 1) and np.all(survived(inv[2]) == 0)
    s = survived(inv[0])
    last = int(np.floor(np.log(5.0 / m) / np.log(albedo)))          # P(S = j) m >= ~5 up to here
    observed = np.append(np.bincount(s, minlength=last + 1)[:last], (s >= last).sum())
    expected = m * np.append((1 - albedo) * albedo ** np.arange(last), albedo ** last)
    assert stats.chisquare(observed, expected).pvalue > 1e-4


def test_the_roulette_shell_a_path_dies_at_halves_with_every_shell():
    """A path dies at roulette shell L + 1, P(L >= k) = 2^-k (a fair coin at each shell; L
    capped at _ROULETTE_SHELLS: never dies). Chi-square over k = 0 .. 11 and the cap, p > 1e-4."""
    from scipy import stats
    from lab.psf_tracing.rng32 import Xoroshiro64
    m = 2 ** 18
    level = volume._emitted(Xoroshiro64.from_pcg32(lane_rng(m, 9))).level.numpy()
    assert np.all(level & 0xFF == 0)                                  # no shell passed yet
    dies = (level >> 8) - 1
    cap = volume._ROULETTE_SHELLS
    observed = np.bincount(dies, minlength=cap + 1)
    expected = m * np.append(0.5 ** np.arange(1, cap + 1), 0.5 ** cap)      # all >= 5 at this m
    assert dies.max() <= cap and stats.chisquare(observed, expected).pvalue > 1e-4


def test_reservoir_numbers_are_uniform_and_independent_of_the_crossing_index():
    """The reservoir keeps a ray's k-th crossing in the image with probability 1/k using a number
    hashed from (ray, k, launch key): uniform over rays for each k (chi-square, 64 bins,
    p > 1e-4) and uncorrelated between k and k + 1 and between launches."""
    from scipy import stats
    from drjit.llvm import UInt32
    n = 2 ** 18
    ray = UInt32(np.arange(n, dtype=np.uint32))
    u = {(k, key): volume._hashed_uniform(ray, UInt32(k), UInt32(key)).numpy()
         for k in (1, 2, 3) for key in (12345, 67890)}
    for v in u.values():
        assert 0.0 <= v.min() and v.max() < 1.0
        assert stats.chisquare(np.histogram(v, 64, (0, 1))[0]).pvalue > 1e-4
    bound = 5.0 / np.sqrt(n)
    assert abs(np.corrcoef(u[1, 12345], u[2, 12345])[0, 1]) < bound
    assert abs(np.corrcoef(u[2, 12345], u[3, 12345])[0, 1]) < bound
    assert abs(np.corrcoef(u[1, 12345], u[1, 67890])[0, 1]) < bound
