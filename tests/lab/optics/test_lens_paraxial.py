"""The thick lens against independent figures: Schott's tabulated indices, ABCD ray-transfer
matrices for focal lengths, pupils and image scale, and a traced defocus spot's size in pixels.

The ABCD matrices here are written from the surface rows alone (translation [[1, d], [0, 1]],
refraction [[1, 0], [-(n2 - n1) / (n2 R), n1 / n2]] on (height, angle)), not from the lens
code's y-nu trace, so a wrong focal length, pupil, sensor scale or pixel scale fails here.
"""
import math

import numpy as np
import pytest

from lab.optics.glass import get_glass
from lab.optics.lens_camera import ThickLensCamera
from lab.optics.thick_lens import LensSystem
from lab.psf_tracing.models.physical_lens import PhysicalLens, PhysicalLensConfig
from lab.psf_tracing.models.physical_lens_config import DEFAULT_SURFACES

D_NM = 587.5618

# Schott optical glass data sheets: n at the tabulated lines (nm), 5 decimals as printed.
SCHOTT = {
    "N-BK7": {365.01: 1.53627, 404.66: 1.53024, 435.83: 1.52668, 479.99: 1.52283, 486.13: 1.52238,
              546.07: 1.51872, 587.56: 1.51680, 632.8: 1.51509, 656.27: 1.51432, 706.52: 1.51289,
              852.11: 1.50980, 1013.98: 1.50731, 1529.6: 1.50091, 1970.1: 1.49495, 2325.4: 1.48921},
    "F2": {404.66: 1.65064, 435.83: 1.64202, 479.99: 1.63310, 486.13: 1.63208, 546.07: 1.62408,
           587.56: 1.62004, 632.8: 1.61656, 656.27: 1.61503, 706.52: 1.61227, 852.11: 1.60671,
           1013.98: 1.60279},
}

# A cemented N-BK7 / F2 doublet behind a stop, and a lens with an element in front of its stop.
DOUBLET = ((0.0, 3.0, "air", 6.0), (61.0, 6.0, "N-BK7", 12.0), (-44.0, 2.5, "F2", 12.0),
           (-129.0, 0.0, "air", 12.0))
FRONT_ELEMENT = ((40.0, 4.0, "N-BK7", 10.0), (math.inf, 5.0, "air", 10.0), (0.0, 5.0, "air", 6.0),
                 (60.0, 5.0, "N-BK7", 10.0), (-60.0, 0.0, "air", 10.0))


@pytest.mark.parametrize("glass", sorted(SCHOTT))
def test_sellmeier_indices_match_schotts_table_across_the_range(glass):
    g = get_glass(glass)
    for nm, n in SCHOTT[glass].items():
        assert float(g.index(nm)) == pytest.approx(n, abs=1e-5), nm   # the table's last digit


def _translate(d):
    return np.array([[1.0, d], [0.0, 1.0]])


def _refract(radius, n1, n2):
    power = 0.0 if radius in (0.0, math.inf) else (n2 - n1) / (n2 * radius)
    return np.array([[1.0, 0.0], [-power, n1 / n2]])


def abcd(rows, nm, upto=None):
    """Ray-transfer matrix from z = 0 (the first vertex) through the rows (all of them, or those
    before ``upto``), ending on the last vertex plane (``upto``: that surface's plane)."""
    m, n1 = np.eye(2), 1.0
    for i, (radius, thickness, glass, _) in enumerate(rows):
        if i == upto:
            return m
        n2 = n1 if radius == 0.0 else float(get_glass(glass).index(nm))
        m = _refract(radius, n1, n2) @ m
        n1 = n2
        if i < len(rows) - 1:
            m = _translate(thickness) @ m
    return m


