"""Scene files: parsing, validation messages, transforms, camera JSON, canonical dicts."""
import json
import math

import numpy as np
import pytest

from lab.errors import UserError
from lab.paths import SCENES
from lab.scene import load_camera, load_scene, parse_scene
from runtime_cl.camera.thin_lens import ThinLens


BASE = """
[scene]
name = "t"
resolution = [32, 24]

[camera]
model = "thin"
position = [0, 1, 0]
look_at = [0, 1, 3]
focal_length_mm = 50
f_number = 2.0
focus_distance_m = 2.5

[render]
reference_spp = 8
input_spp = 4

[materials.floor]
checkerboard = { color0 = [0.8, 0.8, 0.8], color1 = [0.1, 0.1, 0.1], scale = 4 }

[materials.red]
reflectance = [0.7, 0.1, 0.1]

[[shapes]]
type = "rectangle"
material = "floor"
scale = [5, 5, 1]
rotate = [-90, 0, 0]

[[shapes]]
type = "sphere"
center = [0, 1, 3]
radius = 0.05
emitter = { radiance = [20, 20, 20] }

[[emitters]]
type = "constant"
radiance = [0.5, 0.5, 0.5]

[psf.simple_lens]
rays_per_cell = 1000
"""


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def edit(old, new, text=BASE):
    assert old in text
    return text.replace(old, new)


def error(tmp_path, text):
    with pytest.raises(UserError) as exc:
        load_scene(write(tmp_path, text))
    return str(exc.value)


def test_base_scene_parses(tmp_path):
    s = load_scene(write(tmp_path, BASE))
    assert (s.width, s.height, s.name) == (32, 24, "t")
    assert s.materials["floor"].checkerboard.scale == 4.0
    assert s.shapes[1].emitter.radiance == (20.0, 20.0, 20.0) and s.shapes[1].material is None
    assert s.psf == {"simple_lens": {"rays_per_cell": 1000}}
    assert s.render.seed == 0 and s.render.max_depth == 8


def test_thin_lens_and_camera_json(tmp_path):
    cam = load_scene(write(tmp_path, BASE)).camera
    lens = cam.thin_lens()
    assert lens == ThinLens(50.0, 2.0, 2.5, 36.0)
    assert cam.fov_x_deg() == pytest.approx(lens.fov_x_deg())
    data = cam.camera_json()
    assert ThinLens.from_json(json.loads(json.dumps(data))) == lens
    assert data["shutter"] == [0.0, 1.0]
    np.testing.assert_allclose(cam.forward(), [0, 0, 1])


def test_aperture_radius_gives_the_same_lens(tmp_path):
    text = edit("f_number = 2.0", "aperture_radius_mm = 12.5")
    lens = load_scene(write(tmp_path, text)).camera.thin_lens()
    assert lens.f_number == pytest.approx(2.0)
    assert lens.aperture_radius_m == pytest.approx(0.0125)


def test_pinhole_fov_from_focal_length(tmp_path):
    text = edit("f_number = 2.0\nfocus_distance_m = 2.5", "").replace('"thin"', '"pinhole"')
    cam = load_scene(write(tmp_path, text)).camera
    assert cam.thin_lens() is None
    assert cam.fov_x_deg() == pytest.approx(math.degrees(2 * math.atan(18 / 50)))
    assert cam.camera_json() == {"lens": "pinhole", "fov_x_deg": cam.fov_x_deg(), "shutter": [0.0, 1.0]}


def test_round_trip_and_canonical_dict(tmp_path):
    s = load_scene(write(tmp_path, BASE))
    d = s.to_dict()
    assert json.loads(json.dumps(d)) == d  # JSON-friendly for content hashes
    assert parse_scene(d, "again") == s
    assert "source" not in json.dumps(d)
    other = load_scene(write(tmp_path, edit("scale = 4", "scale = 5"), "o.toml"))
    assert other.to_dict() != d


