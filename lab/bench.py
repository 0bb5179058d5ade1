"""``splatlab bench``: benchmarks written as JSON under ``reports/bench/``.

Methods are compared as ratios measured in the same run (the machine is shared and noisy).
"""
from __future__ import annotations

import json
import os
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from .precompute import ROOT
from .report.machine import machine_info

BENCH_DIR = ROOT / "reports" / "bench"


def _write(name: str, data: dict) -> Path:
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    data = dict(data, benchmark=name, created=stamp, machine=machine_info())
    path = BENCH_DIR / f"{name}-{stamp}.json"
    for target in (path, BENCH_DIR / f"{name}-latest.json"):
        fd, tmp = tempfile.mkstemp(dir=BENCH_DIR, prefix=f".{target.name}.")
        with os.fdopen(fd, "w") as fh:
            json.dump(data, fh, indent=2)
        os.replace(tmp, target)
    return path


def bench_runtime(scene_path, repeats: int) -> Path:
    """Spreadlets vs Splat vs Filter on a scene: time, SSIM, kernel throughput, ratios."""
    from runtime_cl.database import SpreadletDatabase
    from runtime_cl.psf_coords import psf_coords
    from runtime_cl.render import Renderer
    from runtime_cl.thin_lens import ThinLens

    from .pipeline import build_databases, inputs_and_reference, load_scene_and_plan, run_method
    from .report.metrics import ssim

    scene, plan = load_scene_and_plan(scene_path)
    if "simple_lens" not in plan.psf_models:
        from .errors import UserError

        raise UserError(f"{scene_path}: `bench runtime` needs a thin-lens scene (its plan has no simple_lens)")
    image, reference, _ = inputs_and_reference(scene, plan)
    result = build_databases(scene, plan, image)["simple_lens"]
    db = SpreadletDatabase.load(result.path, expect_model="simple_lens")
    coords = psf_coords(ThinLens.from_json(image.camera), image.depth, db)
    renderer = Renderer(db)
    methods = {}
    for method in plan.runtime_passes:
        rendered, timing = run_method(renderer, image, coords, method, repeats)
        timing["ssim"] = ssim(rendered[..., :3], reference)
        methods[method] = timing
    sp = methods["spreadlets"]
    splat_ms = sp["kernel_ms"]
    data = {
        "scene": str(scene_path), "resolution": list(scene.info.resolution), "repeats": repeats,
        "database": {"path": str(result.path), **db.info()},
        "methods": methods,
        "ratios": {
            "splat_time_over_spreadlets": methods["splat"]["time_ms"] / sp["time_ms"],
            "filter_time_over_spreadlets": methods["filter"]["time_ms"] / sp["time_ms"],
            "ssim_spreadlets_minus_splat": sp["ssim"] - methods["splat"]["ssim"],
        },
        "throughput": {
            "spreadlet_kernel_M_per_s": sp["counts"]["spreadlets"] / (splat_ms / 1e3) / 1e6,
            "dense_splat_kernel_M_per_s": methods["splat"]["counts"]["dense_pixels"]
            / (methods["splat"]["kernel_ms"] / 1e3) / 1e6,
        },
        "targets": {"splat_time_over_spreadlets": ">= 10", "ssim_spreadlets_minus_splat": ">= -0.02",
                    "spreadlet_kernel_M_per_s": ">= 300 (aim ~650)"},
    }
    return _write("runtime", data)


def bench_precompute(repeats: int) -> Path:
    """PSF tracing throughput (M rays/s) and sparsification time per PSF at LSR18's defaults."""
    from .psf_tracing.benchmark import measure_throughput
    from .psf_tracing.models import load_model
    from .sparsify.spreadlets import sparsify

    model = load_model("simple_lens", {"max_coc_px": 250.0})
    trace = measure_throughput(model, repeats=repeats).to_json()
    sparsify_s = {}
    for cell in (model.grid.size // 2, 3 * model.grid.size // 4, model.grid.size - 1):
        traced = model.trace_checked(cell)
        t = time.perf_counter()
        sp = sparsify(traced.psf, seed=cell, rays=traced.n_rays)
        radius = round(model.boxes[cell].centre[0], 1)
        sparsify_s[f"r={radius}px"] = {"seconds": time.perf_counter() - t, **sp.stats}
    data = {"trace": trace, "sparsify": sparsify_s,
            "targets": {"trace_Mrays_per_s": ">= 35 (LSR18: 700 M rays per PSF in ~20 s on a GPU)"}}
    return _write("precompute", data)


def run_bench(what: str, scene_path, repeats: int) -> list[Path]:
    from .errors import UserError

    if not (isinstance(repeats, int) and repeats >= 1):
        raise UserError(f"--repeats {repeats}: must be an integer >= 1")
    out = []
    if what in ("precompute", "all"):
        out.append(bench_precompute(repeats))
    if what in ("runtime", "all"):
        out.append(bench_runtime(scene_path, repeats))
    return out