@pytest.mark.parametrize("rows", [DEFAULT_SURFACES, DOUBLET, FRONT_ELEMENT])
@pytest.mark.parametrize("nm", [475.0, D_NM, 650.0])
def test_focal_lengths_and_pupil_match_the_abcd_matrices(rows, nm):
    lens = LensSystem(rows)
    (a, b), (c, d) = abcd(rows, nm)
    assert lens.effective_focal_length_mm(nm) == pytest.approx(-1.0 / c, rel=1e-10)
    assert lens.back_focal_distance_mm(nm) == pytest.approx(-a / c, rel=1e-10)
    stop = next(i for i, r in enumerate(rows) if r[0] == 0.0)
    (fa, fb), _ = abcd(rows, nm, upto=stop)   # z = 0 -> the stop's plane
    # the entrance pupil: the axial point whose rays cross the stop's centre, and the stop's image
    z_ep, r_ep = lens.entrance_pupil(nm)
    assert z_ep == pytest.approx(fb / fa, rel=1e-10, abs=1e-12)
    assert r_ep == pytest.approx(rows[stop][3] / abs(fa), rel=1e-10)


def _camera(rows, focus_m=2.0):
    return ThickLensCamera.focused(LensSystem(rows), focus_m, (650.0, 510.0, 475.0), D_NM, 1024, 36.0,
                                   "paraxial")


@pytest.mark.parametrize("rows", [DEFAULT_SURFACES, FRONT_ELEMENT])
def test_sensor_and_image_scale_match_the_abcd_matrices(rows):
    cam = _camera(rows)
    lens = cam.lens
    z_last = lens.vertices_mm[-1]
    # the sensor: where the ABCD image of the axial point 2 m in front of the pupil lies
    (a, b), (c, d) = abcd(rows, D_NM)
    y0, u0 = 2000.0 - cam.pupil_z_mm, 1.0          # at z = 0 from the point, slope 1 (heights/unit)
    y, u = a * y0 + b * u0, c * y0 + d * u0
    assert cam.sensor_z_mm == pytest.approx(z_last - y / u, rel=1e-9)
    # the pinhole scale: the chief ray (slope 1 through the pupil centre) on the sensor
    out = _translate(cam.sensor_z_mm - z_last) @ np.array([[a, b], [c, d]]) @ np.array([-cam.pupil_z_mm, 1.0])
    assert cam.chief_scale_mm == pytest.approx(out[0], rel=1e-9)
    assert cam.px_per_mm == 1024 / 36.0


def test_a_defocused_spot_has_the_abcd_size_in_pixels():
    """f/25 (a 1 mm stop before the singlet: spherical aberration, which grows as the aperture
    cubed, is below 0.2 %), focused at 2 m; a point at 0.15 m spreads into a uniform disc whose
    radius the paraxial marginal ray gives. Its second moment (R^2 / 2, plus 1/6 px^2 from
    binning) fixes R to 0.5 %, so a 3 % error of the sensor or pixel scale fails."""
    rows = ((0.0, 10.0, "air", 1.0), (50.0, 8.0, "N-BK7", 12.0), (-50.0, 0.0, "air", 12.0))
    model = PhysicalLens(PhysicalLensConfig(surfaces=rows, focus="paraxial", psf_resolution=61,
                                            wavelengths_nm=(D_NM, D_NM, D_NM), near_m=0.15, far_m=20.0))
    cam = model.camera
    depth = 150.0                                   # mm in front of the entrance pupil
    theta = cam.pupil_radius_mm / depth             # the marginal ray through the pupil's rim
    y0 = theta * (depth - cam.pupil_z_mm)           # its height at z = 0
    (a, b), (c, d) = abcd(rows, D_NM)
    y, u = a * y0 + b * theta, c * y0 + d * theta
    radius_px = abs(y + (cam.sensor_z_mm - cam.lens.vertices_mm[-1]) * u) * 1024 / 36.0
    assert 6.0 < radius_px < 25.0
    psf = model.trace_box((depth / 1000.0, 0.0), (depth / 1000.0, 0.0), n_rays=2 ** 21, seed=3).psf[..., 1]
    yy, xx = np.mgrid[:61, :61] - 30
    second = float((psf * (xx ** 2 + yy ** 2)).sum() / psf.sum())
    assert math.sqrt(2.0 * (second - 1.0 / 6.0)) == pytest.approx(radius_px, rel=0.005)


