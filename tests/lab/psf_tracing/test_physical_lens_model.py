"""PhysicalLens: a thick bi-convex N-BK7 lens light-traced by Snell's law, RGB at 650/510/475 nm."""
import math

import numpy as np
import pytest
from drjit.llvm import Float

from lab.config import from_table
from lab.errors import UserError
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.physical_lens import PhysicalLens, PhysicalLensConfig
from lab.psf_tracing.tracer import lane_rng

R = 181
C = R // 2
YY, XX = np.mgrid[:R, :R] - C
RR = np.hypot(XX, YY)
CORNER = 600.0          # about the half diagonal of the default 1024 x 683 image
N = 2 ** 20


@pytest.fixture(scope="module")
def model():
    return PhysicalLens(PhysicalLensConfig(psf_resolution=R))


def psf_at(model, depth, ecc, n=N, seed=1):
    t = model.trace_box((depth, ecc), (depth, ecc), n_rays=n, seed=seed)
    assert t.n_outside == 0
    return t


def r80(p):
    order = np.argsort(RR.ravel())
    return RR.ravel()[order][np.searchsorted(np.cumsum(p.ravel()[order]), 0.8)]


def rms_radius(p):
    return math.sqrt((p * RR ** 2).sum())


def moments(p):
    p = p / p.sum()
    mx, my = (p * XX).sum(), (p * YY).sum()
    return mx, my, (p * (XX - mx) ** 2).sum(), (p * (YY - my) ** 2).sum()


def test_registered_with_lsr18_defaults():
    m = load_model("physical_lens", {})
    assert get_model("physical_lens") is PhysicalLens and m.channels == 3
    assert m.grid.size >= 4000 and m.beta == (2.5, 1.2) and m.grid.ns == 2
    assert m.config.wavelengths_nm == (650.0, 510.0, 475.0) and "optical_axis" in m.symmetries
    assert 2.7 < m.camera.f_number < 2.9


@pytest.mark.parametrize("table, match", [
    ({"surfaces": [[0.0, 10.0, "air", 8.9], [50.0, 8.0, "BK7", 12.0], [-50.0, 0.0, "air", 12.0]]},
     r"'BK7' is not in the catalog; known glasses are \['F2', 'N-BK7'"),
    ({"focus_distance_m": 0.03}, "cannot focus"),
    ({"near_m": 0.005}, "near_m = 0.005"),
    ({"near_m": 5.0, "far_m": 2.0}, "near_m < far_m"),
    ({"wavelengths_nm": [650.0, 510.0, 100.0]}, "wavelength_nm = 100.0"),
    ({"focus": "sharpest"}, "focus = 'sharpest'"),
    ({"surfaces": [[0.0, 10.0, "air"]]}, "must have 4 entries"),
    ({"surfaces": [[0.0, 10.0, "air", 8.9], [50.0, 8.0, "N-BK7", 12.0]]}, "last surface's glass"),
    ({"aperture": "polygon", "aperture_blades": 2}, "aperture_blades = 2"),
    ({"angle_bins": 3}, "round aperture looks the same"),
    ({"aperture": "star", "angle_bins": 1.5}, "angle_bins = 1.5"),
])
def test_bad_configuration_is_refused_before_tracing(table, match):
    with pytest.raises(UserError, match=match):
        from_table(PhysicalLensConfig, table, "[psf.physical_lens]")


def test_in_focus_on_axis_psf_is_compact_and_defocus_spreads_it(model):
    sharp = psf_at(model, 2.0, 0.0).psf
    near = psf_at(model, 0.5, 0.0).psf
    for c in range(3):
        assert r80(sharp[..., c]) <= 5.0 < 10.0 <= r80(near[..., c])
        assert sharp[..., c].sum() == pytest.approx(1.0, abs=1e-5)


def test_on_axis_psf_is_rotationally_symmetric(model):
    p = psf_at(model, 0.7, 0.0).psf
    assert np.abs(p - p.transpose(1, 0, 2)).sum() / 3 < 0.1
    mx, my, vx, vy = moments(p[..., 1])
    assert abs(mx) < 0.05 and abs(my) < 0.05 and vx == pytest.approx(vy, rel=0.02)


def test_colour_fringes_follow_the_glass_dispersion(model):
    """N-BK7 bends blue more: near points (image behind the sensor) blur red widest, far points
    (image in front of it) blue widest, and off axis blue lands farthest in (lateral colour)."""
    near, far = psf_at(model, 0.5, 0.0).psf, psf_at(model, 20.0, 0.0).psf
    rn = [rms_radius(near[..., c]) for c in range(3)]
    rf = [rms_radius(far[..., c]) for c in range(3)]
    assert rn[0] > rn[1] > rn[2] and rf[2] > rf[1] > rf[0]
    corner = psf_at(model, 2.0, CORNER).psf
    cx = [moments(corner[..., c])[0] for c in range(3)]
    assert cx[0] > cx[1] > cx[2] and cx[0] - cx[2] > 1.0


