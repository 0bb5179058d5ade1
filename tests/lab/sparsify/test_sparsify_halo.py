"""Faint, smooth parts of a PSF survive sparsification: the Volume model's scattering halo.

Before the local level (:mod:`lab.sparsify.laplacian`), the point sources and coarse scales of the
noise model (:mod:`lab.sparsify.noise`) and the energy moment (:mod:`lab.sparsify.moments`), the
Volume PSF at 1 m (default settings) kept 84 - 91 % of its energy from 9 spreadlets and its halo
beyond 100 px was gone; at 5 m it kept 49 - 62 %.
"""
import math

import numpy as np
import pytest

from lab.precompute.cell import landed_rays
from lab.psf_tracing.models import load_model
from lab.psf_tracing.models.volume import Volume, VolumeConfig
from lab.sparsify import analytic, sparsify
from lab.sparsify.laplacian import importance, local_level, psf_laplacian
from lab.sparsify.moments import MomentMatch, moment_basis
from lab.sparsify.noise import coarse_laplacian, denoise, K_SIGMA
from lab.sparsify.voronoi import assign, collapse

RINGS = (1.5, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, math.inf)  # px, octaves from the centre


def histogram(psf, rays, seed=0):
    """``psf`` (R, R, 1) light-traced with ``rays`` equal-weight rays (count / rays, float32)."""
    p = psf[..., 0].astype(np.float64).ravel()
    counts = np.random.default_rng(seed).multinomial(rays, p / p.sum())
    return (counts.reshape(psf.shape[:2]) / rays).astype(np.float32)[..., None]


def sparsified_volume_psf(distance: float, seed: int = 0) -> tuple:
    """The Volume PSF of the cell nearest ``distance`` (default settings but ``seed``), its landed
    rays per channel, its sparsification and that sparsification reconstructed (float64)."""
    model = Volume(VolumeConfig(seed=seed))
    cell = min(range(model.grid.size), key=lambda i: abs(sum(model.boxes[i].lo + model.boxes[i].hi) / 2 - distance))
    traced = model.trace_checked(cell)
    rays = np.array(landed_rays(traced), np.float64)
    sp = sparsify(traced.psf, seed=cell, rays=landed_rays(traced))
    return traced.psf.astype(np.float64), rays, sp, sp.reconstruct(traced.psf.shape[0]).astype(np.float64)


@pytest.fixture(scope="module")
def volume_psfs():
    """Volume PSFs at the model's default settings (255^2 px, 2^23 photons) at 1 m and at 5 m,
    where 86 % of the light in the image is halo; with their sparsifications."""
    return {d: sparsified_volume_psf(d) for d in (1.0, 5.0)}


@pytest.mark.parametrize("distance", [1.0, 5.0])
def test_volume_psf_keeps_its_energy_within_the_ray_noise(volume_psfs, distance):
    """Each channel's integrated spreadlets hold the PSF's energy to within 5 sd of the Monte
    Carlo error of its halo's share, sqrt(p (1 - p) / N) for a share p of N landed rays (0.2 % at
    1 m, 0.3 - 0.4 % at 5 m): the loss would not stand out of the ray noise."""
    psf, rays, sp, rec = volume_psfs[distance]
    c = psf.shape[0] // 2
    halo = 1.0 - psf[c, c]
    bound = 5 * np.sqrt(halo * (1 - halo) / rays)
    assert not sp.fast_track and sp.stats["n_points"] < 0.05 * sp.stats["n_dense"]
    np.testing.assert_array_less(np.abs(rec.sum(axis=(0, 1)) - 1.0), bound)


def ring_errors(psf, rays, rec):
    """Per octave ring (rows) and channel: the reconstruction's energy less the PSF's, and 5 sd of
    the ring's Monte Carlo error, sqrt(p (1 - p) / N) for its share p of N landed rays."""
    c = psf.shape[0] // 2
    r = np.hypot(*(np.mgrid[:psf.shape[0], :psf.shape[1]] - c))
    errors, noise = [], []
    for lo, hi in zip(RINGS[:-1], RINGS[1:]):
        ring = (r >= lo) & (r < hi)
        dense = psf[ring].sum(axis=0)
        errors.append(rec[ring].sum(axis=0) - dense)
        noise.append(5 * np.sqrt(dense * (1 - dense) / rays))
    return np.array(errors), np.array(noise)


@pytest.mark.parametrize("distance", [1.0, 5.0])
def test_volume_halo_profile_matches_the_dense_psf(volume_psfs, distance):
    """Every octave ring from 1.5 px out keeps its energy to within 5 sd of its Monte Carlo error
    plus 3 % of the PSF's energy. Which Voronoi cells the noise gives a halo moves its energy by
    rings from one traced realisation to the next: over 16 seeds the worst ring was off by 0.5 %
    at 1 m and 2.6 % at 5 m (the 64 - 128 px ring; sd 0.9 %), while the rings' mean error over the
    seeds stays within 0.53 % (:func:`test_the_halo_profile_is_unbiased_over_realisations`). Before
    the sparsifier's halo work, the rings beyond 64 px lost 9 % of the energy at 1 m and 29 % at 5 m."""
    errors, noise = ring_errors(*(volume_psfs[distance][i] for i in (0, 1, 3)))
    assert (np.abs(errors) < noise + 0.03).all(), (errors, noise)


