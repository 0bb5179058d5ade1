"""A precompute job: light-trace every cell of a PSF model, sparsify it, write the database.

Each cell's result is written as its own shard, atomically (:mod:`.shards`), under
``<cache>/precompute/<model>-<hash>/``: an interrupted job resumes with the missing shards and
never leaves a corrupt file. Cells run in this process, in local worker processes or on a Dask
cluster (:mod:`.executors`), heaviest first (fewest stragglers at the end); the database is the
same bitwise either way. The final step consolidates the shards in cell order into one database
(:mod:`.consolidate`), named by content hash (:mod:`.naming`): an unchanged configuration is
reused, a changed one rebuilt.
"""
from __future__ import annotations

import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from runtime_cl.atomic_file import made_folder, remove_stale_temps
from runtime_cl.errors import InputError
from runtime_cl.psf.database import SpreadletDatabase

from lab.parallel import Executor

from .consolidate import consolidate
from .executors import run_cells
from .naming import content_hash, database_path, shard_dir, source_digest
from .shards import shard_ok

__all__ = ["PrecomputeResult", "precompute"]


@dataclass
class PrecomputeResult:
    """What a precompute job did.

    Attributes
    ----------
    path : Path
        The database file (under ``<cache>/db/``).
    reused : bool
        True when a database with this content hash existed and nothing was computed.
    seconds : float
        Wall time of the whole call.
    rays : int
        Rays traced by this call (0 when reused; cells resumed from shards are not counted).
    trace_seconds, sparsify_seconds : float
        Time spent tracing and sparsifying, summed over every worker.
    cells : int
        Cells computed by this call (the rest were reused shards).
    executor : str
        ``"serial"``, ``"processes"`` or ``"dask"``.
    """

    path: Path
    reused: bool
    seconds: float
    rays: int
    trace_seconds: float
    sparsify_seconds: float
    cells: int = 0
    executor: str = "serial"


def _reusable(out: Path, name: str) -> bool:
    if not out.exists():
        return False
    try:
        SpreadletDatabase.load(out, expect_model=name)  # validates the checksum
    except InputError:
        return False  # a damaged cache entry: build it again (the new file replaces it atomically)
    return True


def precompute(model, *, force: bool = False, progress: bool = True, workers: int = 1,
               scheduler: str | None = None, threads: int | None = None) -> PrecomputeResult:
    """Build (or reuse) the spreadlet database of ``model``.

    Parameters
    ----------
    model : PSFModel
        A configured, registered model (``lab.psf_tracing.models.load_model``).
    force : bool, default False
        Rebuild even if a database with this content hash exists; discard old shards.
    progress : bool, default True
        Show a progress bar (rays done of the job's total, rays/s, ETA) on stderr.
    workers : int, default 1
        Local worker processes; 1 computes in this process.
    scheduler : str, optional
        Dask scheduler address (``tcp://HOST:PORT``): run the cells on that cluster instead.
    threads : int, optional
        Dr.Jit threads per worker process (default: cores / workers locally, cores of the host /
        task slots on the host on Dask, all cores for a single local process).

    Returns
    -------
    PrecomputeResult

    Raises
    ------
    UserError
        Bad ``workers``, ``scheduler`` or ``threads`` (before anything is traced), an
        unreachable scheduler, or a cell the model rejects.
    """
    t_start = time.perf_counter()
    executor = Executor(workers, scheduler, threads)
    code = source_digest(model.name)
    digest = content_hash(model.name, model.config, code)
    out = database_path(model.name, digest)
    if not force and _reusable(out, model.name):
        return PrecomputeResult(out, True, time.perf_counter() - t_start, 0, 0.0, 0.0)
    folder = shard_dir(model.name, digest)
    if force:
        shutil.rmtree(folder, ignore_errors=True)
    remove_stale_temps(out.parent)     # a killed writer's half database
    with made_folder(folder):          # removed again if the job fails before its first shard
        remove_stale_temps(folder)
        rays, trace_s, sparsify_s, todo, executor_kind = _run(model, executor, code, folder, progress)
        consolidate(model, digest, folder, out)
    shutil.rmtree(folder, ignore_errors=True)  # the database now holds everything
    return PrecomputeResult(out, False, time.perf_counter() - t_start, rays, trace_s, sparsify_s,
                            len(todo), executor_kind)


def _run(model, executor, code: str, folder: Path, progress: bool) -> tuple:
    """Trace and sparsify the cells without a shard in ``folder``, heaviest first; (rays,
    trace seconds, sparsify seconds, the cells computed, the executor kind)."""
    n = model.grid.size
    cost = [model.rays_for_cell(c) for c in range(n)]
    todo = sorted((c for c in range(n) if not shard_ok(folder, c)), key=lambda c: -cost[c])
    done_cost = sum(cost) - sum(cost[c] for c in todo)
    rays = 0
    trace_s = sparsify_s = 0.0
    with executor, tqdm(total=sum(cost), initial=done_cost, unit="ray", unit_scale=True,
                        dynamic_ncols=True, desc=f"precompute {model.name}", disable=not progress) as bar:
        bar.set_postfix_str(f"PSF {n - len(todo)}/{n}")
        executor_kind, cells_iter = run_cells(executor, model, code, folder, todo)
        try:
            for k, s in enumerate(cells_iter, start=1):
                rays += s["rays"]
                trace_s += s["trace_s"]
                sparsify_s += s["sparsify_s"]
                bar.update(cost[s["cell"]])
                bar.set_postfix_str(f"PSF {n - len(todo) + k}/{n}", refresh=False)
        finally:
            cells_iter.close()
    return rays, trace_s, sparsify_s, todo, executor_kind
