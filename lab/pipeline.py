"""The main job for one scene: plan -> inputs and reference -> PSF databases -> runtime -> report.

Every stage computes only what the plan lists and is cached by content hash under ``.cache/``:
renders by the scene's render-relevant contents and the rendering code, databases by model
configuration and the precompute code (:mod:`lab.precompute`). A warm run takes seconds.
"""
from __future__ import annotations

import hashlib
import json
import shutil
import time
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path, check_output, check_output_dir, remove_stale_temps

from .cache_key import code_digest
from .errors import UserError
from .exr_io import LabelledImage, read_labelled, read_rgb, write_labelled, write_rgb
from .parallel import Executor
from .paths import REPORTS, cache_root
from .plan import Plan, make_plan
from .precompute import precompute
from .scene import Scene, load_scene

# What renders the input and the reference (their imports, lab.optics included, are found, not listed).
RENDER_ROOTS = ("lab.reference.references", "lab.reference.labelled")
# imported by the rendering code (through the plan, the cameras and the PSF settings) but never run
# by it: the runtime's passes and the PSF tracer. Editing them keeps the cached renders (10-40 min
# for a 1024^2 reference); tests/lab/reference/test_render_key_exclusions.py renders every kind of
# scene and checks that none of their code runs.
RENDER_EXCLUDE = ("lab.psf_tracing", "lab.runtime_passes", "runtime_cl.passes", "runtime_cl.spreadlets",
                  "runtime_cl.integrate", "runtime_cl.layered", "runtime_cl.layers", "runtime_cl.stochastic",
                  "runtime_cl.psf", "runtime_cl.polygon.kernel", "runtime_cl.polygon.layers",
                  "runtime_cl.polygon.radii", "runtime_cl.polygon.scale", "runtime_cl.polygon.splat",
                  "runtime_cl.polygon.terms", "runtime_cl.polygon.uniform")