@pytest.mark.parametrize("old,new,needles", [
    ("focal_length_mm = 50", "focal_length_mm = 50\nfocal_lenght_mm = 3",
     ["[camera]", "focal_lenght_mm", "known keys"]),
    ("[render]", "[render]\nspp = 3", ["[render]", "'spp'"]),
    ("[[emitters]]", "[emiters]\nx = 1\n[[emitters]]", ["unknown table", "emiters"]),
    ("radius = 0.05", "radius = 0.05\ncolour = 1", ["[[shapes]] #2", "colour"]),
    ("scale = 4 }", "scale = 4, color2 = [1, 1, 1] }", ["[materials.floor].checkerboard", "color2"]),
    ("radiance = [20, 20, 20] }", "radiance = [20, 20, 20], power = 3 }", ["#2.emitter", "power"]),
])
def test_unknown_keys_name_file_table_and_key(tmp_path, old, new, needles):
    msg = error(tmp_path, edit(old, new))
    assert "s.toml" in msg
    for needle in needles:
        assert needle in msg


@pytest.mark.parametrize("old,new,needles", [
    ("f_number = 2.0", "f_number = 2.0\naperture_radius_mm = 10", ["exactly one", "f_number", "aperture_radius_mm"]),
    ("f_number = 2.0", "aperture_radius_mm = -3", ["aperture_radius_mm = -3", "> 0"]),
    ("focus_distance_m = 2.5", "focus_distance_m = 0.04", ["focus_distance_m = 0.04", "focal length", "> 0.05 m"]),
    ("resolution = [32, 24]", "resolution = [0, 24]", ["[scene]", "resolution", "> 0"]),
    ("material = \"floor\"", "material = \"flor\"", ["#1", "'flor'", "[materials.flor]", "floor"]),
    # found by the 10 000-case fuzzer: a name with a newline broke the one-line message
    ("material = \"floor\"", "material = \"fl\\nor\"", ["#1", "'fl\\nor'", '[materials."fl\\nor"]']),
    ('model = "thin"', 'model = "fisheye"', ["model = 'fisheye'", "pinhole", "thick"]),
    ("look_at = [0, 1, 3]", "look_at = [0, 1, 0]", ["look_at", "equals position"]),
    ("look_at = [0, 1, 3]", "look_at = [0, 5, 0]", ["up", "parallel"]),
    ("[render]", "[render]\nmax_depth = 0", ["max_depth = 0", ">= 1"]),
    ('type = "sphere"', 'type = "torus"', ["torus", "sphere"]),
    ("radius = 0.05", "radius = 0.05\nscale = [1, 2, 1]", ["uniform"]),
    ("scale = [5, 5, 1]", "scale = [5, 5, 1]\nto_world = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]",
     ["to_world", "scale", "keep one"]),
    ("radiance = [0.5, 0.5, 0.5]", "radiance = [0.5, -1, 0.5]", ["[[emitters]] #1", ">= 0"]),
    ('type = "constant"', 'type = "point"', ["point", "intensity", "position"]),
    ("reflectance = [0.7, 0.1, 0.1]", "reflectance = [0.7, 0.1, 0.1]\nalpha = 0.2", ["alpha", "diffuse"]),
])
def test_bad_values_say_what_to_fix(tmp_path, old, new, needles):
    msg = error(tmp_path, edit(old, new))
    assert "s.toml" in msg and "\n" not in msg
    for needle in needles:
        assert needle in msg, msg


def test_pinhole_rejects_lens_keys(tmp_path):
    msg = error(tmp_path, BASE.replace('"thin"', '"pinhole"'))
    assert "pinhole has none" in msg and "f_number" in msg


def test_file_errors(tmp_path):
    with pytest.raises(UserError, match=r"scene file .*missing.toml: no such file"):
        load_scene(tmp_path / "missing.toml")
    with pytest.raises(UserError, match="not valid TOML"):
        load_scene(write(tmp_path, "[scene\nname = 1"))
    with pytest.raises(UserError, match=r"missing the \[camera\] table"):
        load_scene(write(tmp_path, '[scene]\nname = "x"\nresolution = [4, 4]\n'))


def test_transforms():
    s = parse_scene({"scene": {"name": "x", "resolution": [4, 4]},
                     "camera": {"model": "pinhole", "position": [0, 0, 0], "look_at": [0, 0, 1], "fov_deg": 40},
                     "materials": {"m": {"reflectance": [1, 1, 1]}},
                     "shapes": [{"type": "rectangle", "material": "m", "center": [1, 2, 3],
                                 "scale": [2, 3, 1], "rotate": [-90, 0, 0]},
                                {"type": "disk", "material": "m", "radius": 2, "rotate": [0, 90, 0]},
                                {"type": "sphere", "material": "m", "center": [0, 1, 0], "radius": 0.5}]})
    floor, disk, ball = (sh.to_world_matrix() for sh in s.shapes)
    np.testing.assert_allclose(floor[:3, 2], [0, 1, 0], atol=1e-12)  # normal +z -> +y
    np.testing.assert_allclose(floor @ [1, 1, 0, 1], [3, 2, 0, 1], atol=1e-12)  # corner (x+2, z-3)
    np.testing.assert_allclose(disk[:3, 2], [2, 0, 0], atol=1e-12)  # +z -> +x, radius 2
    np.testing.assert_allclose(ball, [[0.5, 0, 0, 0], [0, 0.5, 0, 1], [0, 0, 0.5, 0], [0, 0, 0, 1]])


