"""Motion in scene files: the keys, the rigid motion of shapes, the camera's motion and shutter,
and what the plan makes of a moving scene."""
import math

import numpy as np
import pytest

from lab.errors import UserError
from lab.motion import describe_motion, rigid_motion, scene_moves
from lab.plan import make_plan
from lab.scene import parse_scene

THIN = {"model": "thin", "focal_length_mm": 50, "f_number": 2, "focus_distance_m": 3}
PINHOLE = {"model": "pinhole", "fov_deg": 40}
BALL = {"type": "sphere", "material": "m", "center": [1.0, 0.5, 4.0], "radius": 0.5}


def scene(camera=THIN, shapes=(BALL,), **tables):
    return parse_scene({"scene": {"name": "m", "resolution": [16, 8]},
                        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **camera},
                        "materials": {"m": {"reflectance": [0.5, 0.5, 0.5]}},
                        "shapes": list(shapes), **tables}, "m.toml")


def test_rigid_motion_turns_about_the_centre_then_moves():
    np.testing.assert_array_equal(rigid_motion([1, 2, 3], [1, 0, 0], [0, 0, 90], 0.0), np.eye(4))
    m = rigid_motion([1, 2, 3], [0.5, 0, 0], [0, 0, 90], 1.0)
    np.testing.assert_allclose(m @ [1, 2, 3, 1], [1.5, 2, 3, 1])                 # the centre only moves
    np.testing.assert_allclose(m @ [2, 2, 3, 1], [1.5, 3, 3, 1], atol=1e-12)     # +x turns to +y
    half = rigid_motion([0, 0, 0], None, [0, 0, 90], 0.5)
    np.testing.assert_allclose(half[:3, :3] @ half[:3, :3], m[:3, :3], atol=1e-12)


def test_a_shape_at_time_t():
    s = scene(shapes=[{**BALL, "velocity": [0, 1, 0], "angular_velocity_deg": [0, 360, 0]}]).shapes[0]
    m = s.to_world_at(0.5)
    np.testing.assert_allclose(m[:3, 3], [1.0, 1.0, 4.0])
    np.testing.assert_allclose(m[:3, :3], 0.5 * np.diag([-1, 1, -1]), atol=1e-12)   # half a turn, radius 0.5
    np.testing.assert_array_equal(s.to_world_at(0.0), s.to_world_matrix())


def test_what_moves():
    assert not scene_moves(scene()) and describe_motion(scene()) == "none"
    assert scene_moves(scene(shapes=[{**BALL, "velocity": [0.1, 0, 0]}]))
    assert scene_moves(scene({**THIN, "velocity": [0, 0, 1]}))
    assert not scene_moves(scene(shapes=[{**BALL, "velocity": [0, 0, 0]}]))            # zero motion
    assert not scene_moves(scene({**THIN, "shutter": [0.5, 0.5]}, [{**BALL, "velocity": [1, 0, 0]}]))
    text = describe_motion(scene({**THIN, "velocity": [0, 0, 1], "shutter": [-1, 1]},
                                 [{**BALL, "angular_velocity_deg": [0, 10, 0]}]))
    assert "1 moving shape(s), 1 turning" in text and "camera velocity" in text and "[-1, 1]" in text


@pytest.mark.parametrize("where, value, needles", [
    ("shape", {"velocity": [1, 2]}, ["velocity", "tuple[float, float, float]"]),
    ("shape", {"velocity": [1, math.nan, 0]}, ["velocity", "finite"]),
    ("shape", {"angular_velocity_deg": [0, math.inf, 0]}, ["angular_velocity_deg", "finite"]),
    ("camera", {"velocity": [0, "a", 0]}, ["velocity", "wrong type"]),
    ("camera", {"shutter": [1, 0]}, ["shutter", "open <= close"]),
    ("camera", {"shutter": [0, math.nan]}, ["shutter", "finite"]),
    ("camera", {"position": [0, math.nan, 0]}, ["position", "finite"]),
])
def test_bad_motion_keys_name_the_file_and_key(where, value, needles):
    with pytest.raises(UserError) as err:
        if where == "shape":
            scene(shapes=[{**BALL, **value}])
        else:
            scene({**THIN, **value})
    assert "m.toml" in str(err.value) and all(n in str(err.value) for n in needles), str(err.value)


def test_a_moving_thin_lens_scene_plans_the_combined_model_against_subframes():
    plan = make_plan(scene(shapes=[{**BALL, "velocity": [0.1, 0, 0]}]))
    assert plan.psf_models == ("combined",)
    assert [r.name for r in plan.references] == ["mitsuba_motion"]
    assert plan.runtime_passes == ("spreadlets", "splat", "filter")
    assert plan.effects["motion"].startswith("linear per pixel (1 moving shape(s)")
    assert "motion.X, motion.Y" in plan.inputs[0].detail
    assert "motion blur" not in {s.name for s in plan.skipped}


def test_a_moving_pinhole_scene_blurs_motion_alone():
    plan = make_plan(scene(PINHOLE, [{**BALL, "velocity": [0.1, 0, 0]}]))
    assert plan.psf_models == ("combined",) and plan.effects["dof"] == "none"
    assert [r.name for r in plan.references] == ["mitsuba_motion"]


@pytest.mark.parametrize("aperture, says, keys", [
    ({"blades": 6}, "polygon (6 blades", {"aperture": "polygon", "aperture_blades": 6, "aperture_rotation_deg": 0.0,
                                         "aperture_rounding": 0.0}),
    ({"shape": "star"}, "star (stylized)", {"aperture": "star"}),
])
def test_a_moving_lens_with_a_shaped_aperture_sweeps_that_aperture(aperture, says, keys):
    s = scene({**THIN, "aperture": aperture}, [{**BALL, "velocity": [0.1, 0, 0]}])
    plan = make_plan(s)
    assert plan.psf_models == ("combined",) and plan.effects["aperture"].startswith(says)
    assert [r.name for r in plan.references] == ["mitsuba_motion"]
    assert s.camera.aperture_keys() == keys    # what the combined database is traced with


@pytest.mark.parametrize("camera, extra, needles", [
    (PINHOLE, {"medium": {"sigma_t": 0.1}}, ["[medium]", "motion"]),
])
def test_motion_with_what_no_model_combines_is_an_error(camera, extra, needles):
    with pytest.raises(UserError) as err:
        make_plan(scene(camera, [{**BALL, "velocity": [0.1, 0, 0]}], **extra))
    assert "m.toml" in str(err.value) and all(n in str(err.value) for n in needles), str(err.value)


def test_motion_with_a_layered_input_is_an_error():
    with pytest.raises(UserError, match="layer"):
        make_plan(scene(shapes=[{**BALL, "velocity": [0.1, 0, 0], "layer": 0}]))


def test_the_header_carries_the_shutter():
    assert scene({**THIN, "shutter": [-0.5, 0.5]}).camera.camera_json()["shutter"] == [-0.5, 0.5]
    assert scene(PINHOLE).camera.camera_json()["shutter"] == [0.0, 1.0]
