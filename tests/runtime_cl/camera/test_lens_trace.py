"""The runtime's thick-lens ray tracing (numpy and OpenCL) against the lab's (numpy float64 and
Dr.Jit float32): the same 10^4 rays, through the built-in lenses, agree to 1e-5 mm."""
import numpy as np
import pytest

from lab.cameras import camera_names  # noqa: F401  (registers the cameras)
from lab.cameras.thick import WAVELENGTHS_NM, _focused
from lab.optics.lenses import LENSES
from lab.optics.thick_lens import DRJIT
from runtime_cl.camera.lens_trace import LensTraceKernel, TracedLens
from runtime_cl.camera.thick_lens import ThickLens
from runtime_cl.errors import InputError


def runtime_lens(name, focus_m=2.0):
    cam = _focused(LENSES[name], focus_m, 36.0, 1024)
    header = ThickLens(surfaces=LENSES[name], focus_distance_m=focus_m, focus="best", sensor_width_mm=36.0,
                       focal_length_mm=cam.lens.effective_focal_length_mm(587.56), chief_scale_mm=cam.chief_scale_mm,
                       pupil_radius_mm=cam.pupil_radius_mm, sensor_z_mm=cam.sensor_z_mm, pupil_z_mm=cam.pupil_z_mm, wavelengths_nm=WAVELENGTHS_NM,
                       indices=tuple(cam.lens.indices(w) for w in WAVELENGTHS_NM))
    return cam, TracedLens.from_camera(header)


def object_rays(rng, n=10_000):
    """Rays from object points 0.5-5 m away, up to 15 degrees off axis, aimed at random points of
    a 10 mm disc at the first surface (stops and rims block some), one channel each."""
    depth = rng.uniform(500.0, 5000.0, n)
    off = np.tan(np.radians(rng.uniform(0, 15, n))) * depth
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.stack([off * np.cos(phi), off * np.sin(phi), -depth], axis=1)
    r, a = 10.0 * np.sqrt(rng.random(n)), rng.uniform(0, 2 * np.pi, n)
    aim = np.stack([r * np.cos(a), r * np.sin(a), np.zeros(n)], axis=1)
    d = aim - start
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = aim - 1.0 * d          # 1 mm in front of the first vertex plane
    return o, d, rng.integers(0, 3, n)


@pytest.mark.parametrize("name", sorted(LENSES))
def test_runtime_traces_agree_with_the_lab_to_1e5_mm(name):
    import drjit as dr
    from drjit.llvm import Float

    rng = np.random.default_rng(3)
    cam, lens = runtime_lens(name)
    o, d, ch = object_rays(rng)
    eta = [np.array([cam.lens.relative_indices(w)[i] for w in WAVELENGTHS_NM])[ch] for i in range(len(cam.lens))]
    (lx, ly, lz), _, lok = cam.lens.trace(tuple(o.T), tuple(d.T), eta, sensor_z_mm=cam.sensor_z_mm)
    lab64 = np.stack([lx, ly, lz], axis=1)
    fo = tuple(Float(v.astype(np.float32)) for v in o.T)
    fd = tuple(Float(v.astype(np.float32)) for v in d.T)
    (jx, jy, jz), _, jok = cam.lens.trace(fo, fd, [Float(e.astype(np.float32)) for e in eta], DRJIT,
                                          sensor_z_mm=cam.sensor_z_mm)
    lab32 = np.stack([np.array(jx), np.array(jy), np.array(jz)], axis=1)
    ours64, _, ok64 = lens.trace(o, d, ch)
    ours32, _, ok32 = LensTraceKernel(lens).trace(o, d, ch)
    assert 0.3 < lok.mean() < 0.98                      # some rays blocked, most through
    assert np.array_equal(ok64, lok)
    both = lok & np.array(jok) & ok32
    assert both.sum() > 0.99 * lok.sum()                 # float32 may flip rays grazing an aperture edge
    np.testing.assert_allclose(ours64[lok], lab64[lok], rtol=0, atol=1e-9)
    for name32, got in (("OpenCL", ours32), ("Dr.Jit", lab32)):
        err = np.abs(got[both] - lab64[both]).max()
        assert err <= 1e-5, (name32, err)


def test_the_reversed_lens_sends_sensor_rays_back_along_the_object_rays():
    """A ray traced to the sensor and back through the reversed lens (directions flipped, z'
    = L - z) leaves the first surface where it came in, in the opposite direction."""
    rng = np.random.default_rng(4)
    _, lens = runtime_lens("achromat")
    o, d, ch = object_rays(rng, 2000)
    s, ds, ok = lens.trace(o, d, ch)
    back = lens.reversed()
    last = lens.vertex_mm[-1]
    flip = np.array([1.0, 1.0, -1.0])
    bo, bd, bok = back.trace(s * flip + np.array([0, 0, last]), -ds * flip, ch, to_sensor=False)
    assert np.all(bok[ok])
    # in the original frame: the ray leaves through the first surface heading back to the object
    bo_orig = (bo - np.array([0, 0, last])) * flip
    first_hit = o + d * ((0.0 - o[:, 2]) / d[:, 2])[:, None]   # where it crossed z = 0 (flat first face)
    np.testing.assert_allclose(bo_orig[ok][:, :2], first_hit[ok][:, :2], atol=1e-6)
    np.testing.assert_allclose(-(bd * flip)[ok], d[ok], atol=1e-9)


def test_headers_without_indices_or_with_bad_ones_are_refused():
    cam, _ = runtime_lens("singlet")
    data = ThickLens(surfaces=LENSES["singlet"], focus_distance_m=2.0, focus="best", sensor_width_mm=36.0,
                     focal_length_mm=49.7, chief_scale_mm=cam.chief_scale_mm, pupil_radius_mm=cam.pupil_radius_mm,
                     sensor_z_mm=cam.sensor_z_mm, pupil_z_mm=cam.pupil_z_mm, wavelengths_nm=WAVELENGTHS_NM,
                     indices=tuple(cam.lens.indices(w) for w in WAVELENGTHS_NM)).to_json()
    assert max(ThickLens.from_json(data).indices[0]) > 1.5           # N-BK7 at 650 nm
    for key, value, match in (("indices", [[1.5] * 2] * 3, "indices"), ("wavelengths_nm", [], "wavelengths_nm"),
                              ("sensor_z_mm", -1.0, "sensor_z_mm"), ("pupil_z_mm", float("nan"), "pupil_z_mm")):
        with pytest.raises(InputError, match=match):
            ThickLens.from_json({**data, key: value})
    with pytest.raises(InputError, match=r"missing key\(s\) \['indices'\]"):
        ThickLens.from_json({k: v for k, v in data.items() if k != "indices"})