def test_load_camera_from_scene_or_camera_file(tmp_path):
    assert load_camera(write(tmp_path, BASE)).thin_lens().f_number == 2.0
    cam_only = BASE[BASE.index("[camera]"):BASE.index("[render]")]
    assert load_camera(write(tmp_path, cam_only, "c.toml")).focus_distance_m == 2.5
    with pytest.raises(UserError, match=r"no \[camera\] table"):
        load_camera(write(tmp_path, "[render]\nseed = 1\n", "r.toml"))


@pytest.mark.parametrize("name", sorted(p.name for p in SCENES.glob("*.toml")))
def test_shipped_scenes_load_and_plan(name):
    """Every shipped scene is valid, plans, and only tables its plan uses (no [psf.X] it skips)."""
    from lab.focus import resolve_focus
    from lab.plan import make_plan

    s = resolve_focus(load_scene(SCENES / name))   # focus_point(s): from the depths they see
    plan = make_plan(s)
    assert set(s.psf) <= set(plan.psf_models), (set(s.psf), plan.psf_models)


IRIS = 'focus_distance_m = 2.5\naperture = { blades = 6, rotation_deg = 15 }'


def test_camera_iris_and_its_header(tmp_path):
    cam = load_scene(write(tmp_path, edit("focus_distance_m = 2.5", IRIS))).camera
    assert (cam.iris().blades, cam.iris().rotation_deg, cam.iris().rounding) == (6, 15.0, 0.0)
    data = json.loads(json.dumps(cam.camera_json()))
    assert data["aperture"] == {"blades": 6, "rotation_deg": 15.0, "rounding": 0.0}
    assert ThinLens.from_json(data) == cam.thin_lens()      # the iris does not change the CoC
    assert load_scene(write(tmp_path, BASE, "round.toml")).camera.iris() is None


@pytest.mark.parametrize("new,needles", [
    ('aperture = { blade = 6 }', ["[camera]", "aperture", "'blade'", "known keys", "'blades'"]),
    ('aperture = { blades = 2 }', ["[camera]", "aperture", "blades = 2", "3 to 64"]),
    ('aperture = { blades = 6, rounding = 1.5 }', ["rounding = 1.5", "[0, 1]"]),
    ('aperture = "hexagon"', ["aperture = 'hexagon'", "{ blades = 6", "remove it"]),
])
def test_camera_iris_typos_say_what_to_fix(tmp_path, new, needles):
    msg = error(tmp_path, edit("focus_distance_m = 2.5", f"focus_distance_m = 2.5\n{new}"))
    assert "s.toml" in msg and len(msg.splitlines()) == 1
    for needle in needles:
        assert needle in msg, msg


def test_pinhole_has_no_iris(tmp_path):
    text = edit("f_number = 2.0\nfocus_distance_m = 2.5", "aperture = { blades = 6 }").replace('"thin"', '"pinhole"')
    msg = error(tmp_path, text)
    assert "'aperture'" in msg and "pinhole has none" in msg


def test_shape_layers(tmp_path):
    tagged = edit('type = "sphere"', 'type = "sphere"\nlayer = 0')
    s = load_scene(write(tmp_path, tagged))
    assert s.input_layers() == [[1], [0]] and s.shapes[1].layer == 0
    assert load_scene(write(tmp_path, BASE, "flat.toml")).input_layers() == []
    assert "layer" not in json.dumps(load_scene(write(tmp_path, BASE, "flat.toml")).to_dict())
    msg = error(tmp_path, edit('type = "sphere"', 'type = "sphere"\nlayer = 2'))
    assert "layer = [2]" in msg and "without gaps" in msg
    assert "numbered from 0" in error(tmp_path, edit('type = "sphere"', 'type = "sphere"\nlayer = -1'))
