"""The render cache key leaves out code the renders import but never run (lab.pipeline.RENDER_EXCLUDE:
the runtime's passes, the PSF tracer), so editing it keeps hours of cached references. Sound only
if no rendering runs that code: each kind of scene's input and reference are rendered (at a few
spp, in a scratch cache) with a profiler recording every Python function called, and every
project module whose functions ran must be one the key hashes -- none excluded, none missed (the pipeline's
own orchestration aside, which names the files and does not draw pixels)."""
import sys
from dataclasses import replace

import pytest

from lab.cache_key import _excluded, module_files
from lab.paths import SCENES
from lab.pipeline import RENDER_EXCLUDE, RENDER_ROOTS, inputs_and_reference, load_scene_and_plan

# modules that schedule, cache and name the renders (their output is keyed by the scene settings)
ORCHESTRATION = {"lab.pipeline", "lab.paths", "lab.parallel", "lab.cache_key", "lab.reference.execute",
                 "lab.reference.pass_files", "runtime_cl.atomic_file"}


def _modules_run(name, tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path))
    scene, plan = load_scene_and_plan(SCENES / f"{name}.toml")
    r = scene.render
    few = dict(reference_spp=min(r.reference_spp, 4), input_spp=min(r.input_spp, 4))
    if r.peel_spp:
        few["peel_spp"] = min(r.peel_spp, 4)
    scene = replace(scene, render=replace(r, **few))
    ran = set()

    def hook(frame, event, arg):      # functions only: a module body run by an import defines things
        if event == "call" and frame.f_code.co_name != "<module>":
            ran.add(frame.f_globals.get("__name__", ""))
    sys.setprofile(hook)
    try:
        inputs_and_reference(scene, plan, progress=False)
    finally:
        sys.setprofile(None)
    return {m for m in ran if m.partition(".")[0] in ("lab", "runtime_cl")}


def _check(name, tmp_path, monkeypatch):
    ran = _modules_run(name, tmp_path, monkeypatch)
    keyed = set(module_files(RENDER_ROOTS, None, RENDER_EXCLUDE))
    assert not {m for m in ran if _excluded(m, RENDER_EXCLUDE)}, "excluded code ran while rendering"
    assert ran - keyed - ORCHESTRATION == set(), "rendering ran code the render key does not hash"
    assert len(ran & keyed) > 10                                       # the hook saw the rendering


# motion sub-frames, an aperture shape from runtime_cl.polygon.shapes, a medium in a box
@pytest.mark.parametrize("name", ["tiny_motion", "tiny_heart", "tiny_fogbox"])
def test_rendering_runs_no_excluded_code(name, tmp_path, monkeypatch):
    _check(name, tmp_path, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tiny", "tiny_rain", "tiny_fog", "tiny_guard", "tiny_foreground",
                                  "tiny_thick_layers", "tiny_tiltshift", "tiny_thick_tiltshift"])
def test_rendering_every_kind_of_scene_runs_no_excluded_code(name, tmp_path, monkeypatch):
    _check(name, tmp_path, monkeypatch)