def _exact_spot(cam, depth_mm, tan_f, n=2_000_000, seed=0):
    """Sensor points (px, image axes about the ABCD pinhole image) of rays from one object point,
    emitted uniformly in solid angle and traced exactly (numpy, float64) through the lens."""
    lens = cam.lens
    p = np.array([tan_f * depth_mm, 0.0, cam.pupil_z_mm - depth_mm])
    stop = next(i for i, s in enumerate(lens.surfaces) if s.is_stop)
    to_stop = np.array([0.0, 0.0, lens.vertices_mm[stop]]) - p
    dist = float(np.linalg.norm(to_stop))
    w = to_stop / dist                                  # a cone about the stop's centre that holds it
    beta = math.asin(min(1.0, 1.5 * lens.surfaces[stop].aperture_radius_mm / dist))
    e1 = np.cross(w, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(w, e1)
    rng = np.random.default_rng(seed)
    cz = 1.0 - rng.random(n) * (1.0 - math.cos(beta))
    phi = 2.0 * math.pi * rng.random(n)
    sz = np.sqrt(1.0 - cz * cz)
    d = np.outer(sz * np.cos(phi), e1) + np.outer(sz * np.sin(phi), e2) + np.outer(cz, w)
    o = tuple(np.full(n, v) for v in p)
    with np.errstate(divide="ignore", invalid="ignore"):    # rays blocked before the sensor
        (x, y, _), _, ok = lens.trace(o, tuple(d.T), lens.relative_indices(D_NM), sensor_z_mm=cam.sensor_z_mm)
    k = 1024 / 36.0
    rows = [(s.radius_mm, s.thickness_mm, s.glass, s.aperture_radius_mm) for s in lens.surfaces]
    (a, b), (c, d) = abcd(rows, D_NM)
    chief = (_translate(cam.sensor_z_mm - lens.vertices_mm[-1]) @ np.array([[a, b], [c, d]])
             @ np.array([-cam.pupil_z_mm, 1.0]))[0]                      # sensor mm per unit tangent
    centre = -chief * tan_f
    return np.stack([-k * (x[ok] - centre), k * y[ok]], 1)


@pytest.mark.parametrize("ecc_px", [0.0, 300.0, 600.0])
def test_the_f28_psf_matches_an_exact_trace_on_and_off_axis(ecc_px):
    """The default f/2.8 singlet (spherical aberration, distortion, cat-eye vignetting) at 0.5 m:
    the traced PSF's centroid and spread agree with an exact numpy trace of the same point,
    mapped to pixels here (the ABCD pinhole image, 1024 px on 36 mm)."""
    model = PhysicalLens(PhysicalLensConfig(psf_resolution=181, wavelengths_nm=(D_NM, D_NM, D_NM)))
    cam = model.camera
    spot = _exact_spot(cam, 500.0, ecc_px / (cam.px_per_mm * cam.chief_scale_mm))
    t = model.trace_box((0.5, ecc_px), (0.5, ecc_px), n_rays=2 ** 21, seed=3)
    assert t.n_outside == 0
    psf = t.psf[..., 1]
    yy, xx = np.mgrid[:181, :181] - 90
    mx, my = float((psf * xx).sum()), float((psf * yy).sum())
    ex, ey = spot.mean(axis=0)
    assert mx == pytest.approx(ex, abs=0.08) and my == pytest.approx(ey, abs=0.08)   # ~4 sigma
    spread = float((psf * ((xx - mx) ** 2 + (yy - my) ** 2)).sum()) - 1.0 / 6.0
    exact = float(((spot - spot.mean(axis=0)) ** 2).sum(axis=1).mean())
    assert math.sqrt(spread) == pytest.approx(math.sqrt(exact), rel=0.005)
