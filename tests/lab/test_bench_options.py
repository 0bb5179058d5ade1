"""``splatlab bench runtime|report --set KEY=VALUE``: the options reach every pass of the plan that
takes them, and only those, on top of the plan's own options."""
from lab.paths import SCENES
from lab.pipeline import load_scene_and_plan
from lab.runtime_passes import with_pass_options
from runtime_cl.passes import get_pass, pass_options


def test_set_reaches_every_pass_that_takes_it():
    _, plan = load_scene_and_plan(SCENES / "tiny_foreground.toml")
    runs = with_pass_options(plan, {"spreadlet_rotation": "bank", "run_max": 16}).pass_runs
    assert list(runs) == list(plan.runtime_passes)
    assert with_pass_options(plan, {}) is plan
    took = []
    for label, (name, options) in runs.items():
        assert name == plan.pass_run(label)[0]
        assert {k: v for k, v in options.items() if k not in ("spreadlet_rotation", "run_max")} == \
            plan.pass_run(label)[1]
        if "spreadlet_rotation" in pass_options(get_pass(name)):
            assert options["spreadlet_rotation"] == "bank" and options["run_max"] == 16
            took.append(label)
        else:
            assert "spreadlet_rotation" not in options
    assert "spreadlets" in took and len(took) < len(runs)   # the layered pass takes neither
