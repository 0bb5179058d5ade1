"""The Mitsuba thick-lens sensor against the ``physical_lens`` PSF model, at three field positions.

Three small emitters at 0.5 m (the default f/2.8 singlet focused at 2 m: spots of 5-15 px RMS at
1024 px across, spherical aberration, cat-eye vignetting and ~2.5 px of lateral colour at the
edge) on the image's centre, straight above it and at its right edge: the reference renders each
(a film crop around it, one render per channel wavelength), the PSF model traces the same point
(rotated to its azimuth: traced along image +x). Per channel, the spot's centroid relative to
the point's pinhole image must agree within 0.25 px, and its RMS radius within 1 % (the emitter's
own disc, radius 2.5 px, adds RE^2 / 2 to the model's variance). Measured: centroids within
0.1 px, radii within 0.4 %.

A 3 % pixel-scale error (``ThickLensCamera.px_per_mm`` times 1.03, the PSF offsets 3 % larger)
fails: every radius is 3 % off, and the edge spot's centroid 1.1 px.
"""
import dataclasses
import math

import numpy as np
import pytest

from lab.cameras.thick import WAVELENGTHS_NM
from lab.psf_tracing.models.physical_lens import PhysicalLens, PhysicalLensConfig
from lab.reference.backend import mitsuba
from lab.reference.mitsuba_scene import scene_dict
from lab.scene import parse_scene

W, H, Z, CROP, RE = 1024, 683, 0.5, 73, 2.5
# eccentricity (px), azimuth (degrees, counter-clockwise from image +x, y up)
FIELD = {"centre": (0.0, 0.0), "above": (250.0, 90.0), "edge": (480.0, 0.0)}
CAMERA = {"model": "thick", "position": [0, 0, 0], "look_at": [0, 0, 1], "lens": "singlet", "focus_distance_m": 2.0}


def _scene():
    base = {"scene": {"name": "spots", "resolution": [W, H]}, "camera": CAMERA, "render": {"max_depth": 1}}
    cam = parse_scene({**base, "emitters": [{"type": "constant", "radiance": [0, 0, 0]}]}, "s.toml").camera
    k = cam.runtime_camera().focal_px(W)                # pinhole pixels per unit tangent
    shapes = []
    for ecc, azimuth in FIELD.values():                 # world +x is the image's left, +y up
        a = math.radians(azimuth)
        shapes.append({"type": "sphere", "center": [-ecc * math.cos(a) / k * Z, ecc * math.sin(a) / k * Z, Z],
                       "radius": RE / k * Z, "emitter": {"radiance": [1000.0] * 3}})
    return parse_scene({**base, "shapes": shapes}, "s.toml")


def _pinhole_px(name):
    ecc, azimuth = FIELD[name]
    a = math.radians(azimuth)
    return W / 2 + ecc * math.cos(a), H / 2 - ecc * math.sin(a)


def stats(img, origin):
    """(3, 3): per channel, centroid x, y (px, image axes, from ``origin``) and RMS radius."""
    yy, xx = np.mgrid[:img.shape[0], :img.shape[1]] + 0.5
    out = []
    for c in range(3):
        p = img[..., c] / img[..., c].sum()
        mx, my = (p * xx).sum() - origin[0], (p * yy).sum() - origin[1]
        out.append((mx, my, math.sqrt((p * ((xx - origin[0] - mx) ** 2 + (yy - origin[1] - my) ** 2)).sum())))
    return np.array(out)


@pytest.fixture(scope="module")
def spots():
    """name -> (reference crop (CROP, CROP, 3), the pinhole image's position in the crop)."""
    mi = mitsuba()
    scene = _scene()
    out = {}
    for name, (ecc, _) in FIELD.items():
        px, py = _pinhole_px(name)
        x0, y0 = int(px - 0.04 * ecc) - CROP // 2, int(py) - CROP // 2    # barrel distortion: ~4 % inward
        channels = []
        for c, nm in enumerate(WAVELENGTHS_NM):
            data = scene_dict(scene, "scene")
            data["sensor"]["wavelength_nm"] = nm
            data["sensor"]["film"].update(crop_offset_x=x0, crop_offset_y=y0, crop_width=CROP, crop_height=CROP)
            channels.append(np.asarray(mi.render(mi.load_dict(data), spp=2048, seed=1), np.float64)[..., c])
        out[name] = (np.stack(channels, -1), (px - x0, py - y0))
    return out


@pytest.fixture(scope="module")
def model():
    return PhysicalLens(PhysicalLensConfig(width_px=W, sensor_height_mm=36.0 * H / W, psf_resolution=CROP))


def model_stats(model, name):
    """The model's spot of the emitter ``name``: its PSF's centroid turned to the azimuth, its RMS
    radius with the emitter's disc."""
    ecc, azimuth = FIELD[name]
    psf = model.trace_box((Z, ecc), (Z, ecc), n_rays=2 ** 21, seed=3).psf.astype(np.float64)
    s = stats(psf, (CROP / 2, CROP / 2))
    a = math.radians(azimuth)                    # image axes: y down, so a turn by a is (c, s; -s, c)
    mx, my = s[:, 0] * math.cos(a) + s[:, 1] * math.sin(a), -s[:, 0] * math.sin(a) + s[:, 1] * math.cos(a)
    return np.stack([mx, my, np.sqrt(s[:, 2] ** 2 + RE ** 2 / 2)], axis=1)


def agree(ref, mod) -> bool:
    return bool(np.all(np.abs(ref[:, :2] - mod[:, :2]) <= 0.25) and np.all(np.abs(ref[:, 2] / mod[:, 2] - 1) <= 0.01))


@pytest.mark.parametrize("name", list(FIELD))
def test_the_reference_spot_is_the_physical_lens_psf(spots, model, name):
    img, origin = spots[name]
    assert img[0].max() < 1e-3 * img.max() and img[:, 0].max() < 1e-3 * img.max()    # the crop holds it
    ref, mod = stats(img, origin), model_stats(model, name)
    assert agree(ref, mod), (ref.round(3).tolist(), mod.round(3).tolist())
    if name == "edge":                       # lateral colour: blue lands farther in than red
        assert ref[2, 0] - ref[0, 0] < -2.0


def test_a_3_percent_pixel_scale_error_fails(spots, model):
    wrong = PhysicalLens(model.config)
    wrong.camera = dataclasses.replace(model.camera, px_per_mm=model.camera.px_per_mm * 1.03)
    for name in FIELD:
        img, origin = spots[name]
        assert not agree(stats(img, origin), model_stats(wrong, name)), name


def test_the_scene_and_pinhole_sensors():
    scene = _scene()
    sensor = scene_dict(scene, "scene")["sensor"]
    assert sensor["type"] == "splatlab_thick_lens" and "fov" not in sensor
    assert sensor["wavelength_nm"] == pytest.approx(587.5618)
    pinhole = scene_dict(scene, "pinhole")["sensor"]
    assert pinhole["type"] == "perspective" and pinhole["fov_axis"] == "x"
    cam = scene.camera.optics()       # the pinhole at the entrance pupil with the chief-ray scale
    assert pinhole["fov"] == pytest.approx(math.degrees(2 * math.atan(18.0 / cam.chief_scale_mm)))
