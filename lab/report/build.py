"""Assemble a scene report: metrics per method, PNGs, the accuracy/time plot, regressions."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.timing import COLUMNS

from .images import save_heatmap, save_render
from .machine import machine_info
from .metrics import TONEMAP, error_map, noise_corrected_mse, psnr, ssim
from .insets import write_insets
from .pareto import front_sentence
from .sweep_plots import accuracy_time_plot
from .regress import compare
from ..runtime_passes import TIMED_MIN_MS, TIMED_RUNS

ERROR_SCALE = 4.0  # error maps show 4 x |difference| so small errors are visible


def _database_summary(result) -> dict:
    db = SpreadletDatabase.load(result.path)
    info = db.info()
    info.update(path=str(result.path), reused=result.reused, build_seconds=round(result.seconds, 2),
                rays=result.rays, trace_seconds=round(result.trace_seconds, 2),
                sparsify_seconds=round(result.sparsify_seconds, 2))
    if result.trace_seconds > 0:
        info["trace_Mrays_per_s"] = round(result.rays / result.trace_seconds / 1e6, 1)
    for key in ("ssim", "l1", "sparsity"):
        if key in db.stats:
            info[f"mean_{key}"] = float(np.mean(db.stats[key]))
    return info


def timing_reference(methods: dict):
    """The method whose pass other times are compared against (``timing_reference``), or None."""
    from runtime_cl.passes import get_pass, pass_names

    known = set(pass_names())
    return next((name for name, m in methods.items()
                 if m.get("pass") in known and get_pass(m["pass"]).timing_reference), None)


def assemble_report(scene, plan, image, reference, ref_info, databases, results, out_dir,
                    baseline=None, reference_b=None) -> dict:
    """Write the images of one run into ``out_dir`` and return the report.json dictionary.

    ``reference`` None (a plan with no reference): the methods' images and times, SSIM and PSNR None.

    ``reference_b``: a second reference with an independent seed; each method then also gets its
    noise-corrected MSE (:func:`~lab.report.metrics.noise_corrected_mse`) and the PSNR of it."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if reference is not None:
        save_render(reference, out_dir / "reference.png")
    save_render(image.rgb, out_dir / "input.png")
    methods, rgbs = {}, {}
    for name, (rendered, timing) in results.items():
        rgb = rendered[..., :3] if rendered.shape[2] >= 3 else np.repeat(rendered, 3, axis=2)
        rgbs[name] = rgb
        save_render(rgb, out_dir / f"{name}.png")
        if reference is None:   # nothing to score against (an expressive focal surface): the image alone
            methods[name] = dict(timing, ssim=None, psnr=None, image=f"{name}.png")
            continue
        save_heatmap(error_map(rgb, reference) * ERROR_SCALE, out_dir / f"{name}_error.png", vmax=1.0)
        methods[name] = dict(timing, ssim=ssim(rgb, reference), psnr=psnr(rgb, reference),
                             image=f"{name}.png", error_image=f"{name}_error.png", error_scale=ERROR_SCALE)
        if reference_b is not None:
            mse = noise_corrected_mse(rgb, reference, reference_b)
            methods[name].update(noise_corrected_mse=mse,
                                 noise_corrected_psnr=float(-10.0 * np.log10(mse)) if mse > 0 else None)
    plots = {}
    if len(methods) > 1 and reference is not None:
        points = [dict(m, method=name) for name, m in methods.items()]
        accuracy_time_plot(points, out_dir / "accuracy_vs_time.png", f"{scene.name}: accuracy vs time, per method")
        plots["accuracy vs time"] = {"image": "accuracy_vs_time.png",
                                     "sentences": [front_sentence(points, "ssim", "SSIM", 3),
                                                   front_sentence(points, "psnr", "PSNR", 2, " dB")]}
    reference_method = timing_reference(methods)
    if reference_method is not None:
        ref_ms = methods[reference_method]["time_ms"]
        for m in methods.values():
            m["speedup_vs_timing_reference"] = ref_ms / m["time_ms"] if m["time_ms"] else None
    report = {
        "schema": 1,
        "scene": {"name": scene.name, "path": scene.source, "resolution": list(scene.info.resolution),
                  "camera": image.camera, "guard_px": image.guard_px},
        "plan": {"effects": plan.effects, "psf_models": list(plan.psf_models),
                 "runtime_passes": list(plan.runtime_passes),
                 "pass_options": {label: plan.pass_run(label)[1] for label in plan.runtime_passes
                                  if plan.pass_run(label)[1]},
                 "skipped": [f"{s.name}: {s.detail}" for s in plan.skipped]},
        "tonemap": TONEMAP,
        "metrics": "SSIM: skimage structural_similarity, gaussian sigma 1.5, data_range 1, channel_axis 2; "
                   "PSNR data_range 1; both on the tonemap",
        "timing": dict(COLUMNS, runs=f"timed calls after one warm-up call (at least {TIMED_RUNS}, more until they add up to "
                                    f"{TIMED_MIN_MS:.0f} ms); every figure is their median"),
        "images": ({"reference": "reference.png"} if reference is not None else {}) | {"input (pinhole)": "input.png"},
        "plots": plots,
        "insets": write_insets(reference, rgbs, out_dir) if rgbs and reference is not None else None,
        "methods": methods,
        "timing_reference": reference_method,
        "database": {name: _database_summary(r) for name, r in databases.items()},
        "reference": ref_info,
        "settings": {"render": scene.to_dict()["render"], "psf": scene.psf},
        "machine": machine_info(),
    }
    if baseline is not None:
        report["regressions"] = compare(baseline, report)
    return report