@pytest.mark.slow
@pytest.mark.parametrize("distance", [1.0, 5.0])
def test_the_halo_profile_is_unbiased_over_realisations(distance):
    """The rings' error averaged over 16 traced realisations (seeds) is within 1 % of the PSF's
    energy plus 5 sd of the mean's Monte Carlo error: the sparsifier moves no halo energy
    systematically (measured: at most 0.53 % at 5 m, 64 - 128 px, against a spread of the 16-seed
    mean of 0.23 %), so an image that sums many cells' halos keeps their profile."""
    errors, noise = [], None
    for seed in range(16):
        psf, rays, _, rec = sparsified_volume_psf(distance, seed)
        e, noise = ring_errors(psf, rays, rec)
        errors.append(e)
    mean = np.mean(errors, axis=0)
    assert (np.abs(mean) < noise / 4 + 0.01).all(), (mean, noise)


def test_traced_point_stays_a_point():
    """Albedo 0: the medium only absorbs, every photon that arrives lands in the centre pixel. Its
    ray count is known, yet the sparsified PSF is that one pixel, exactly: nothing is blurred into
    a halo."""
    model = Volume(VolumeConfig(albedo=(0.0, 0.0, 0.0), psf_resolution=65))
    traced = model.trace_box((2.0,), (2.0,), n_rays=2 ** 18, seed=1)
    sp = sparsify(traced.psf, rays=landed_rays(traced))
    np.testing.assert_array_equal(sp.reconstruct(65), traced.psf)
    delta = analytic.delta(33, channels=1)
    np.testing.assert_array_equal(sparsify(delta, rays=2 ** 20).reconstruct(33), delta)


def test_noise_alone_grows_no_spreadlets_and_no_halo():
    """The inside of a light-traced disc (52 rays per pixel) is noise around a constant. Its
    spreadlets stay on the rim: the 3-sigma floor lets about 0.13 % of pure-noise pixels through,
    4 of the 2 800 pixels deeper than 8 px inside, 1 % of the spreadlets, and no more get there.
    The reconstruction inside is flat to 1.5 % of the level (one pixel's noise is 14 %), and
    beyond 5 px outside the rim (a 3 px ramp blurred by at most 2 sigma) it holds under 0.2 % of
    the energy."""
    f = analytic.prefiltered_disc(128, 40.0, 3.0)
    sp = sparsify(histogram(f, 2 ** 18, seed=1), rays=2 ** 18, seed=3)
    rec = sp.reconstruct(128)[..., 0].astype(np.float64)
    r = np.hypot(*(np.mgrid[:128, :128] - 64))
    assert (np.hypot(*sp.points.T.astype(np.float64)) < 32).sum() <= 0.01 * len(sp.points)
    level = f.max()
    assert np.abs(rec[r < 30] - level).mean() < 0.015 * level
    assert np.abs(rec[r > 48]).sum() < 2e-3


def test_local_level_is_the_level_on_a_disc_and_follows_a_faint_part():
    f = analytic.prefiltered_disc(96, 20.0, 3.0).astype(np.float64)
    level = (f * f).sum() / f.sum()
    on = (psf_laplacian(f) != 0)
    np.testing.assert_allclose(local_level(f)[on], level)
    # a point and, far from it, a faint ring: the ring is measured against its own height
    g = 1e-3 * analytic.prefiltered_disc(96, 30.0, 3.0).astype(np.float64)
    g[48, 48] += 1.0
    lv = local_level(g)
    faint = g[48, 30, 0]                                  # the ring's plateau, 1e-3 of a disc's
    assert lv[48, 48, 0] == pytest.approx((g * g).sum() / g.sum())
    assert lv[48, 18, 0] == pytest.approx(faint)          # its rim, measured against its height
    assert lv[48, 45, 0] == pytest.approx(faint)          # the point does not set its neighbours'
    # a structure thinner than 2 px (a plus of 5 pixels) still sets its own Laplacian's level
    plus = np.zeros((16, 16, 1))
    plus[7:10, 8, 0] = plus[8, 7:10, 0] = 0.2
    lap = psf_laplacian(plus)
    imp = importance(plus, lap)
    assert np.isfinite(imp).all() and np.array_equal(imp > 0, lap[..., 0] != 0)


