"""``splatlab report --sweep``: what accuracy costs in time, knob by knob.

For every method the scene's plan runs and every knob of :mod:`lab.report.knobs` that applies to
it, the method is run again with the knob set to each of its values (the others as in the
report) and scored against the scene's reference as the report scores it: time by the runtime's
one contract (:mod:`runtime_cl.timing`, ``time_ms``), SSIM and PSNR on the tonemap, and the
noise-corrected PSNR when the report has a second reference. PSF-model knobs go through
:func:`lab.precompute.precompute`, so every database is content-hashed and a re-run is warm.

The ``reference_spp`` knob sweeps the path tracer itself (the method ``path tracer``): the scene's
reference re-rendered with fewer samples and an independent seed, scored against the reference;
its time is the wall clock of the render (not the runtime's contract: Mitsuba has no events),
each render cached with its seconds under the scene's render folder.
"""
from __future__ import annotations

import dataclasses

import json
import time
from dataclasses import dataclass, field, replace

import numpy as np

from runtime_cl.atomic_file import atomic_path

from .knobs import REFERENCE, Knob, pass_default
from .metrics import noise_corrected_mse, psnr, ssim

__all__ = ["SweepTask", "sweep_tasks", "run_sweep"]


@dataclass(frozen=True)
class SweepTask:
    """One point to measure: ``method`` (report label) with ``knob`` at ``value``; ``base`` is
    the value of the report's own run."""

    method: str
    label: str
    model: str | None
    knob: Knob
    value: object
    base: object
    extra: dict = field(default_factory=dict)


def _models_of(cls, plan) -> list:
    """The plan's databases a pass renders (None: it takes none), as ``run_runtime`` pairs them."""
    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    if cls.database_models == ():
        return [None]
    return [m for m in plan.psf_models
            if m != FAR_FIELD and (cls.database_models is None or m in cls.database_models)]


def sweep_tasks(scene, plan, image, knobs) -> tuple[list[SweepTask], list[dict]]:
    """Every point to measure, and every (method, knob) skipped with the reason."""
    from runtime_cl.passes import get_pass

    from ..psf_settings import model_table
    from ..psf_tracing.models.base import get_model

    tasks, skipped = [], []
    for label in plan.runtime_passes:
        name, options = plan.pass_run(label)
        cls = get_pass(name)
        models = _models_of(cls, plan)
        for model in models:
            method = label if len(models) == 1 else f"{label}:{model}"
            config = None if model is None else get_model(model).Config
            for knob in knobs:
                if knob.kind == "reference":
                    continue
                reason = knob.skip_reason(cls, config)
                if reason is None and knob.refuses is not None and model is not None:
                    defaults = {f.name: f.default for f in dataclasses.fields(config)
                                if f.default is not dataclasses.MISSING}
                    reason = knob.refuses({**defaults, **scene.psf.get(model, {})})
                if reason is not None:
                    skipped.append({"method": method, "knob": knob.name, "reason": reason})
                    continue
                if knob.kind == "psf":
                    table = model_table(scene, model, image)
                    base = table.get(knob.key, getattr(config, "__dataclass_fields__")[knob.key].default)
                    extra = {k: table.get(k, config.__dataclass_fields__[k].default) for k in knob.scale_with
                             if k in config.__dataclass_fields__}
                else:
                    base, extra = options.get(knob.key, pass_default(cls, knob.key)), {}
                tasks += [SweepTask(method, label, model, knob, v, base, extra) for v in knob.values(base)]
    for knob in knobs:
        if knob.kind != "reference":
            continue
        if plan.references[0].name == "pinhole":
            skipped.append({"method": REFERENCE, "knob": knob.name,
                            "reason": "the reference is the pinhole input itself: nothing is sampled"})
            continue
        base = getattr(scene.render, knob.key)
        tasks += [SweepTask(REFERENCE, REFERENCE, None, knob, v, base) for v in knob.values(base)]
    return tasks, skipped


def _scores(rgb, reference, reference_b) -> dict:
    out = {"ssim": ssim(rgb, reference), "psnr": psnr(rgb, reference)}
    if reference_b is not None:
        mse = noise_corrected_mse(rgb, reference, reference_b)
        out["noise_corrected_psnr"] = float(-10.0 * np.log10(mse)) if mse > 0 else None
    return out


