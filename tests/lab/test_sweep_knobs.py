"""The sweep's knob registry: which knob applies to which runtime pass, and why not."""
import numpy as np
import pytest

from lab.exr_io import LabelledImage
from lab.paths import SCENES
from lab.pipeline import load_scene_and_plan
from lab.psf_tracing.models.base import get_model
from lab.report.knobs import KNOBS, Knob, pass_accepts, register_knob, select_knobs
from lab.report.sweep import sweep_tasks
from runtime_cl.errors import InputError
from runtime_cl.passes import get_pass


def test_pass_knobs_apply_only_where_the_pass_takes_the_option():
    assert KNOBS["integrator"].skip_reason(get_pass("spreadlets")) is None
    assert "takes no option 'integrator'" in KNOBS["integrator"].skip_reason(get_pass("splat"))
    assert KNOBS["lens_rays"].skip_reason(get_pass("layered")) is None
    assert "takes no option 'rays'" in KNOBS["lens_rays"].skip_reason(get_pass("spreadlets"))
    assert KNOBS["layers"].skip_reason(get_pass("polygon")) is None     # the polygon pass's global layers
    assert "no depth layers of its own" in KNOBS["layers"].skip_reason(get_pass("layered"))
    assert KNOBS["traced_layers"].skip_reason(get_pass("layered")) is None
    assert pass_accepts(get_pass("polygon"), "layers") and not pass_accepts(get_pass("identity"), "layers")


def test_psf_knobs_need_a_database_with_the_setting():
    simple = get_model("simple_lens").Config
    assert KNOBS["operating_point"].skip_reason(get_pass("spreadlets"), simple) is None
    assert "uses no PSF database" in KNOBS["operating_point"].skip_reason(get_pass("polygon"), None)
    assert "draws the dense PSFs" in KNOBS["operating_point"].skip_reason(get_pass("splat"), simple)
    assert KNOBS["psf_samples"].skip_reason(get_pass("splat"), simple) is None   # dense PSFs have samples too
    motion = Knob("motion_range", "psf", "max_motion_px", "largest motion", lambda b: [b])
    assert "has no setting 'max_motion_px'" in motion.skip_reason(get_pass("spreadlets"), simple)
    assert motion.skip_reason(get_pass("spreadlets"), get_model("combined").Config) is None


def test_values_pass_through_the_run_and_bracket_it():
    assert KNOBS["operating_point"].values(1.0) == [0.5, 1.0, 2.0]
    assert KNOBS["lens_rays"].values(100) == [12, 50, 100, 200]
    assert KNOBS["reference_spp"].values(256) == [32, 64, 128, 256]
    assert KNOBS["psf_samples"].values(1) == [1, 2]     # no 0 samples: at least 1, no duplicates


def test_sweep_tasks_of_tiny_skip_with_reasons_and_grow_by_one_entry(monkeypatch):
    scene, plan = load_scene_and_plan(SCENES / "tiny.toml")   # spreadlets, splat, filter; a thin-lens reference
    tasks, skipped = sweep_tasks(scene, plan, None, select_knobs(["integrator", "lens_rays"]))
    assert tasks == []   # tiny's database stores row differences (the default basis): no integrator
    reasons = {(s["method"], s["knob"]): s["reason"] for s in skipped}
    assert set(reasons) == {("spreadlets", "lens_rays"), ("splat", "lens_rays"), ("filter", "lens_rays"),
                            ("splat", "integrator"), ("filter", "integrator"), ("spreadlets", "integrator")}
    assert "row differences" in reasons[("spreadlets", "integrator")]
    # A new knob is one registry entry: the spreadlet passes' run length, swept with no other change.
    monkeypatch.setitem(KNOBS, "run_max", Knob("run_max", "pass", "run_max", "spreadlet run", lambda b: [b // 2, b]))
    tasks, _ = sweep_tasks(scene, plan, None, select_knobs(["run_max"]))
    assert {t.method for t in tasks} == {"spreadlets", "splat", "filter"} and len(tasks) == 6


def test_unknown_knob_names_the_known_ones():
    with pytest.raises(InputError, match="operating_point,psf_samples"):
        select_knobs(["nope"])
    with pytest.raises(ValueError, match="kind"):
        register_knob(Knob("x", "shader", "x", "x", lambda b: [b]))


def test_a_laplacian_database_sweeps_the_integrators_and_both_bases(tmp_path):
    """With ``basis = "laplacian"`` the spreadlets pass integrates a Laplacian: the integrator knob
    sweeps every registered integrator from the default, and ``basis`` sweeps both (the
    spreadlets pass only: Splat and Filter draw the dense PSFs)."""
    scene_file = tmp_path / "laplacian.toml"
    scene_file.write_text((SCENES / "tiny.toml").read_text().replace("[psf.simple_lens]\n",
                                                                     '[psf.simple_lens]\nbasis = "laplacian"\n'))
    scene, plan = load_scene_and_plan(scene_file)
    h, w = scene.height, scene.width
    image = LabelledImage(rgb=np.ones((h, w, 3), np.float32), alpha=np.ones((h, w), np.float32),
                          depth=np.linspace(0.5, 4.0, h * w, dtype=np.float32).reshape(h, w),
                          camera=scene.camera.camera_json())   # the plan derives the CoC range from it
    tasks, skipped = sweep_tasks(scene, plan, image, select_knobs(["integrator", "basis"]))
    assert {(t.method, t.knob.name, t.value, t.base) for t in tasks} == {
        ("spreadlets", "integrator", n, "fft32") for n in ("exact", "fft32", "pyramid")} | {
        ("spreadlets", "basis", b, "laplacian") for b in ("laplacian", "rows")}
    reasons = {(s["method"], s["knob"]): s["reason"] for s in skipped}
    assert ("spreadlets", "integrator") not in reasons
    assert "dense PSFs" in reasons[("splat", "basis")]
