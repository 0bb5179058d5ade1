"""The main job for one scene: plan -> inputs and reference -> PSF databases -> runtime -> report.

Every stage computes only what the plan lists and is cached by content hash under ``.cache/``:
renders by the scene's render-relevant contents and the rendering code, databases by model
configuration and the precompute code (:mod:`lab.precompute`). A warm run takes seconds.
"""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

from .cache_key import code_digest
from .exr_io import LabelledImage, read_labelled, read_rgb, write_labelled, write_rgb
from .paths import REPORTS, cache_root
from .plan import Plan, make_plan
from .precompute import precompute
from .scene import Scene, load_scene

# What renders the input and the reference (their imports, lab.optics included, are found, not listed).
RENDER_ROOTS = ("lab.reference.references", "lab.reference.labelled")


def render_key(scene: Scene, packages=None) -> str:
    """12 hex digits naming a scene's input and reference: the scene's render settings and the
    content of the code that renders them (:data:`RENDER_ROOTS` and what they import);
    ``packages`` as for :func:`lab.cache_key.code_digest`."""
    data = scene.to_dict()
    data.pop("psf", None)
    data.pop("precompute", None)
    key = json.dumps({"scene": data, "code": code_digest(RENDER_ROOTS, packages)}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


NOISE_SEED_OFFSET = 1_000_003   # the second reference's seed: seed + this (mod 2^31)


def noise_floor(scene: Scene, plan: Plan, image, reference, folder: Path, progress: bool = True) -> dict:
    """A second reference with an independent seed (cached as ``reference_b.exr``) and how far
    the two agree: the SSIM and PSNR a method cannot beat (the reference's own Monte Carlo noise)."""
    from .exr_io import read_rgb, write_rgb
    from .reference.references import render_reference_step
    from .report.metrics import psnr, ssim

    path = folder / "reference_b.exr"
    if path.exists():
        second = read_rgb(path)
    else:
        other = replace(scene, render=replace(scene.render, seed=(scene.render.seed + NOISE_SEED_OFFSET) % 2**31))
        second = render_reference_step(plan.references[0].name, other, image, progress)
        write_rgb(path, second)
    return {"ssim": ssim(second, reference), "psnr": psnr(second, reference),
            "seeds": [scene.render.seed, (scene.render.seed + NOISE_SEED_OFFSET) % 2**31]}


def inputs_and_reference(scene: Scene, plan: Plan, progress: bool = True, second: bool = False) -> tuple:
    """The labelled-pixel input and the reference of ``scene`` (cached); returns (input, reference, info).

    ``second``: also render a reference with an independent seed and put their agreement in
    ``info["noise_floor"]`` (:func:`noise_floor`)."""
    from .reference.labelled import render_labelled
    from .reference.references import render_reference_step

    folder = cache_root() / "renders" / f"{scene.name}-{render_key(scene)}"
    folder.mkdir(parents=True, exist_ok=True)
    info = {"cache": str(folder)}
    input_path, ref_path = folder / "input.exr", folder / "reference.exr"
    if input_path.exists():
        image = read_labelled(input_path)
        info["input_s"] = "cached"
    else:
        t = time.perf_counter()
        image = render_labelled(scene, progress=progress)
        write_labelled(input_path, image)
        info["input_s"] = round(time.perf_counter() - t, 2)
    if ref_path.exists():
        reference = read_rgb(ref_path)
        info["reference_s"] = "cached"
    else:
        t = time.perf_counter()
        reference = render_reference_step(plan.references[0].name, scene, image, progress)
        write_rgb(ref_path, reference)
        info["reference_s"] = round(time.perf_counter() - t, 2)
    info.update(reference_spp=scene.render.reference_spp, input_spp=scene.render.input_spp,
                steps=[s.name for s in plan.references])
    if second and plan.references[0].name != "pinhole":
        info["noise_floor"] = noise_floor(scene, plan, image, reference, folder, progress)
    return image, reference, info


def build_databases(scene: Scene, plan: Plan, image: LabelledImage, force: bool = False,
                    progress: bool = True) -> dict:
    """Precompute (or reuse) every PSF model the plan lists; name -> PrecomputeResult."""
    from .psf_settings import model_table
    from .psf_tracing.models import load_model

    results = {}
    for name in plan.psf_models:
        model = load_model(name, model_table(scene, name, image), f"{scene.source} [psf.{name}]")
        results[name] = precompute(model, force=force, progress=progress)
    return results


def load_scene_and_plan(path) -> tuple:
    scene = load_scene(path)
    return scene, make_plan(scene)


def default_out_dir(scene: Scene) -> Path:
    return REPORTS / scene.name


def run_report(scene_path, out_dir=None, baseline=None, progress: bool = True, noise: bool = False) -> dict:
    """The whole job; writes ``report.json`` and ``index.html`` and returns the report dict.
    ``noise``: measure the reference's noise floor (:func:`noise_floor`)."""
    from .report.build import assemble_report

    scene, plan = load_scene_and_plan(scene_path)
    out_dir = Path(out_dir) if out_dir else default_out_dir(scene)
    baseline_report = None
    if baseline is not None:
        from .report.regress import load_report

        baseline_report = load_report(baseline)  # fail early, before hours of work
    t0 = time.perf_counter()
    image, reference, ref_info = inputs_and_reference(scene, plan, progress, second=noise)
    databases = build_databases(scene, plan, image, progress=progress)
    from .runtime_passes import run_runtime

    results = run_runtime(plan, image, databases, progress=progress)
    report = assemble_report(scene, plan, image, reference, ref_info, databases, results, out_dir,
                             baseline_report)
    report["settings"]["job_seconds"] = round(time.perf_counter() - t0, 2)
    report["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    from .report.html import write_report

    write_report(report, out_dir)
    return report
