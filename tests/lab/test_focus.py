"""Focus control from pixels (lab.focus): a focus point focuses the thin and the thick lens on the
depth the labelled input sees there; focus points tilt the sensor onto their least-squares plane;
bad focus pixels exit 2 with one line (scene files and ``splatlab render --focus-point``)."""

import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, write_labelled
from lab.focus import fit_plane, resolve_focus
from lab.paths import SCENES
from lab.reference.labelled import planar_depth
from lab.errors import UserError

TILT = (SCENES / "tiny_tiltshift.toml").read_text()
FOREGROUND = (SCENES / "tiny_foreground.toml").read_text()


def with_camera(text, old, new):
    assert old in text
    return text.replace(old, new)


def scene_file(tmp_path, text, name="s.toml"):
    (tmp_path / name).write_text(text)
    return tmp_path / name


def test_a_focus_point_focuses_on_what_its_pixel_sees(tmp_path):
    """The subject (a sphere on the image's left, at 4 m): the resolved focus is the Z the input
    rendered with that focus sees at the pixel (the fixed point of focus breathing)."""
    from lab.scene import load_scene

    path = scene_file(tmp_path, with_camera(FOREGROUND, "focus_distance_m = 4.0", "focus_point = [33, 59]"))
    scene = resolve_focus(load_scene(path))
    z = planar_depth(scene)
    assert scene.camera.focus_distance_m == pytest.approx(float(z[59, 33]), rel=1e-6)
    assert 3.7 < scene.camera.focus_distance_m < 4.0                    # the sphere's front
    assert scene.camera.runtime_camera().to_json()["focus_points"] == [[33, 59]]


def test_a_focus_point_moves_the_thick_lens_sensor(tmp_path):
    from lab.scene import load_scene

    text = with_camera(FOREGROUND, '''model = "thin"''', '''model = "thick"\nlens = "singlet"''')
    for key in ("focal_length_mm = 50.0\n", "f_number = 0.5\n"):
        text = text.replace(key, "")
    near = scene_file(tmp_path, text.replace("focus_distance_m = 4.0", "focus_point = [43, 36]"), "near.toml")
    far = scene_file(tmp_path, text.replace("focus_distance_m = 4.0", "focus_point = [33, 59]"), "far.toml")
    cams = [resolve_focus(load_scene(p)) for p in (near, far)]
    for scene, (x, y) in zip(cams, [(43, 36), (33, 59)]):
        assert scene.camera.focus_distance_m == pytest.approx(float(planar_depth(scene)[y, x]), rel=1e-6)
    (a, b) = (c.camera.runtime_camera() for c in cams)
    assert a.focus_distance_m < 1.0 < 3.0 < b.focus_distance_m          # the post, the subject
    assert a.sensor_z_mm > b.sensor_z_mm                                # nearer focus: sensor farther back


def test_focus_points_tilt_the_sensor_onto_their_plane():
    from lab.scene import load_scene

    scene = resolve_focus(load_scene(SCENES / "tiny_tiltshift.toml"))
    lens = scene.camera.runtime_camera()
    assert lens.tilted and abs(lens.sensor_tilt_deg[0]) > 5.0
    z = planar_depth(scene)
    h, w = z.shape
    f_px = lens.focal_px(w)
    pts = np.array([[(x + 0.5 - w / 2) / f_px * z[y, x], (h / 2 - y - 0.5) / f_px * z[y, x], z[y, x]]
                    for x, y in scene.camera.focus_points])
    centre = pts.mean(axis=0)
    n = np.linalg.svd(pts - centre)[2][2]                                # their total-least-squares plane
    ys, xs = np.mgrid[0:h, 0:w]
    plane = (n[0] * (xs + 0.5 - w / 2) / f_px + n[1] * (h / 2 - ys - 0.5) / f_px + n[2]) / (n @ centre)
    # 1e-5: the plane here is fitted to the input's float32 Z (7 digits); lab.focus traces float64
    np.testing.assert_allclose(lens.inverse_focus_map(h, w), plane, rtol=1e-5)
    seen = [z[y, x] * plane[y, x] for x, y in scene.camera.focus_points]
    # 0.05: four points on two house walls are not coplanar; the fit passes near each (3.6 % here)
    np.testing.assert_allclose(seen, 1.0, atol=0.05)


def test_fit_plane_is_total_least_squares():
    rng = np.random.default_rng(2)
    n = np.array([0.2, -0.6, 0.77])
    n /= np.linalg.norm(n)
    pts = rng.normal(size=(40, 3))
    pts -= np.outer(pts @ n - 1.3, n)                                    # onto n . X = 1.3
    normal, offset = fit_plane(pts, "k")
    assert abs(abs(normal @ n) - 1.0) < 1e-12 and abs(offset * np.sign(normal @ n) - 1.3) < 1e-12
    with pytest.raises(UserError, match="collinear"):
        fit_plane(np.outer(np.arange(4.0), [1.0, 2.0, 3.0]) + 0.5, "k")


