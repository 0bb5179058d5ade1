"""`splatlab render --method spreadlets|splat|filter --layers N` and the plan's depth layers."""
import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from lab.plan import make_plan
from lab.scene import parse_scene
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.frame import Frame
from runtime_cl.passes import run_pass
from runtime_cl.psf.synthetic import disc_database

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 1.4, "focus_distance_m": 1.0,
          "sensor_width_mm": 3.6, "shutter": [0.0, 1.0]}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A sharp block in front of a blurred bright background (CoC ~ +3.9 px), and a disc database."""
    rng = np.random.default_rng(2)
    h, w = 24, 30
    depth = np.full((h, w), 2.0, np.float32)
    depth[8:16, 10:20] = 1.0
    rgb = (rng.random((h, w, 3)) * 4).astype(np.float32)
    rgb[8:16, 10:20] = 0.1
    folder = tmp_path_factory.mktemp("spl")
    write_labelled(folder / "in.exr", LabelledImage(rgb, np.ones((h, w), np.float32), depth, dict(CAMERA)))
    disc_database(5.0, samples=8).save(folder / "db.spdb")
    return folder, Frame(rgb, depth)


@pytest.mark.parametrize("method", ["spreadlets", "splat", "filter"])
def test_render_layers_is_the_runtime_pass(files, tmp_path, capsys, method):
    from runtime_cl.psf.database import SpreadletDatabase

    folder, frame = files
    out = tmp_path / "o.exr"
    assert main(["render", str(folder / "in.exr"), "--db", str(folder / "db.spdb"), "--method", method,
                 "--layers", "3", "--out", str(out)]) == 0
    assert "of 3 depth layers used (flat input)" in capsys.readouterr().out
    want, _ = run_pass(method, frame, ThinLens.from_json(CAMERA), SpreadletDatabase.load(folder / "db.spdb"),
                       layers=3)
    np.testing.assert_array_equal(read_rgb(out), want)


def test_depth_layers_add_the_layered_spreadlet_passes_to_the_plan():
    data = {"scene": {"name": "p", "resolution": [16, 8]},
            "camera": {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50,
                       "f_number": 2, "focus_distance_m": 3},
            "render": {"reference_spp": 32, "input_spp": 8, "depth_layers": 4, "guard_band": True},
            "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}
    plan = make_plan(parse_scene(data, "p.toml"))
    assert plan.runtime_passes == ("spreadlets", "splat", "filter", "spreadlets_layers", "splat_layers",
                                   "filter_layers")
    assert plan.pass_run("splat_layers") == ("splat", {"layers": 4})
    assert plan.pass_run("spreadlets") == ("spreadlets", {})
    assert "guard band" in plan.inputs[0].detail


def _plan(camera: dict, **shape_keys):
    data = {"scene": {"name": "p", "resolution": [16, 8]},
            "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **camera},
            "render": {"reference_spp": 32, "input_spp": 8, "depth_layers": 2},
            "materials": {"m": {"reflectance": [0.5, 0.5, 0.5]}},
            "shapes": [{"type": "sphere", "material": "m", "center": [0, 0, 3], "radius": 0.3, **shape_keys}],
            "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}
    return make_plan(parse_scene(data, "p.toml"))


THIN = {"model": "thin", "focal_length_mm": 50, "f_number": 2, "focus_distance_m": 3}


@pytest.mark.parametrize("camera, shape", [
    (THIN, {"velocity": [0.1, 0, 0]}),                              # combined
    (dict(THIN, aperture={"shape": "star"}), {}),                   # stylized
    ({"model": "thick", "lens": "singlet", "focus_distance_m": 3}, {}),   # physical_lens
])
def test_depth_layers_reach_moving_stylized_and_thick_lens_plans(camera, shape):
    plan = _plan(camera, **shape)
    assert plan.runtime_passes[-3:] == ("spreadlets_layers", "splat_layers", "filter_layers")
    assert plan.pass_run("spreadlets_layers") == ("spreadlets", {"layers": 2})


def test_depth_layers_a_plan_cannot_draw_are_skipped_with_the_reason():
    plan = _plan({"model": "pinhole", "fov_deg": 40}, velocity=[0.1, 0, 0])
    assert not any(p.endswith("_layers") for p in plan.runtime_passes)
    [step] = [s for s in plan.skipped if s.name == "depth_layers = 2"]
    assert "pinhole" in step.detail
