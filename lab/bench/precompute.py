"""``splatlab bench precompute``: light-tracing throughput and database builds per PSF model."""
from __future__ import annotations

import time
from pathlib import Path

from lab.bench import output

__all__ = ["BENCH_TABLES", "bench_precompute"]


# What a model needs beyond its defaults for a benchmark: CoC and motion ranges are the scene's to
# decide; 250 px is the demo scene's largest CoC (1024^2, 85 mm at f/1.4). Combined splits the
# same 512^2 PSF image between CoC (125 px) and motion (250 px long).
BENCH_TABLES = {"simple_lens": {"max_coc_px": 250.0}, "stylized": {"max_coc_px": 250.0},
                "combined": {"max_coc_px": 125.0, "max_motion_px": 250.0}}


def _bench_models(models) -> list[str]:
    from lab.errors import UserError
    from lab.psf_tracing.models import model_names

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

    from lab.config import to_table
    from lab.errors import UserError
    from lab.precompute import precompute
    from lab.precompute.cell import landed_rays
    from lab.bench.tracing import measure_throughput
    from lab.psf_tracing.models import load_model
    from lab.report.atlas import write_atlas
    from lab.report.table1 import table1_row
    from lab.sparsify.spreadlets import sparsify

    try:
        model = load_model(name, table, f"bench precompute {name}")
    except UserError as exc:
        return {"error": str(exc)}
    entry = {"config": to_table(model.config), "trace": measure_throughput(model, repeats=repeats).to_json()}
    if not build:  # the build's totals say the same for every cell
        cell = model.grid.size - 1
        traced = model.trace_checked(cell)
        t = time.perf_counter()
        sp = sparsify(traced.psf, density=model.config.density, seed=cell, rays=landed_rays(traced),
                      basis=model.fitted_bases[0], denoise_tau=model.denoise_tau)
        entry["sparsify_largest"] = {"cell": cell, "rays": traced.n_rays,
                                     "seconds": time.perf_counter() - t, **sp.stats}
        return entry
    r = precompute(model, force=True, workers=workers)
    db = SpreadletDatabase.load(r.path, expect_model=name)
    entry["build"] = {"seconds": r.seconds, "workers": workers, "executor": r.executor, "cells": r.cells,
                      "rays": r.rays, "trace_seconds": r.trace_seconds,
                      "sparsify_seconds": r.sparsify_seconds, "path": str(r.path)}
    entry["table1"] = table1_row(db)
    entry["atlas"] = str(write_atlas(db, output.BENCH_DIR / "atlas" / name).png)
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
    from lab.parallel import check_workers
    from lab.report.table1 import write_table1

    check_workers(workers)
    names = _bench_models(models)
    tables = BENCH_TABLES if tables is None else tables
    results = {name: _bench_model(name, dict(tables.get(name, {})), repeats, build, workers)
               for name in names}
    rows = [r["table1"] for r in results.values() if "table1" in r]
    data = {"models": results, "repeats": repeats,
            "targets": {"trace_Mrays_per_s": ">= 35 for physical_lens and volume (LSR18: 700 M rays per "
                                             "PSF in ~20 s on a GPU)"}}
    if rows:
        data["table1_markdown"] = str(write_table1(rows, output.BENCH_DIR)[0])
    return output.write_bench("precompute", data)
