"""``splatlab bench``: benchmarks written as JSON under ``reports/bench/``.

Methods are compared as ratios measured in the same run (the machine is shared and noisy).
"""
from __future__ import annotations

import json
import time
from datetime import datetime, timezone
from pathlib import Path

from runtime_cl.atomic_file import atomic_path

from .paths import REPORTS
from .report.machine import machine_info

BENCH_DIR = REPORTS / "bench"


def _write(name: str, data: dict) -> Path:
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    data = dict(data, benchmark=name, created=stamp, machine=machine_info())
    path = BENCH_DIR / f"{name}-{stamp}.json"
    for target in (path, BENCH_DIR / f"{name}-latest.json"):
        with atomic_path(target) as tmp:
            tmp.write_text(json.dumps(data, indent=2))
    return path


def bench_runtime(scene_path, repeats: int) -> Path:
    """Spreadlets vs Splat vs Filter on a scene: time, SSIM, kernel throughput, ratios."""
    from runtime_cl.psf.database import SpreadletDatabase
    from runtime_cl.coords.maps import psf_coords
    from runtime_cl.spreadlets.renderer import Renderer
    from runtime_cl.camera.thin_lens import ThinLens

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


# What a model needs beyond its defaults for a benchmark: CoC and motion ranges are the scene's to
# decide; 250 px is the demo scene's largest CoC (1024^2, 85 mm at f/1.4). Combined splits the
# same 512^2 PSF image between CoC (125 px) and motion (250 px long).
BENCH_TABLES = {"simple_lens": {"max_coc_px": 250.0}, "stylized": {"max_coc_px": 250.0},
                "combined": {"max_coc_px": 125.0, "max_motion_px": 250.0}}


def _bench_models(models) -> list[str]:
    from .errors import UserError
    from .psf_tracing.models import model_names

    known = model_names()
    if models is None:
        return known
    names = list(dict.fromkeys(m.strip() for m in str(models).split(",") if m.strip()))
    unknown = [m for m in names if m not in known]
    if unknown or not names:
        raise UserError(f"--models {models!r}: unknown model(s) {unknown}; registered models are {known}")
    return names


def _bench_model(name: str, table: dict, repeats: int, build: bool, workers: int) -> dict:
    """One model: tracing M rays/s, then its database build (wall time, Table 1 row, atlas) or,
    with ``build=False``, the sparsify time of its largest PSF."""
    from runtime_cl.psf.database import SpreadletDatabase

    from .config import to_table
    from .errors import UserError
    from .precompute import precompute
    from .precompute.cell import landed_rays
    from .psf_tracing.benchmark import measure_throughput
    from .psf_tracing.models import load_model
    from .report.atlas import write_atlas
    from .report.table1 import table1_row
    from .sparsify.spreadlets import sparsify

    try:
        model = load_model(name, table, f"bench precompute {name}")
    except UserError as exc:
        return {"error": str(exc)}
    entry = {"config": to_table(model.config), "trace": measure_throughput(model, repeats=repeats).to_json()}
    if not build:  # the build's totals say the same for every cell
        cell = model.grid.size - 1
        traced = model.trace_checked(cell)
        t = time.perf_counter()
        sp = sparsify(traced.psf, density=model.config.density, seed=cell, rays=landed_rays(traced))
        entry["sparsify_largest"] = {"cell": cell, "rays": traced.n_rays,
                                     "seconds": time.perf_counter() - t, **sp.stats}
        return entry
    r = precompute(model, force=True, workers=workers)
    db = SpreadletDatabase.load(r.path, expect_model=name)
    entry["build"] = {"seconds": r.seconds, "workers": workers, "executor": r.executor, "cells": r.cells,
                      "rays": r.rays, "trace_seconds": r.trace_seconds,
                      "sparsify_seconds": r.sparsify_seconds, "path": str(r.path)}
    entry["table1"] = table1_row(db)
    entry["atlas"] = str(write_atlas(db, BENCH_DIR / "atlas" / name).png)
    return entry


def bench_precompute(repeats: int, models=None, build: bool = True, workers: int = 1,
                     tables: dict | None = None) -> Path:
    """Per registered PSF model: tracing M rays/s, and the wall time to build its database.

    Parameters
    ----------
    repeats : int
        Timed traces per model after a warm-up; the best counts (the machine is shared).
    models : str, optional
        Comma-separated model names (default: every registered model).
    build : bool, default True
        Also build each database at default settings (minutes per model), with LSR18 Table 1
        (``reports/bench/table1.md``) and a PSF atlas per model (``reports/bench/atlas/``).
    workers : int, default 1
        Local worker processes for the builds.
    tables : dict, optional
        Model name -> settings replacing :data:`BENCH_TABLES` (tests use small ones).
    """
    from .precompute.executors import check_workers
    from .report.table1 import write_table1

    check_workers(workers)
    names = _bench_models(models)
    tables = BENCH_TABLES if tables is None else tables
    results = {name: _bench_model(name, dict(tables.get(name, {})), repeats, build, workers)
               for name in names}
    rows = [r["table1"] for r in results.values() if "table1" in r]
    data = {"models": results, "repeats": repeats,
            "targets": {"trace_Mrays_per_s": ">= 35 for physical_lens (LSR18: 700 M rays per PSF in "
                                             "~20 s on a GPU)"}}
    if rows:
        data["table1_markdown"] = str(write_table1(rows, BENCH_DIR)[0])
    return _write("precompute", data)


def bench_rotation(repeats: int, size: int = 512, r_max: float = 50.0) -> Path:
    """The cost of per-pixel PSF rotation (:func:`runtime_cl.bench.rotation`): spreadlets (and
    the pixel-by-pixel unrotated kernel) with a constant and a per-pixel angle over without, as
    kernel-time ratios measured in the same run."""
    from runtime_cl.bench import rotation

    return _write("rotation", rotation(size, size, r_max=r_max, repeats=repeats))


def run_bench(what: str, scene_path, repeats: int, models=None, build: bool = True,
              workers: int = 1) -> list[Path]:
    from .errors import UserError

    if not (isinstance(repeats, int) and repeats >= 1):
        raise UserError(f"--repeats {repeats}: must be an integer >= 1")
    out = []
    if what in ("precompute", "all"):
        out.append(bench_precompute(repeats, models, build, workers))
    if what in ("runtime", "all"):
        out.append(bench_runtime(scene_path, repeats))
    if what == "rotation":
        out.append(bench_rotation(repeats))
    return out