SKY = with_camera(TILT, "look_at = [0.0, 0.0, 0.35]", "look_at = [0.0, 0.2, 1.0]")


@pytest.mark.parametrize("text, needles", [
    (with_camera(SKY, "focus_points = [[60, 22], [60, 33], [39, 50], [39, 62]]", "focus_point = [48, 3]"),
     ["[camera] focus_point [48, 3] sees no surface", "pick a pixel on a surface, e.g. the nearest one, [48, "]),
    (with_camera(TILT, "focus_points = [[60, 22], [60, 33], [39, 50], [39, 62]]", "focus_point = [96, 10]"),
     ["focus_point [96, 10] is outside the 96 x 72 image", "0 <= x < 96"]),
    (with_camera(TILT, "focus_points = [[60, 22], [60, 33], [39, 50], [39, 62]]",
                 "focus_points = [[47, 24], [47, 45], [47, 66]]"),
     ["focus_points [[47, 24], [47, 45], [47, 66]]", "contains the view direction", "faces the camera"]),
    (with_camera(TILT, "focus_points = [[60, 22], [60, 33], [39, 50], [39, 62]]",
                 "focus_points = [[3, 40], [3, 50], [3, 60]]"),
     ["focus_points: the points they see are collinear", "add a focus point off their line"]),
    (with_camera(TILT, "focus_points = [[60, 22], [60, 33], [39, 50], [39, 62]]", "focus_points = [[3, 40], [3, 50]]"),
     ["a focal plane needs >= 3 points"]),
    (with_camera(FOREGROUND, "focus_distance_m = 4.0", "focus_distance_m = 4.0\nfocus_point = [1, 2]"),
     ["give one way to focus"]),
])
def test_bad_focus_in_a_scene_exits_2(tmp_path, capfd, text, needles):
    code = main(["plan", str(scene_file(tmp_path, text))])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    for needle in needles:
        assert needle in err[0], (needle, err[0])


@pytest.fixture
def exr(tmp_path):
    rng = np.random.default_rng(1)
    z = rng.uniform(1, 9, (12, 16)).astype(np.float32)
    z[2, 3] = np.inf
    alpha = np.ones((12, 16), np.float32)
    alpha[2, 3] = 0.0
    camera = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 0.5, "focus_distance_m": 3.0,
              "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}
    write_labelled(tmp_path / "in.exr", LabelledImage(rng.random((12, 16, 3), dtype=np.float32), alpha, z, camera))
    return tmp_path, z


def test_render_focus_point_refocuses_the_header(exr):
    """--focus-point 5,7 renders as the same EXR whose header focuses at Z[7, 5] does (and not as the
    header's own focus; a tilted header loses its tilt)."""
    from lab.exr_io import read_labelled, read_rgb

    tmp, z = exr
    image = read_labelled(tmp / "in.exr")
    write_labelled(tmp / "at.exr", LabelledImage(image.rgb, image.alpha, image.depth,
                                                 dict(image.camera, focus_distance_m=float(z[7, 5]))))
    write_labelled(tmp / "tilted.exr", LabelledImage(image.rgb, image.alpha, image.depth,
                                                     dict(image.camera, sensor_tilt_deg=[5.0, -3.0])))
    for args, out in ((["in.exr", "--focus-point", "5,7"], "point.exr"), (["at.exr"], "at_out.exr"),
                      (["in.exr"], "own.exr"), (["tilted.exr", "--focus-point", "5,7"], "untilted.exr")):
        assert main(["render", str(tmp / args[0]), *args[1:], "--method", "polygon", "--out", str(tmp / out)]) == 0
    point, at, own, untilted = (read_rgb(tmp / n) for n in ("point.exr", "at_out.exr", "own.exr", "untilted.exr"))
    np.testing.assert_array_equal(point, at)
    np.testing.assert_array_equal(untilted, at)             # the point overrides the header's tilt too
    assert np.abs(point - own).max() > 0.05


@pytest.mark.parametrize("value, needles", [
    ("3,2", ["--focus-point [3, 2] sees no surface", "pick a pixel on a surface"]),
    ("16,2", ["--focus-point [16, 2] is outside the 16 x 12 image"]),
    ("3;2", ["--focus-point '3;2'", "X,Y"]),
])
def test_render_bad_focus_point_exits_2(exr, capfd, value, needles):
    tmp, _ = exr
    code = main(["render", str(tmp / "in.exr"), "--method", "polygon", f"--focus-point={value}",
                 "--out", str(tmp / "o.exr")])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    for needle in needles:
        assert needle in err[0], (needle, err[0])
    assert not (tmp / "o.exr").exists()


