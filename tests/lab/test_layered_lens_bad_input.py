"""Issue 13's last bad input: a lens prescription the runtime twin cannot represent. ``splatlab
render --method layered`` exits 2 with one line naming the value and the fix, and writes nothing;
the runtime API refuses the same lenses with the same InputError."""
import json
import math

import numpy as np
import pytest

import runtime_cl
from lab.cameras.thick import ThickCamera
from lab.exr_io import LabelledImage, write_labelled
from runtime_cl.camera import from_header
from runtime_cl.errors import InputError
from test_cli_bad_input import exr_with, fails_cleanly

H, W = 12, 16
SINGLET = [[math.inf, 15.0, "air", 11.5], [0, 10.0, "air", 8.9], [50, 8, "N-BK7", 12], [-50, 0, "air", 12]]
# The singlet behind a 2 mm front opening 40 mm ahead: the axis sees through, the image corners do not.
BLIND = [[math.inf, 40.0, "air", 2.0], [0, 10.0, "air", 8.9], [50, 8, "N-BK7", 12], [-50, 0, "air", 12]]
PINHOLE = {"lens": "pinhole", "fov_x_deg": 40.0}


def thick_header(rows) -> dict:
    cam = ThickCamera(model="thick", position=(0.0, 0.0, 0.0), look_at=(0.0, 0.0, 1.0), surfaces=rows,
                      focus_distance_m=2.0, sensor_width_mm=24.0)
    return cam.camera_json()


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    return tmp_path


def exr(work, camera, name="in.exr"):
    rng = np.random.default_rng(3)
    write_labelled(work / name, LabelledImage(rng.random((H, W, 3), dtype=np.float32), np.ones((H, W), np.float32),
                                              rng.uniform(1, 5, (H, W)).astype(np.float32), camera))
    return work / name


def layered(work, path):
    return ["render", path, "--method", "layered", "--rays", "4", "--out", work / "o.exr"]


def test_a_lens_blind_at_the_image_corners(work, capfd):
    """The twin aims backward rays through exit-pupil boxes; a sensor radius no ray leaves from has none."""
    path = exr(work, thick_header(BLIND))
    fails_cleanly(layered(work, path), capfd, work, "no ray from the sensor", "mm off axis gets through",
                  "widen the apertures or shrink the sensor")


def test_a_header_with_other_than_three_channels(work, capfd):
    """One wavelength cannot give RGB: the lab refuses the header (its indices disagree with the
    surfaces at the camera's three wavelengths), naming the value and how to write it."""
    header = thick_header(SINGLET)
    exr(work, header)
    header = dict(header, wavelengths_nm=header["wavelengths_nm"][1:2], indices=header["indices"][1:2])
    path = exr_with(work, {"splatlab.camera": json.dumps(header)})   # written as a hand-edited file would be
    fails_cleanly(layered(work, path), capfd, work, "wavelengths_nm = [", "but the header's surfaces give",
                  "write the header from the scene's [camera]")


def test_a_pinhole_has_no_lens_to_trace(work, capfd):
    path = exr(work, PINHOLE)
    fails_cleanly(layered(work, path), capfd, work, "camera lens 'pinhole'", "['thick', 'thin']",
                  "render a pinhole input with the spreadlet passes instead")


def test_the_runtime_refuses_what_it_cannot_trace():
    """Through the runtime API (no lab checks in between): a one-channel thick lens."""
    rng = np.random.default_rng(4)
    rgb, z = rng.random((H, W, 3), dtype=np.float32), rng.uniform(1, 5, (H, W)).astype(np.float32)
    header = thick_header(SINGLET)
    one = from_header(dict(header, wavelengths_nm=header["wavelengths_nm"][:1], indices=header["indices"][:1]))
    with pytest.raises(InputError, match=r"camera indices: 1 channel\(s\); .* needs indices at three wavelengths"):
        runtime_cl.render(rgb, z, one, method="layered", rays=4)


def test_cone_with_a_method_that_traces_no_lens_rays(work, capfd):
    path = exr(work, thick_header(SINGLET))
    fails_cleanly(["render", path, "--method", "polygon", "--cone", "--out", work / "o.exr"], capfd, work,
                  "--cone: --method polygon traces no lens rays", "drop --cone or use --method layered")