def test_off_axis_psf_is_a_cat_eye(model):
    """The hood clips oblique beams on one side, the lens rim on the other: the pupil narrows
    along the radius (image x), not across it, and the PSF loses its left-right symmetry while
    keeping the mirror symmetry about the meridional plane (row flip)."""
    p = psf_at(model, 2.0, CORNER).psf
    assert np.abs(p - p[::-1]).sum() / 3 < 0.35
    assert np.abs(p - p[:, ::-1]).sum() / 3 > 1.0
    open_lens = PhysicalLens(PhysicalLensConfig(psf_resolution=R, surfaces=(
        (0.0, 10.0, "air", 8.9), (50.0, 8.0, "N-BK7", 19.0), (-50.0, 0.0, "air", 19.0))))
    q = psf_at(open_lens, 2.0, CORNER).psf
    _, _, vx, vy = moments(p.sum(axis=2))
    _, _, qx, qy = moments(q.sum(axis=2))
    assert vx < 0.6 * qx and vy > 0.75 * qy  # cut mostly along the radius
    assert open_lens.ray_statistics((2.0, CORNER), (2.0, CORNER), 2 ** 18)["vignetting_rate"] == 0.0


def test_vignetting_is_counted_and_grows_off_axis(model):
    rates = [model.ray_statistics((2.0, e), (2.0, e), 2 ** 18)["vignetting_rate"] for e in (0.0, 300.0, CORNER)]
    assert rates[0] == 0.0 and 0.0 < rates[1] < 0.1 < 0.2 < rates[2]


def test_energy_accounting_matches_the_ray_statistics(model):
    box = ((1.0, 400.0), (3.0, CORNER))
    n = 2 ** 18
    t = model.trace_box(*box, n_rays=n, seed=3)
    s = model.ray_statistics(*box, n_rays=n, seed=3)  # the tracer's streams: the very same rays
    landed = int(t.counts.sum())
    assert landed + t.n_outside + t.n_blocked == n
    assert s["reached"] == landed + t.n_outside
    assert s["rejected"] + s["missed_entrance"] + s["stopped"] + s["vignetted"] \
        + s["total_internal_reflection"] + s["reached"] == n
    assert t.n_blocked == n - s["reached"] and s["vignetted"] > 0
    assert np.allclose(t.psf.sum(axis=(0, 1)), 1.0, atol=1e-5)


def test_psf_centre_is_the_pinhole_image(model):
    """Near the axis, in focus, the PSF centroid sits at the pinhole image of the point (no
    distortion yet): the eccentricity <-> object point mapping is consistent."""
    p = psf_at(model, 2.0, 50.0).psf
    mx, my, _, _ = moments(p[..., 1])
    assert abs(mx) < 0.5 and abs(my) < 0.05


def test_points_are_emitted_uniformly_in_solid_angle(model):
    cam = model.camera
    n = 2 ** 20
    rng = lane_rng(n, 1)
    u = [rng.next_float32() for _ in range(3)]
    dist = 30.0  # close: the disc's density per area varies strongly (dz / r^3)
    q, _, _, keep = cam.draw_rays(Float(0.0), Float(cam.entry_z_mm - dist), *u)
    keep = keep.numpy()
    r = np.hypot(q[0].numpy(), q[1].numpy())[keep]
    a = cam.entry_radius_mm
    for rho in (2.0, 4.0, 6.0, 8.0):  # solid angle of the disc of radius rho / of the whole
        expected = (1 - dist / math.hypot(dist, rho)) / (1 - dist / math.hypot(dist, a))
        assert (r < rho).mean() == pytest.approx(expected, abs=0.002)
    px = 20.0  # off axis: the halves of the disc subtend different solid angles
    q, _, _, keep = cam.draw_rays(Float(px), Float(cam.entry_z_mm - dist), *u)
    keep = keep.numpy()
    xs = np.linspace(-a, a, 2001)
    gx, gy = np.meshgrid(xs, xs)
    inside = gx ** 2 + gy ** 2 <= a * a
    density = dist / ((gx - px) ** 2 + gy ** 2 + dist ** 2) ** 1.5 * inside
    assert (q[0].numpy()[keep] > 0).mean() == pytest.approx(density[gx > 0].sum() / density.sum(), abs=0.003)


def test_same_seed_same_psf(model):
    a = model.trace_box((1.0, 100.0), (1.2, 200.0), n_rays=2 ** 16, seed=4).counts
    b = model.trace_box((1.0, 100.0), (1.2, 200.0), n_rays=2 ** 16, seed=4).counts
    c = model.trace_box((1.0, 100.0), (1.2, 200.0), n_rays=2 ** 16, seed=5).counts
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_too_small_psf_resolution_is_refused_before_the_first_trace():
    m = PhysicalLens(PhysicalLensConfig(psf_resolution=65))
    need = m.required_resolution()
    assert 150 < need <= R
    with pytest.raises(UserError, match=f"psf_resolution >= {need}"):
        m.trace_checked(m.grid.size - 1)


def test_rays_per_cell_follow_the_psf_area(model):
    small = model.rays_for_cell(0)                  # nearest depth and eccentricity range start
    large = model.rays_for_cell(model.grid.size - 1)
    launch = model.config.rays_per_launch
    assert small % launch == 0 and large % launch == 0
    assert model.config.rays_per_psf <= small < large
