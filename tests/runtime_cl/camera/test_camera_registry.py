"""The runtime camera registry: headers dispatch on "lens"; the pinhole twin; no lab imports."""
import json
import subprocess
import sys

import numpy as np
import pytest

from runtime_cl.camera import from_header, lens_names
from runtime_cl.camera.pinhole import Pinhole
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0,
        "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}


def test_headers_build_their_registered_camera():
    assert lens_names() == ["pinhole", "thick", "thin"]
    assert from_header(THIN, "a.exr") == ThinLens.from_json(THIN, "a.exr") == ThinLens(50.0, 2.0, 3.0, 36.0)
    iris = from_header({**THIN, "aperture": {"blades": 6}})
    assert iris == ThinLens(50.0, 2.0, 3.0, 36.0)                 # the iris does not change the CoC
    assert from_header({"lens": "pinhole", "fov_x_deg": 40.0, "shutter": [0, 1]}) == Pinhole(40.0)
    for camera in (ThinLens(35.0, 1.4, 0.6, 24.0), Pinhole(70.0)):
        assert from_header(json.loads(json.dumps(camera.to_json()))) == camera


@pytest.mark.parametrize("data,needles", [
    ({"lens": "fisheye"}, ["a.exr header", "lens = 'fisheye' is not known", "['pinhole', 'thick', 'thin']"]),
    ({"focal_length_mm": 50}, ["a.exr header", "lens = None is not known", "['pinhole', 'thick', 'thin']"]),
    ({"lens": ["thin"]}, ["a.exr header", "lens = ['thin'] is not known"]),
    ([1, 2], ["a.exr header", "must be a JSON object", "[1, 2]"]),
    ({"lens": "pinhole", "fov_x_deg": 180}, ["a.exr header", "fov_x_deg = 180", "(0, 180)"]),
    ({"lens": "pinhole", "fov_x_deg": 40, "f_number": 2}, ["a.exr header", "['f_number']", "pinhole"]),
    ({**THIN, "fstop": 2}, ["a.exr header", "['fstop']", "known keys"]),
])
def test_bad_headers_name_the_source_the_value_and_the_choices(data, needles):
    with pytest.raises(InputError) as exc:
        from_header(data, "a.exr header")
    for needle in needles:
        assert needle in str(exc.value), str(exc.value)


def test_a_camera_refuses_another_lens():
    with pytest.raises(InputError, match="lens = 'pinhole', this runtime path needs 'thin'"):
        ThinLens.from_json({"lens": "pinhole", "fov_x_deg": 40.0})
    with pytest.raises(InputError, match="lens = 'thin', this runtime path needs 'pinhole'"):
        Pinhole.from_json(THIN)


def test_pinhole_has_no_defocus():
    cam = Pinhole(fov_deg=40.0)
    z = np.array([[0.5, 3.0], [20.0, np.inf]])
    assert cam.fov_x_deg() == 40.0
    np.testing.assert_array_equal(cam.coc_radius_px(z, 64), np.zeros((2, 2)))
    with pytest.raises(InputError, match="depths must be > 0"):
        cam.coc_radius_px(np.array([1.0, np.nan]), 64)
    with pytest.raises(InputError, match="fov_deg = 0"):
        Pinhole(fov_deg=0)


def test_the_camera_package_imports_no_lab_mitsuba_or_drjit():
    code = ("import sys, runtime_cl.camera; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'lab', 'mitsuba', 'drjit'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_every_camera_states_its_focal_length_in_pixels():
    """Pixels per unit tangent: what places a pixel's ray (volume coordinates use it)."""
    import math

    assert Pinhole(90.0).focal_px(64) == pytest.approx(32.0)
    thin = ThinLens(50.0, 2.0, 3.0, 36.0)
    assert thin.focal_px(1000) == pytest.approx(1000 / (2 * math.tan(math.radians(thin.fov_x_deg()) / 2)))
