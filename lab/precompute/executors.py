"""Where the cells of a precompute job run: this process, local worker processes, or Dask.

The machinery (worker processes, Dask, threads per worker) is :mod:`lab.parallel`'s; this module
says what a cell task is on each. Every runner takes cells and yields each finished cell's
summary (cell, rays, timings) as it completes, after its shard is on disk. Results do not depend
on the executor (see :mod:`.cell`); the order cells finish in does not matter because shards are
consolidated in cell order.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Iterable, Iterator

from lab.parallel import Executor, set_threads

from .cell import CellJob, build_cell, run_cell
from .shards import summary, write_shard

__all__ = ["run_serial", "run_cells"]


def run_serial(model, folder: Path, cells: Iterable[int], threads: int | None = None) -> Iterator[dict]:
    """Compute ``cells`` one after the other in this process, with the model already built."""
    set_threads(threads)
    for cell in cells:
        shard = build_cell(model, cell)
        write_shard(folder, shard)
        yield summary(shard)


def run_cells(executor: Executor, model, code: str, folder: Path, cells: list[int]) -> tuple[str, Iterator[dict]]:
    """Compute ``cells`` where ``executor`` says; returns (``"serial"|"processes"|"dask"``, summaries).

    Local workers write their shards themselves; Dask workers send them back to this process,
    which writes them (workers need not share its file system). Dask re-runs the cells of a
    worker that dies; a dead local worker stops the job with the shards kept.
    """
    kind = executor.where(len(cells))
    if kind == "serial":
        return kind, run_serial(model, folder, cells, executor.threads)
    job = CellJob(model.name, model.config, code, executor.worker_threads())
    if kind == "processes":
        results = executor.map(partial(run_cell, job, folder=str(folder)), cells, "precompute",
                               f"finished shards are kept in {folder}")
        return kind, _summaries(results)
    return kind, _summaries(executor.map(partial(run_cell, job, folder=None), cells), folder)


def _summaries(results, folder: Path | None = None) -> Iterator[dict]:
    """The summaries of finished cells; with ``folder``, the results are whole shards to write there."""
    try:
        for _, result in results:
            if folder is not None:
                write_shard(folder, result)
                result = summary(result)
            yield result
    finally:
        results.close()