def test_tilted_and_expressive_cameras_round_trip_through_the_header():
    from lab.cameras.base import parse_camera
    from lab.exr_io import validate_camera
    from runtime_cl.camera import from_header
    import json

    place = {"position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50.0, "f_number": 1.0,
             "focus_distance_m": 2.0}
    for extra in ({"sensor_tilt_deg": [4.0, -2.5]}, {"focal_surface": {"points": [[1, 2, 1.5], [5, 6, 3.0]]}}):
        cam = parse_camera({"model": "thin", **place, **extra}, "c.toml [camera]")
        header = json.loads(json.dumps(cam.camera_json()))
        assert validate_camera(header, "h") == header
        assert from_header(header, "h") == cam.runtime_camera() and cam.runtime_camera().has_focal_map


def test_render_with_an_expressive_camera_file(tmp_path):
    """``--camera`` with a focal_surface: two bright points at 3 m, one on a pixel the surface holds at
    3 m (it stays in its pixel), one where it holds 1 m (it spreads: dof_extent 0.2, five times the blur of the f/0.5 lens)."""
    rgb = np.zeros((12, 16, 3), np.float32)
    rgb[7, 5] = rgb[3, 12] = 50.0
    camera = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 0.5, "focus_distance_m": 3.0,
              "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}
    write_labelled(tmp_path / "in.exr", LabelledImage(rgb, np.ones((12, 16), np.float32),
                                                      np.full((12, 16), 3.0, np.float32), camera))
    (tmp_path / "cam.toml").write_text(
        "[camera]\nmodel = \"thin\"\nposition = [0, 0, 0]\nlook_at = [0, 0, 1]\nfocal_length_mm = 50.0\n"
        "f_number = 0.5\nfocus_distance_m = 3.0\nfocal_surface = { points = [[5, 7, 3.0], [12, 3, 1.0]], beta = 2, dof_extent = 0.2 }\n")
    for method in ("polygon", "layered"):
        assert main(["render", str(tmp_path / "in.exr"), "--method", method, "--camera", str(tmp_path / "cam.toml"),
                     "--out", str(tmp_path / f"{method}.exr")]) == 0
        from lab.exr_io import read_rgb

        out = read_rgb(tmp_path / f"{method}.exr")[..., 0]
        assert out[7, 5] == pytest.approx(50.0, rel=1e-4) and out[6:9, 4:7].sum() == pytest.approx(50.0, rel=1e-4)
        assert out[3, 12] < 10.0 and (out[:7, 9:] > 0.3).sum() >= 12              # a disc of radius 3.8 px


def test_render_refuses_a_header_tilt_along_the_view_direction(tmp_path, capfd):
    import json

    import OpenEXR

    camera = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 0.5, "focus_distance_m": 3.0,
              "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}
    write_labelled(tmp_path / "ok.exr", LabelledImage(np.zeros((8, 8, 3), np.float32), np.ones((8, 8), np.float32),
                                                      np.full((8, 8), 2.0, np.float32), camera))
    with OpenEXR.File(str(tmp_path / "ok.exr"), separate_channels=True) as exr:   # a header edited by hand
        header = dict(exr.header(), **{"splatlab.camera": json.dumps(dict(camera, sensor_tilt_deg=[0.0, 75.0]))})
        channels = {k: c.pixels for k, c in exr.channels().items()}
    with OpenEXR.File(header, channels) as f:
        f.write(str(tmp_path / "in.exr"))
    code = main(["render", str(tmp_path / "in.exr"), "--method", "polygon", "--out", str(tmp_path / "o.exr")])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    assert "sensor_tilt_deg = [0.0, 75.0]" in err[0] and "along the view direction" in err[0], err[0]
    assert not (tmp_path / "o.exr").exists()


def test_refocus_header_moves_the_thick_lens_sensor():
    """--focus-point on a thick-lens EXR: the lab re-derives the sensor plane for the new distance,
    and the header still passes the lab's check of its paraxial figures."""
    from lab.cameras.base import parse_camera
    from lab.exr_io import validate_camera
    from lab.focus import refocus_header

    cam = parse_camera({"model": "thick", "lens": "singlet", "focus_distance_m": 2.0, "position": [0, 0, 0],
                        "look_at": [0, 0, 1]}, "c.toml [camera]")
    header = cam.camera_json()
    depth = np.full((6, 8), 5.0)
    depth[2, 3] = 0.7
    near = refocus_header(header, depth, 3, 2, "in.exr camera")
    assert near["focus_distance_m"] == 0.7 and near["focus_points"] == [[3, 2]]
    assert near["sensor_z_mm"] > header["sensor_z_mm"]                  # nearer focus: the sensor moves back
    assert validate_camera(near, "h") == near
    with pytest.raises(UserError, match=r"--focus-point \[8, 2\] is outside the 8 x 6 image"):
        refocus_header(header, depth, 8, 2, "in.exr camera")
