"""``splatlab bench runtime``: every runtime pass a scene's plan runs, timed and scored in one run.

The passes are the plan's (:func:`lab.runtime_passes.run_runtime`, the same ones a report runs,
on the databases the plan builds), each timed by the runtime's one contract
(:mod:`runtime_cl.timing`). Ratios are taken against the plan's first pass, measured in the same
run (the machine is shared and noisy).
"""
from __future__ import annotations

from pathlib import Path

from lab.bench import output

__all__ = ["bench_runtime"]

# Counts a pass reports whose rate through its kernels is worth a figure (M per second).
RATES = ("spreadlets", "dense_pixels")


def bench_runtime(scene_path, repeats: int, reference: bool = True, passes=None, sets=None) -> Path:
    """Every runtime pass of ``scene_path``'s plan (or the ``passes`` labels of it): times, SSIM
    against the reference, ratios. ``reference=False`` renders no reference (1024^2 references
    take many minutes; the input and databases are cheap): times and ratios only, no SSIM.
    ``sets``: ``KEY=VALUE`` options given to every pass of the plan that takes them."""
    from dataclasses import replace

    from lab.errors import UserError
    from lab.pipeline import build_databases, inputs_and_reference, input_only, load_scene_and_plan
    from lab.precompute.target import parse_sets
    from lab.report.metrics import ssim
    from lab.runtime_passes import run_runtime, with_pass_options

    scene, plan = load_scene_and_plan(scene_path)
    if passes:
        unknown = [p for p in passes if p not in plan.runtime_passes]
        if unknown:
            raise UserError(f"--passes {','.join(passes)}: {unknown} not in the plan of {scene_path}; "
                            f"choose from {list(plan.runtime_passes)}")
        plan = replace(plan, runtime_passes=tuple(p for p in plan.runtime_passes if p in passes))
    options = parse_sets(sets, example="spreadlet_rotation=bank") if sets else {}
    plan = with_pass_options(plan, options)
    image, ref = inputs_and_reference(scene, plan)[:2] if reference else (input_only(scene), None)
    databases = build_databases(scene, plan, image)
    methods = {}
    for label, (rendered, timing) in run_runtime(plan, image, databases, runs=repeats).items():
        rgb = rendered[..., :3] if rendered.shape[2] >= 3 else rendered.repeat(3, axis=2)
        methods[label] = dict(timing, ssim=ssim(rgb, ref) if reference else None)
    base, base_m = next(iter(methods.items()))
    ratios = {}
    for label, m in list(methods.items())[1:]:
        ratios[f"{label}_time_over_{base}"] = m["time_ms"] / base_m["time_ms"]
        if reference:
            ratios[f"ssim_{base}_minus_{label}"] = base_m["ssim"] - m["ssim"]
    without_split = _hdr_split_cost(plan, image, databases, methods, repeats)
    if without_split is not None:
        ratios["spreadlets_time_over_spreadlets_without_hdr_split"] = (methods["spreadlets"]["time_ms"]
                                                                       / without_split["time_ms"])
    throughput = {label: {f"{count}_M_per_s": m["counts"][count] / m["device_ms"] / 1e3
                          for count in RATES if m["counts"].get(count) and m["device_ms"] > 0}
                  for label, m in methods.items()}
    data = {"scene": str(scene_path), "resolution": list(scene.info.resolution), "repeats": repeats,
            "databases": {name: {"path": str(r.path)} for name, r in databases.items()},
            "options": options, "methods": methods, "spreadlets_without_hdr_split": without_split, "ratios": ratios,
            "throughput": throughput,
            "targets": {"splat_time_over_spreadlets": ">= 10", "ssim_spreadlets_minus_splat": ">= -0.02",
                        "spreadlets.spreadlets_M_per_s": ">= 300 (aim ~650)"}}
    return output.write_bench("runtime", data)


def _hdr_split_cost(plan, image, databases, methods, repeats) -> dict | None:
    """The spreadlets pass again without its HDR-highlight check and dense splat (``hdr_ratio =
    None``, runtime_cl/spreadlets/highlights.py), in the same run: what that fix costs (its
    timing; None where the plan has no single-database spreadlets pass)."""
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase
    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    from lab.runtime_passes import frame_of, runtime_camera

    paths = [r.path for model, r in databases.items() if model != FAR_FIELD]
    if "spreadlets" not in methods or "spreadlets" not in plan.runtime_passes or len(paths) != 1:
        return None
    name, options = plan.pass_run("spreadlets")
    db = SpreadletDatabase.load(paths[0])
    _, timing = run_pass(name, frame_of(image, db=db), runtime_camera(image), db, runs=repeats,
                         **dict(options, hdr_ratio=None))
    return timing.to_json()