def _database(task, scene, image, executor):
    """The precompute result of the task's model with its knob set (cached by content hash)."""
    from ..precompute import precompute
    from ..psf_settings import model_table
    from ..psf_tracing.models import load_model

    table = model_table(scene, task.model, image)
    table[task.knob.key] = task.value
    factor = task.value / task.base if task.extra and task.base else 1.0
    for key, value in task.extra.items():
        table[key] = max(1, int(round(value * factor))) if isinstance(value, int) else value * factor
    model = load_model(task.model, table, f"{scene.source} [psf.{task.model}] {task.knob.key} = {task.value}")
    return precompute(model, progress=False, workers=executor.workers, scheduler=executor.scheduler,
                      threads=executor.threads)


def _runtime_point(task, scene, plan, image, databases, executor) -> dict:
    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    from ..runtime_passes import run_runtime

    name, options = plan.pass_run(task.label)
    dbs = {m: r for m, r in databases.items() if m == task.model or m == FAR_FIELD}
    point = {}
    if task.knob.kind == "psf":
        result = _database(task, scene, image, executor)
        dbs[task.model] = result
        point["database"] = {"reused": result.reused, "build_s": round(result.seconds, 2),
                             "path": result.path.name}
    else:
        options = dict(options, **{task.knob.key: task.value})
    one = replace(plan, runtime_passes=(task.label,), pass_runs=dict(plan.pass_runs, **{task.label: (name, options)}))
    (rendered, timing), = run_runtime(one, image, dbs, progress=False).values()
    point.update({k: timing[k] for k in ("time_ms", "device_ms", "transfer_ms", "host_ms") if k in timing})
    point["rgb"] = rendered[..., :3] if rendered.shape[2] >= 3 else np.repeat(rendered, 3, axis=2)
    point["timing"] = "runtime contract (median time_ms)"
    return point


def _reference_point(task, scene, plan, image, executor) -> dict:
    """The path tracer at ``task.value`` spp with an independent seed; seconds kept beside it."""
    from ..exr_io import read_rgb
    from ..pipeline import _reference, render_folder, reseeded

    other = reseeded(scene, 2, reference_spp=int(task.value))   # neither the reference's nor its twin's
    seed = other.render.seed
    folder = render_folder(scene) / "sweep"
    path, seconds_file = folder / f"reference-{other.render.reference_spp}spp.exr", \
        folder / f"reference-{other.render.reference_spp}spp.json"
    if path.exists() and seconds_file.exists():
        rgb, seconds = read_rgb(path), json.loads(seconds_file.read_text())["seconds"]
    else:
        path.unlink(missing_ok=True)
        t = time.perf_counter()
        rgb, *_ = _reference(other, plan, image, path, executor, False)
        seconds = time.perf_counter() - t
        with atomic_path(seconds_file) as tmp:
            tmp.write_text(json.dumps({"seconds": seconds, "spp": task.value, "seed": seed}))
    return {"time_ms": 1000.0 * seconds, "rgb": rgb, "seed": seed,
            "timing": "wall clock of the Mitsuba render (no runtime contract)"}


def run_sweep(scene, plan, image, reference, reference_b, databases, knobs, executor=None,
              progress: bool = True) -> dict:
    """Measure every sweep point of ``scene``; returns the report's ``sweep`` dictionary
    (``points``, ``skipped``, the knobs swept). A method's point at its report settings is
    rendered once, however many knobs it has (the other knobs' base points repeat it)."""
    from tqdm import tqdm

    from ..parallel import Executor

    executor = Executor() if executor is None else executor
    tasks, skipped = sweep_tasks(scene, plan, image, knobs)
    points, at_base = [], {}
    for task in tqdm(tasks, desc=f"sweep {scene.name}", unit="point", disable=not progress):
        base = task.value == task.base
        if task.knob.kind == "reference":
            measured = _reference_point(task, scene, plan, image, executor)
        elif base and task.method in at_base:
            measured = dict(at_base[task.method])
        else:
            point = _runtime_point(task, scene, plan, image, databases, executor)
            rgb = point.pop("rgb")
            measured = dict(point, **_scores(rgb, reference, reference_b))
            if base:
                at_base[task.method] = {k: v for k, v in measured.items() if k != "database"}
        if "rgb" in measured:
            rgb = measured.pop("rgb")
            measured.update(_scores(rgb, reference, reference_b))
        points.append(dict(method=task.method, knob=task.knob.name, key=task.knob.key, value=task.value,
                           base=base, **measured))
    return {"knobs": {k.name: {"kind": k.kind, "key": k.key, "label": k.label} for k in knobs},
            "points": points, "skipped": skipped}