def render_key(scene: Scene, packages=None) -> str:
    """12 hex digits naming a scene's input and reference: the scene's render settings and the
    content of the code that renders them (:data:`RENDER_ROOTS` and what they import, less
    :data:`RENDER_EXCLUDE`);
    ``packages`` as for :func:`lab.cache_key.code_digest`."""
    data = scene.to_dict()
    data.pop("psf", None)
    data.pop("precompute", None)
    # the runtime's depth layers render nothing; the guard band changes the input only, whose
    # file name says so (:func:`inputs_and_reference`), so both share one reference
    for key in ("depth_layers", "guard_band"):
        data["render"].pop(key, None)
    key = json.dumps({"scene": data, "code": code_digest(RENDER_ROOTS, packages, RENDER_EXCLUDE)}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def render_folder(scene: Scene):
    """Where a scene's input, references and what derives from them are cached (not made here)."""
    return cache_root() / "renders" / f"{scene.name}-{render_key(scene)}"


NOISE_SEED_OFFSET = 1_000_003   # the second reference's seed: seed + this (mod 2^31)
SECOND_REFERENCE = "reference_b_image"


def reseeded(scene: Scene, stream: int, **render) -> Scene:
    """``scene`` with an independent path-tracing seed: stream 1 is the reference's noise-floor
    twin, stream 2 the path tracer compared as a method (sweeps, benches). Same seed, same passes:
    a render at fewer spp from the reference's own seed would be a subset of its samples, and
    agree with it far better than independent noise does. ``render`` overrides other settings."""
    seed = (scene.render.seed + stream * NOISE_SEED_OFFSET) % 2**31
    return replace(scene, render=replace(scene.render, seed=seed, **render))


def inputs_and_reference(scene: Scene, plan: Plan, progress: bool = True,
                         executor: Executor | None = None, second: bool = False) -> tuple:
    """The labelled-pixel input and the reference of ``scene`` (cached); returns (input, reference, info).
    A plan with no reference (:attr:`lab.plan.Plan.scored` false) gives reference None and the
    reason in ``info["none"]``.

    The reference's passes run where ``executor`` says (default: this process), each cached in
    ``<cache>/renders/<scene>-<key>/reference-passes/`` until ``reference.exr`` is written, so an
    interrupted render resumes (:func:`lab.reference.execute.run_job`). The input renders here.
    ``second``: also render a reference with an independent seed (``reference_b.exr``), put how
    far the two agree in ``info["noise_floor"]`` (the SSIM and PSNR no method can beat) and the
    image in ``info[SECOND_REFERENCE]``.
    """
    from .report.metrics import psnr, ssim

    executor = Executor() if executor is None else executor
    folder = render_folder(scene)   # made by the first write
    remove_stale_temps(folder)
    info = {"cache": str(folder)}
    ref_path = folder / "reference.exr"
    image, info["input_s"] = _input(scene, input_path(scene), progress)
    info.update(steps=[s.name for s in plan.references], input_spp=scene.render.input_spp)
    if not plan.scored:   # nothing physical to render (an expressive focal surface): say so
        if second:
            raise UserError(f"{scene.source}: a second reference (the noise floor) needs a reference, and this "
                            f"scene has none ({plan.references[0].detail})")
        info["none"] = plan.references[0].detail
        return image, None, info
    reference, info["reference_s"], adaptive = _reference(scene, plan, image, ref_path, executor, progress)
    if adaptive is not None:
        info["adaptive"] = adaptive
    if not isinstance(info["reference_s"], str) and plan.references[0].name != "pinhole":
        info["reference_on"] = executor.describe()
    info.update(reference_spp=scene.render.reference_spp)
    if second and plan.references[0].name != "pinhole":
        other = reseeded(scene, 1)
        again, seconds, _ = _reference(other, plan, image, folder / "reference_b.exr", executor, progress)
        info["noise_floor"] = {"ssim": ssim(again, reference), "psnr": psnr(again, reference),
                               "seeds": [scene.render.seed, other.render.seed], "reference_s": seconds}
        info[SECOND_REFERENCE] = again   # not for report.json: run_report takes it out
    elif plan.references[0].name == "pinhole":
        info["noise_floor_skipped"] = "the reference is the labelled input itself: no path-tracing noise"
    else:
        info["noise_floor_skipped"] = "skipped (--no-noise-floor)"
    return image, reference, info


def input_path(scene: Scene) -> Path:
    """Where the labelled-pixel input of ``scene`` is cached."""
    return render_folder(scene) / ("input_guard.exr" if scene.render.guard_band else "input.exr")


def input_only(scene: Scene, progress: bool = True) -> LabelledImage:
    """The labelled-pixel input of ``scene`` (cached), without its reference (benchmarks of speed)."""
    remove_stale_temps(render_folder(scene))
    return _input(scene, input_path(scene), progress)[0]


def _input(scene: Scene, path: Path, progress: bool) -> tuple:
    """(the input read from ``path`` or rendered and written there, seconds or "cached")."""
    from .reference.labelled import render_labelled

    if path.exists():
        return read_labelled(path), "cached"
    t = time.perf_counter()
    image = render_labelled(scene, progress=progress)
    write_labelled(path, image)
    return image, round(time.perf_counter() - t, 2)


def _reference(scene: Scene, plan: Plan, image, path: Path, executor: Executor, progress: bool) -> tuple:
    """The plan's reference of ``scene`` at ``path`` (read if cached; else rendered where ``executor``
    says, its passes cached in ``<path stem>-passes/`` until the EXR is written); (image, seconds or
    "cached", what an adaptive reference spent or None)."""
    from .reference.adaptive import AdaptiveJob
    from .reference.execute import run_job
    from .reference.passes import RenderJob
    from .reference.references import reference_step

    sidecar = path.with_name(f"{path.stem}-adaptive.json")   # what an adaptive reference spent
    if path.exists():
        return read_rgb(path), "cached", (json.loads(sidecar.read_text()) if sidecar.exists() else None)
    t = time.perf_counter()
    reference = reference_step(plan.references[0].name, scene, image)
    passes = path.with_name(f"{path.stem}-passes")
    adaptive = None
    if isinstance(reference, AdaptiveJob):
        reference, adaptive = reference.run(
            lambda job, name, stats: run_job(job, executor, passes / name, progress, stats))
        with atomic_path(sidecar) as tmp:
            tmp.write_text(json.dumps(adaptive))
    elif isinstance(reference, RenderJob):
        reference = run_job(reference, executor, passes, progress)
    write_rgb(path, reference)
    shutil.rmtree(passes, ignore_errors=True)  # the EXR now holds them
    return reference, round(time.perf_counter() - t, 2), adaptive


def stochastic_input(scene: Scene, index: int = 0, shading_spp: int = 1, image: LabelledImage | None = None,
                     progress: bool = True, medium: bool = False) -> LabelledImage:
    """The ``index``-th independent 1-spp stochastic image of ``scene`` (:mod:`lab.reference.
    stochastic`: lens sample and shutter time per pixel; ``shading_spp`` paths per camera ray),
    cached beside its input by a hash of that module. A moving scene's sub-frames follow the
    longest motion of its labelled input: ``image``, or the cached input (rendered if missing).
    ``medium``: the same samples traced through the scene's ``[medium]`` (a denoiser's input)."""
    from .motion import scene_moves
    from .reference.stochastic import render_stochastic

    longest = 0.0
    if scene_moves(scene):
        image = image if image is not None else input_only(scene, progress)
        flow = [image.extra[c] for c in ("motion.X", "motion.Y") if c in image.extra]
        longest = float(np.hypot(*flow).max()) if flow else 0.0
    folder = render_folder(scene)
    kind = "-medium" if medium else ""
    path = folder / f"stochastic-{index}-shade{shading_spp}{kind}-{code_digest(('lab.reference.stochastic',))[:12]}.exr"
    if not path.exists():
        if progress:
            print(f"  stochastic input {index}{kind} of {scene.name}", flush=True)
        write_labelled(path, render_stochastic(scene, index, longest, shading_spp, medium))
    return read_labelled(path)


def build_databases(scene: Scene, plan: Plan, image: LabelledImage, force: bool = False,
                    progress: bool = True, executor: Executor | None = None) -> dict:
    """Precompute (or reuse) every PSF model the plan lists, where ``executor`` says (default:
    this process); name -> PrecomputeResult."""
    from .psf_settings import model_table
    from .psf_tracing.models import load_model

    executor = Executor() if executor is None else executor
    results = {}
    for name in plan.psf_models:
        model = load_model(name, model_table(scene, name, image), f"{scene.source} [psf.{name}]")
        results[name] = precompute(model, force=force, progress=progress, workers=executor.workers,
                                   scheduler=executor.scheduler, threads=executor.threads)
    return results


def load_scene_and_plan(path, depth_layers: int | None = None) -> tuple:
    """The scene of ``path`` and its plan; ``depth_layers`` (``report --layers N``) replaces the
    scene's ``[render] depth_layers``."""
    from dataclasses import replace

    from .focus import resolve_focus
    from .psf_settings import check_tables

    scene = resolve_focus(load_scene(path))   # focus_point(s): the depths they see give the focus
    if depth_layers is not None:
        scene = replace(scene, render=replace(scene.render, depth_layers=depth_layers))
    plan = make_plan(scene)
    check_tables(scene, plan.psf_models)   # a bad [psf.*] setting fails before any render
    return scene, plan


def default_out_dir(scene: Scene) -> Path:
    return REPORTS / scene.name


def run_report(scene_path, out_dir=None, baseline=None, progress: bool = True,
               executor: Executor | None = None, noise: bool = True, sweep=None, options=None,
               depth_layers: int | None = None) -> dict:
    """The whole job; writes ``report.json`` and ``index.html`` and returns the report dict.

    ``executor`` (default: this process) runs the reference's passes and the databases' cells;
    ``noise`` (default True: every report states it) measures the reference's noise floor and each
    method's noise-corrected MSE (see :func:`inputs_and_reference`); ``sweep``
    (a list of :class:`lab.report.knobs.Knob`) also measures accuracy against time knob by knob
    (:mod:`lab.report.sweep`); ``options`` (``--set``) are given to every runtime pass that takes
    them (:func:`lab.runtime_passes.with_pass_options`); ``depth_layers`` replaces the scene's
    ``[render] depth_layers``.
    """
    from .runtime_passes import with_pass_options

    scene, plan = load_scene_and_plan(scene_path, depth_layers)
    plan = with_pass_options(plan, options or {})
    return report_scene(scene, plan, out_dir, baseline, progress, executor, noise, sweep)


def report_scene(scene: Scene, plan: Plan, out_dir=None, baseline=None, progress: bool = True,
                 executor: Executor | None = None, noise: bool = True, sweep=None) -> dict:
    """:func:`run_report` on a loaded scene and its plan."""
    from .report.build import assemble_report

    out_dir = check_output_dir(out_dir if out_dir else default_out_dir(scene))   # before hours of work
    check_output(out_dir / "report.json", "--out-dir", (baseline,))
    baseline_report = None
    if baseline is not None:
        from .report.regress import load_report

        baseline_report = load_report(baseline)  # fail early, before hours of work
    t0 = time.perf_counter()
    image, reference, ref_info = inputs_and_reference(scene, plan, progress, executor, second=noise)
    databases = build_databases(scene, plan, image, progress=progress, executor=executor)
    from .runtime_passes import run_runtime

    results = run_runtime(plan, image, databases, progress=progress)
    reference_b = ref_info.pop(SECOND_REFERENCE, None)
    report = assemble_report(scene, plan, image, reference, ref_info, databases, results, out_dir,
                             baseline_report, reference_b=reference_b)
    if sweep is not None:
        from .report.sweep_section import add_sweep

        add_sweep(report, scene, plan, image, reference, reference_b, databases, sweep, out_dir, executor, progress)
    report["settings"]["job_seconds"] = round(time.perf_counter() - t0, 2)
    report["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    from .report.html import write_report

    write_report(report, out_dir)
    return report
