"""The plan's runtime passes on a labelled image: labels, databases, apertures, one timing contract."""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from lab.exr_io import LabelledImage
from lab.plan import Plan
from lab.runtime_passes import frame_of, run_runtime
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.timing import COLUMNS

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 0.5,
          "sensor_width_mm": 36.0}


@pytest.fixture(scope="module")
def image():
    rng = np.random.default_rng(2)
    h, w = 16, 24
    depth = np.where(np.arange(w)[None, :] < 12, 0.5, 0.3) * np.ones((h, 1))
    return LabelledImage(rng.random((h, w, 3)).astype(np.float32), np.ones((h, w), np.float32),
                         depth.astype(np.float32), dict(CAMERA))


def _plan(passes, pass_runs=None):
    return Plan(scene="t", source="t.toml", resolution=(24, 16), effects={}, psf_models=(), references=(),
                inputs=(), runtime_passes=passes, skipped=(), pass_runs=pass_runs or {})


def test_every_label_runs_its_pass_with_its_options(image, tmp_path):
    db = disc_database(8.0, samples=8)
    db.save(tmp_path / "disc.spdb")
    plan = _plan(("spreadlets", "polygon", "polygon_layers", "identity"),
                 {"polygon_layers": ("polygon", {"layers": 3})})
    out = run_runtime(plan, image, {"simple_lens": SimpleNamespace(path=tmp_path / "disc.spdb")},
                      runs=1, min_ms=0.0, progress=False)
    assert list(out) == list(plan.runtime_passes)
    for label, (rendered, timing) in out.items():
        assert rendered.shape[:2] == image.depth.shape and set(COLUMNS) <= set(timing), label
        assert timing["runs"] == 1 and timing["time_ms"] > 0
    assert [out[k][1]["pass"] for k in out] == ["spreadlets", "polygon", "polygon", "identity"]
    assert out["polygon_layers"][1]["counts"]["depth_layers"] == 3
    assert "used_layers" not in out["polygon"][1]["counts"]
    np.testing.assert_array_equal(out["identity"][0], image.rgb)


def test_the_camera_iris_is_the_polygon(image):
    iris = replace(image, camera=dict(CAMERA, aperture={"blades": 5, "rotation_deg": 0.0, "rounding": 0.0}))
    out = run_runtime(_plan(("polygon",)), iris, {}, runs=1, progress=False)
    round_, _ = run_runtime(_plan(("polygon",)), image, {}, runs=1, progress=False)["polygon"]
    assert out["polygon"][1]["aperture"]["edges"] == 5 and "aperture" not in _
    assert np.abs(out["polygon"][0] - round_).max() > 0.01        # a pentagon, not the hexagon


def test_a_pass_needing_a_database_the_plan_did_not_build(image):
    from lab.errors import UserError

    with pytest.raises(UserError, match=r"'splat' needs a database; the plan built \[\]"):
        run_runtime(_plan(("splat",)), image, {}, runs=1, progress=False)


def test_frames_take_motion_and_layers_only_when_asked(image):
    frame = frame_of(image)
    assert frame.motion is None and frame.layers == ()
    from lab.errors import UserError

    with pytest.raises(UserError, match="no layerN"):
        frame_of(image, layered_input=True)


def test_the_polygon_method_refuses_a_stylized_camera(image):
    from lab.errors import UserError

    heart = replace(image, camera=dict(CAMERA, aperture={"shape": "heart"}))
    with pytest.raises(UserError, match=r"stylized heart is drawn by its stylized database"):
        run_runtime(_plan(("polygon",)), heart, {}, runs=0, progress=False)
