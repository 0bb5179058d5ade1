"""The camera model registry: every model has a runtime twin, header and plan rule; errors list
the models; scene -> header JSON -> runtime camera keeps the CoC."""
import json

import numpy as np
import pytest

from lab.cameras import camera_names, get_camera, parse_camera
from lab.errors import UserError
from lab.exr_io import validate_camera
from runtime_cl.camera import from_header, lens_names

PLACE = {"position": [0, 0, 0], "look_at": [0, 0, 1]}
# One [camera] table per registered model (a new model adds its own here).
EXAMPLES = {
    "thin": {"model": "thin", "focal_length_mm": 50, "f_number": 2.0, "focus_distance_m": 2.5, **PLACE},
    "pinhole": {"model": "pinhole", "fov_deg": 40, **PLACE},
    "thick": {"model": "thick", "lens": "singlet", "focus_distance_m": 2.0, **PLACE},
}
IRIS = {**EXAMPLES["thin"], "aperture": {"blades": 5, "rotation_deg": 10}}
PLAN_KEYS = {"dof", "aperture", "psf_models", "references", "runtime_passes", "skipped"}
OPTIONAL_PLAN_KEYS = {"pass_runs", "effects"}


def camera(table):
    return parse_camera(table, "c.toml [camera]")


def test_every_model_has_an_example_here():
    assert sorted(EXAMPLES) == camera_names() == ["pinhole", "thick", "thin"]


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_every_model_has_its_runtime_twin_under_its_header_lens(name):
    """The header's "lens" is the model's name, which the runtime registers the twin under."""
    cls = get_camera(name)
    cam = camera(EXAMPLES[name])
    assert type(cam) is cls and cam.model == name
    header = json.loads(json.dumps(cam.camera_json()))
    assert header["lens"] == name == cls.runtime.lens
    assert validate_camera(header, "h") == header
    twin = from_header(header, "h")
    assert type(twin) is cls.runtime and twin == cam.runtime_camera()
    assert cam.fov_x_deg() == twin.fov_x_deg()


def test_the_lab_models_every_runtime_lens():
    assert lens_names() == camera_names()


def plan_camera(scene):
    return scene.camera.runtime_camera()


def _db():
    from runtime_cl.psf.synthetic import disc_database

    return disc_database(4.0, samples=4)


@pytest.mark.parametrize("table", [EXAMPLES["thin"], IRIS, EXAMPLES["pinhole"], EXAMPLES["thick"]])
def test_every_plan_rule_gives_the_plan_fields(table):
    from lab.plan import make_plan
    from lab.scene import parse_scene

    scene = parse_scene({"scene": {"name": "c", "resolution": [8, 8]}, "camera": table,
                         "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "c.toml")
    from runtime_cl.passes import get_pass

    rule = scene.camera.plan(scene)
    assert PLAN_KEYS <= set(rule) <= PLAN_KEYS | OPTIONAL_PLAN_KEYS
    plan = make_plan(scene)
    assert plan.runtime_passes == rule["runtime_passes"]
    for label in plan.runtime_passes:          # every label runs a registered pass with its options
        name, options = plan.pass_run(label)
        get_pass(name)(plan_camera(scene), None if get_pass(name).database_models == () else _db(),
                       **options)


def test_scene_to_header_to_runtime_keeps_the_coc():
    """The thin-lens CoC a v W / sensor (1/F - 1/z) survives the header, with either aperture key
    and with an iris (whose circumradius is the aperture radius)."""
    z, width = np.array([0.4, 1.0, 2.5, 7.0, np.inf]), 640
    f, n, focus, sensor = 0.05, 2.0, 2.5, 0.036
    v = f * focus / (focus - f)
    want = (f / (2 * n)) * v * width / sensor * (1 / focus - 1 / z)
    by_radius = {k: v for k, v in EXAMPLES["thin"].items() if k != "f_number"}
    for table in (EXAMPLES["thin"], IRIS, {**by_radius, "aperture_radius_mm": 12.5}):
        cam = camera(table)
        header = json.loads(json.dumps(cam.camera_json()))
        np.testing.assert_allclose(from_header(header, "h").coc_radius_px(z, width), want, rtol=1e-12)
        np.testing.assert_allclose(cam.thin_lens().coc_radius_px(z, width), want, rtol=1e-12)
    pin = camera(EXAMPLES["pinhole"])
    assert pin.thin_lens() is None
    np.testing.assert_array_equal(from_header(pin.camera_json(), "h").coc_radius_px(z, width), 0.0)


def test_unknown_model_and_lens_list_the_choices():
    with pytest.raises(UserError, match=r"c.toml \[camera\]: model = 'fisheye' is not a camera model; "
                                        r"use one of \['pinhole', 'thick', 'thin'\]"):
        camera({**EXAMPLES["thin"], "model": "fisheye"})
    with pytest.raises(UserError, match=r"camera model 'fisheye' is unknown; known camera models are "
                                        r"\['pinhole', 'thick', 'thin'\]"):
        get_camera("fisheye")
    with pytest.raises(UserError, match=r"a.exr: lens = 'fisheye' is not known; use one of "
                                        r"\['pinhole', 'thick', 'thin'\]"):
        validate_camera({"lens": "fisheye"}, "a.exr")
    with pytest.raises(UserError, match=r"missing key\(s\) \['model'\]"):
        camera(PLACE)


def test_unknown_keys_list_the_models_own_keys():
    with pytest.raises(UserError) as exc:
        camera({**EXAMPLES["pinhole"], "focal_lenght_mm": 5})
    msg = str(exc.value)
    assert "c.toml [camera]" in msg and "'focal_lenght_mm'" in msg and "'fov_deg'" in msg
    assert "'f_number'" not in msg.split("known keys")[1]
    with pytest.raises(UserError, match="remove fov_deg"):
        camera({**EXAMPLES["thin"], "fov_deg": 40})


def test_mitsuba_sensors_from_the_perspective_one():
    base = {"type": "perspective", "fov": 40.0, "fov_axis": "x"}
    assert camera(EXAMPLES["pinhole"]).mitsuba_sensor(base) == base
    thin = camera(EXAMPLES["thin"])
    sensor = thin.mitsuba_sensor(base)
    assert sensor == {**base, "type": "thinlens", "aperture_radius": pytest.approx(0.0125),
                      "focus_distance": 2.5}
    assert base["type"] == "perspective"    # the input's sensor is left as it was
