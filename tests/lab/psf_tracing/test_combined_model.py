"""Combined (DoF + linear motion): capsule length, energy, exact pixel probabilities, zero motion,
in-focus lines, pre-filtering, the runtime's rotation rules, config errors."""
import math

import numpy as np
import pytest
from scipy import stats

from lab.config import from_table
from lab.errors import UserError
from lab.psf_tracing.analytic import prefiltered_disc_psf
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.combined import Combined, CombinedConfig, min_combined_resolution
from lab.optics.motion import LinearMotion
from lab.psf_tracing.tracer import RayHits, trace_psf
from runtime_cl.psf.disc import disc_area_in_rect

R = 61
BASE = {"max_coc_px": 12.0, "max_motion_px": 32.0, "psf_resolution": R, "rays_per_psf": 2 ** 18,
        "rays_per_pixel": 64, "rays_per_launch": 2 ** 20}
MODEL = load_model("combined", BASE)
K = np.arange(R) - R // 2


def moments(psf):
    """(E[x^2], E[y^2]) over pixel centres (x right, y down) of a 2D PSF."""
    return float((psf * K[None, :] ** 2).sum()), float((psf * K[:, None] ** 2).sum())


def capsule_reference(r, length, resolution=R, nodes=1024):
    """Exact pixel probabilities of a disc of radius r swept along x over [-l/2, l/2] (midpoint
    rule in t; the integrand is continuous, so the error falls like nodes^-2)."""
    c = resolution // 2
    kx, ky = math.ceil(length / 2 + r + 0.5), math.ceil(r + 0.5)  # the pixels the capsule touches
    ex, ey = np.arange(-kx, kx + 2) - 0.5, np.arange(-ky, ky + 2) - 0.5
    x0, x1, y0, y1 = ex[None, :-1], ex[None, 1:], ey[:-1, None], ey[1:, None]
    window = np.zeros((2 * ky + 1, 2 * kx + 1))
    for s in ((np.arange(nodes) + 0.5) / nodes - 0.5) * length:
        window += disc_area_in_rect(r, x0 - s, x1 - s, y0, y1)
    out = np.zeros((resolution, resolution))
    out[c - ky:c + ky + 1, c - kx:c + kx + 1] = np.maximum(window, 0.0) / (nodes * math.pi * r * r)
    return out


def pooled_chisquare_p(counts, ref, n):
    """Pearson chi-square p-value of counts against n * ref, pixels expecting < 20 pooled in one bin."""
    big = n * ref >= 20
    observed, expected = counts[big], n * ref[big]
    if ref[~big].sum() > 0:
        observed, expected = np.append(observed, counts[~big].sum()), np.append(expected, n * ref[~big].sum())
    assert observed.sum() == n
    return stats.chisquare(observed, expected).pvalue


def test_defaults_follow_lsr18_table_1():
    m = Combined(CombinedConfig(max_coc_px=100.0, max_motion_px=200.0))
    assert get_model("combined") is Combined
    assert m.grid.ns == 2 and m.channels == 1 and m.beta == (2.0, 1.0) and m.grid.size >= 400
    assert m.grid.ranges == ((0.0, 100.0), (0.0, 200.0))
    assert m.symmetries == ("motion_direction", "coc_sign") and m.reference_direction_deg == 0.0
    assert m.config.psf_resolution == 512 and m.config.aperture == "circle"