def test_denoise_keeps_a_point_spreads_a_faint_halo_and_keeps_a_cut_edge():
    """A point of 800 000 rays keeps its rays; its halo of ~17 rays per pixel 40 px out gets a
    wide filter; the halo, cut by the image edge, keeps its height up to that edge (no shoulder);
    the sum is 1."""
    R = 97
    r = np.hypot(*(np.mgrid[:R, :R] - R // 2))
    halo = np.zeros((R, R, 1))
    halo[2:-2, 2:-2, 0] = 1.0 / (1.0 + r[2:-2, 2:-2])
    psf = 0.2 * halo / halo.sum()
    psf[R // 2, R // 2, 0] += 0.8
    rays = 2 ** 20
    h = histogram(psf, rays, seed=2).astype(np.float64)
    dn = denoise(h, np.array([1.0 / rays]))
    assert dn.sigma_map[R // 2, R // 2] == 0
    assert dn.psf[R // 2, R // 2, 0] == pytest.approx(h[R // 2, R // 2, 0], rel=1e-3)
    assert (dn.sigma_map[np.abs(r - 40) < 2] >= 2.0).all()
    np.testing.assert_allclose(dn.psf.sum(), 1.0)
    # at the edge the kernel averages the inner side only: a bias of about 0.8 sigma times the
    # relative slope, 4 % here; cut and renormalised instead, the edge row would lose ~40 %
    edge = dn.psf[2, 20:-20, 0].mean() / psf[2, 20:-20, 0].mean()
    assert edge == pytest.approx(1.0, abs=0.06)


def test_coarse_scales_find_a_smooth_halo_but_not_noise():
    """A broad Gaussian halo at 20 rays per pixel: its Laplacian is far below the per-pixel floor,
    yet the coarse scales find it on most of the ring 10 - 30 px out (inside its inflection at
    35 px). On a flat field at the same ray density, what crosses the soft floor by chance stays
    under a tenth of the halo's Laplacian (in units of the level), where one dart-throwing disk
    spans more than 20 px."""
    R = 129
    y, x = np.mgrid[:R, :R] - R // 2
    ring = (np.hypot(x, y) > 10) & (np.hypot(x, y) < 30)
    halo = np.zeros((R, R, 1))
    halo[4:-4, 4:-4, 0] = np.exp(-(x * x + y * y) / (2 * 25.0 ** 2))[4:-4, 4:-4]
    flat = np.where(halo > 0, 1.0, 0.0)
    true = np.abs(psf_laplacian(halo)[ring, 0]).mean() / halo.max()
    found = {}
    for name, field in (("halo", halo), ("flat", flat)):
        p = field / field.sum()
        rays = int(20 * (field > 0).sum())
        h = histogram(p, rays, seed=4).astype(np.float64)
        q = np.array([1.0 / rays])
        dn = denoise(h, q)
        lap = psf_laplacian(dn.psf)
        floor = K_SIGMA * dn.lap_sd
        found[name] = coarse_laplacian(lap, floor, h, q)[ring, 0] / p.max()
        if name == "halo":
            assert (np.abs(lap[ring, 0]) > floor[ring, 0]).mean() < 0.05
    assert (found["halo"] > 0).mean() > 0.5
    assert found["flat"].max() < 0.1 * true


def test_moment_match_restores_the_energy_by_scaling():
    """After a coarse collapse the spreadlets' second moment (4 x energy) falls short; the match
    restores it and the five harmonic moments together."""
    f = analytic.prefiltered_disc(64, 16.0, 3.0).astype(np.float64)
    lap = psf_laplacian(f)[..., 0]
    sy, sx = np.nonzero(lap)
    rng = np.random.default_rng(0)
    pick = rng.choice(sy.size, 60, replace=False)
    py, px = sy[pick], sx[pick]
    labels, _ = assign(sy, sx, py, px, lap.shape)
    raw = collapse(labels, lap[sy, sx][:, None], py.size)
    match = MomentMatch(sy, sx, lap[sy, sx][:, None])
    fixed = match(py, px, raw)
    basis = moment_basis(py, px, match.cy, match.cx, match.scale)
    assert abs((basis @ raw)[5, 0] - match.target[5, 0]) > 1e-3 * abs(match.target[5, 0])
    np.testing.assert_allclose(basis @ fixed, match.target, atol=1e-12)
    energy = (((py - 32.0) ** 2 + (px - 32.0) ** 2) * fixed[:, 0]).sum() / 4
    assert energy == pytest.approx(f.sum(), rel=1e-9)


# mean SSIM over seeds 0, 1, 2 of the sparsifier before this change (commit db45ee0) on the same
# traced PSFs; a 3-seed mean varies by about 0.003 with the seed (per-seed sd 0.001 - 0.005)
BASELINE = [("simple_lens", {"max_coc_px": 24.0}, 98, 0.9120),
            ("combined", {"max_coc_px": 16.0, "max_motion_px": 32.0}, 415, 0.9830),
            ("stylized", {"max_coc_px": 40.0}, 185, 0.9558),
            ("stylized", {"max_coc_px": 40.0}, 196, 0.9469),
            ("physical_lens", {}, 4054, 0.9825)]


@pytest.mark.parametrize("name, table, cell, before", BASELINE)
def test_other_models_keep_their_similarity(name, table, cell, before):
    traced = load_model(name, table).trace_checked(cell)
    ssim = [sparsify(traced.psf, seed=s, rays=landed_rays(traced)).stats["ssim"] for s in (0, 1, 2)]
    assert np.mean(ssim) > before - 0.003