@pytest.mark.parametrize("r, length", [(6.0, 30.0), (3.5, 11.0)])
def test_capsule_length_and_width_match_the_motion(r, length):
    res = MODEL.trace_box([r, length], [r, length], n_rays=2 ** 20, seed=1)
    psf = res.psf[..., 0]
    assert res.n_outside == 0 and psf.astype(np.float64).sum() == pytest.approx(1.0, abs=1e-6)
    ys, xs = np.nonzero(psf)
    half = length / 2 + r  # capsule reach along the motion
    assert half - 1 < np.abs(xs - R // 2).max() <= half + 0.5
    assert r - 1 < np.abs(ys - R // 2).max() <= r + 0.5
    # variance along the motion = disc (r^2 / 4) + uniform segment (l^2 / 12), plus pixel binning:
    # exactly those of the exact pixel probabilities, and close to Sheppard's + 1/12
    ex2, ey2 = moments(psf)
    rx2, ry2 = moments(capsule_reference(r, length))
    assert ex2 == pytest.approx(rx2, rel=0.004) and ey2 == pytest.approx(ry2, rel=0.004)
    assert rx2 == pytest.approx(r * r / 4 + length ** 2 / 12 + 1 / 12, rel=0.02)
    assert ry2 == pytest.approx(r * r / 4 + 1 / 12, rel=0.02)


def test_counts_are_multinomial_in_the_exact_capsule_probabilities():
    r, length, n = 5.0, 20.0, 2 ** 17
    ref = capsule_reference(r, length)
    counts = MODEL.trace_box([r, length], [r, length], n_rays=n, seed=2).counts[..., 0]
    assert pooled_chisquare_p(counts, ref, n) > 1e-3
    # a capsule 5 % longer is rejected: the test can fail
    assert pooled_chisquare_p(counts, capsule_reference(r, 1.05 * length), n) < 1e-6
    # the ends are dimmer than the middle: intensity varies along the capsule
    assert ref[R // 2, R // 2] > 2 * ref[R // 2, R // 2 + 14]


def test_zero_motion_gives_the_simple_lens_disc():
    r, n = 7.3, 2 ** 17
    combined = MODEL.trace_box([r, 0.0], [r, 0.0], n_rays=n, seed=3).counts[..., 0]
    simple = load_model("simple_lens", {"max_coc_px": 12.0, "psf_resolution": R})
    disc = simple.trace_box([r], [r], n_rays=n, seed=3).counts[..., 0]
    ref = prefiltered_disc_psf(r, r, R)
    for c in (combined, disc):
        assert pooled_chisquare_p(c, ref, n) > 1e-3
    # same support as the exact disc: no ray outside it, no well-covered pixel empty
    assert np.all(ref[combined > 0] > 0) and np.all(combined[n * ref > 10] > 0)


def test_in_focus_motion_is_a_line():
    length, n = 24.0, 2 ** 18
    psf = MODEL.trace_box([0.0, length], [0.0, length], n_rays=n, seed=4).psf[..., 0]
    rows = np.flatnonzero(psf.sum(axis=1))
    assert rows.tolist() == [R // 2]
    line = psf[R // 2]
    cols = np.flatnonzero(line) - R // 2
    # t in [0, 1): x in [-12, 12); pixel k holds [k - 1/2, k + 1/2), so the end pixels are half full
    assert cols.tolist() == list(range(-12, 13))
    assert np.allclose(line[R // 2 - 11:R // 2 + 12], 1 / length, rtol=0.05)  # constant speed
    assert np.allclose(line[[R // 2 - 12, R // 2 + 12]], 0.5 / length, rtol=0.05)


def test_prefiltered_cell_averages_over_its_box():
    cell = MODEL.grid.size - 3
    b = MODEL.boxes[cell]
    (r0, l0), (r1, l1) = b.lo, b.hi
    assert r1 > r0 and l1 > l0
    psf = MODEL.trace(cell)[..., 0]
    er2 = (r1 ** 3 - r0 ** 3) / (3 * (r1 - r0))
    el2 = (l1 ** 3 - l0 ** 3) / (3 * (l1 - l0))
    ex2, ey2 = moments(psf)
    assert ex2 == pytest.approx(er2 / 4 + el2 / 12 + 1 / 12, rel=0.01)
    assert ey2 == pytest.approx(er2 / 4 + 1 / 12, rel=0.01)
    assert MODEL.rays_for_cell(cell) % MODEL.config.rays_per_launch == 0


def test_last_cell_fits_the_minimum_resolution():
    need = min_combined_resolution(12.0, 32.0)
    assert need == 2 * (12 + 16 + 2) + 1
    m = load_model("combined", {**BASE, "psf_resolution": need})
    res = m.trace_cell(m.grid.size - 1, n_rays=2 ** 18)
    assert res.n_outside == 0 and res.psf[:2].sum() == 0 and res.psf[:, -2:].sum() == 0


def test_rotating_the_reference_direction_is_a_rotation_of_the_psf():
    up = load_model("combined", {**BASE, "motion_direction_deg": 90.0})
    a = MODEL.trace_box([4.0, 20.0], [4.0, 20.0], n_rays=2 ** 18, seed=5).psf[..., 0]
    b = up.trace_box([4.0, 20.0], [4.0, 20.0], n_rays=2 ** 18, seed=5).psf[..., 0]
    # np.rot90 turns the displayed image (rows down) counter-clockwise: +x motion -> upward motion
    assert np.abs(np.rot90(a) - b).sum() < 0.05
    assert np.abs(a - b).sum() > 1.0


def test_far_side_is_the_stored_psf_rotated_by_180_degrees():
    """The runtime rule for symmetry coc_sign, checked against a physical trace of a point behind
    the focal plane (CoC > 0) through a triangular iris, whose two orientations differ."""
    m = load_model("combined", {**BASE, "aperture": "polygon", "aperture_blades": 3})
    r, length, direction = 8.0, 14.0, 30.0
    motion = LinearMotion(direction)
    assert r < m.lens.max_far_coc_px(m.config.lens_width_px)

    def far_side(coords, rng):
        inv_depth = m.lens.inv_depth_for_coc_px(coords[0], m.config.lens_width_px)
        h = m.aperture.sample_rng(rng) * m.lens.aperture_radius_m
        off = m.lens.psf_offset_px(h, inv_depth, m.config.lens_width_px)
        return RayHits(off + motion.offset_px(rng.next_float32(), coords[1]))

    far = trace_psf(far_side, [r, length], [r, length], R, 2 ** 19, seed=6).psf[..., 0]
    point = [r, length, direction]
    stored = m.trace_box(point, point, n_rays=2 ** 19, seed=6).psf[..., 0]
    assert np.abs(np.rot90(stored, 2) - far).sum() < 0.05
    assert np.abs(stored - far).sum() > 0.2


def test_polygon_capsule_sweeps_the_polygon():
    m = load_model("combined", {**BASE, "aperture": "polygon", "aperture_blades": 6})
    psf = m.trace_box([10.0, 0.0, 0.0], [10.0, 0.0, 0.0], n_rays=2 ** 18, seed=7).psf[..., 0]
    ys, xs = np.nonzero(psf)
    # hexagon, corner up (near side: down): 10 px up/down, apothem 8.66 px sideways
    assert np.abs(ys - R // 2).max() == 10 and np.abs(xs - R // 2).max() == 9


@pytest.mark.parametrize("table, match", [
    ({"max_motion_px": -4.0}, "max_motion_px = -4.0"),
    ({"max_motion_px": 0.0}, "simple_lens"),
    ({"max_coc_px": -1.0}, "max_coc_px"),
    ({"psf_resolution": 40}, r"psf_resolution >= 61"),
    ({"beta": [2.0]}, "beta"),
    ({"beta": [2.0, -1.0]}, "beta"),
    ({"motion_direction_deg": float("nan")}, "motion_direction_deg"),
    ({"aperture": "polygon", "aperture_blades": 2}, "aperture_blades = 2"),
    ({"aperture": "polygon", "aperture_rounding": -0.5}, "aperture_rounding = -0.5"),
    ({"aperture_blades": 6}, r"does not use \['aperture_blades'\]"),
    ({"aperture": "image"}, "needs aperture_image"),
    ({"aperture": "image", "aperture_image": "/nonexistent/iris.png"}, "iris.png: no such file"),
    ({"motion_px": 3.0}, r"unknown key\(s\) \['motion_px'\]"),
    ({"basis": "rows"}, r"basis = 'rows': choose one of \['dual', 'laplacian'\]"),
    ({"angle_bins": 4}, "round aperture looks the same"),
    ({"aperture": "star", "angle_bins": 0}, "angle_bins = 0"),
    ({"aperture": "star", "angle_bins": 5000}, "at most 4096"),
    ({"aperture": "heart", "motion_direction_deg": 30.0}, "traces every motion direction"),
    ({"samples": 0}, "samples"),
])
def test_bad_config_is_a_user_error_before_tracing(table, match):
    with pytest.raises(UserError, match=match) as info:
        from_table(CombinedConfig, {**BASE, **table}, "scene.toml [psf.combined]")
    assert "scene.toml [psf.combined]" in str(info.value)
