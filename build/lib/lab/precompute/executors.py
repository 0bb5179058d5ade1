"""Where the cells of a precompute job run: this process, local worker processes, or Dask.

Every executor takes cells and yields each finished cell's summary (cell, rays, timings) as it
completes, after its shard is on disk. At most ``2 x slots`` cells are in flight, so memory stays
bounded however many cells a job has. Results do not depend on the executor (see
:mod:`.cell`); the order cells finish in does not matter because shards are consolidated in
cell order.

Threads: Dr.Jit runs one thread pool per process, by default on every core. ``N`` local
workers each get ``max(1, cores // N)`` Dr.Jit threads so they do not oversubscribe the CPU;
on Dask every worker process gets ``max(1, cores of its host // worker processes on its host)``
unless ``threads`` is given. Start Dask workers with one task slot each (``dask worker ADDRESS
--nthreads 1 --nworkers K``): tasks sharing a process also share its one Dr.Jit pool.
"""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import re
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Iterable, Iterator

from lab.errors import UserError

from .cell import CellJob, build_cell, run_cell, set_threads
from .shards import summary, write_shard

__all__ = ["usable_cores", "check_workers", "check_scheduler", "run_serial", "run_processes",
           "connect", "dask_threads", "run_dask", "DASK_TIMEOUT_S"]

DASK_TIMEOUT_S = 20.0
_ADDRESS = re.compile(r"^(tcp|tls|inproc|ws|wss|ucx)://[^\s:/]+(:\d{1,5})?/?$")


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers) -> int:
    """``--workers`` validated: an integer >= 1."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise UserError(f"--workers {workers!r}: must be an integer >= 1 (local worker processes)")
    return workers


def check_scheduler(address) -> str:
    """``--scheduler`` validated: a Dask address such as ``tcp://HOST:PORT``."""
    if not isinstance(address, str) or not _ADDRESS.match(address):
        raise UserError(f"--scheduler {address!r}: expected a Dask scheduler address such as "
                        "tcp://10.0.0.5:8786 (start one with `dask scheduler`)")
    return address


def run_serial(model, folder: Path, cells: Iterable[int], threads: int | None = None) -> Iterator[dict]:
    """Compute ``cells`` one after the other in this process."""
    set_threads(threads)
    for cell in cells:
        shard = build_cell(model, cell)
        write_shard(folder, shard)
        yield summary(shard)


def _windowed(submit, cells: Iterable[int], window: int, wait_some) -> Iterator:
    """Keep at most ``window`` submissions in flight; yield finished futures as they come."""
    pending = set()
    for cell in cells:
        pending.add(submit(cell))
        if len(pending) >= window:
            done, pending = wait_some(pending)
            yield from done
    while pending:
        done, pending = wait_some(pending)
        yield from done


def run_processes(job: CellJob, folder: Path, cells: Iterable[int], workers: int) -> Iterator[dict]:
    """Compute ``cells`` in ``workers`` local processes (spawned: Dr.Jit's threads do not fork);
    each worker writes its shards itself."""
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))

    def wait_some(pending):
        return cf.wait(pending, return_when=cf.FIRST_COMPLETED)

    try:
        for future in _windowed(lambda c: pool.submit(run_cell, job, c, str(folder)), cells,
                                2 * workers, wait_some):
            yield future.result()
    except BrokenProcessPool:
        raise UserError(f"precompute: a worker process died (out of memory or killed); finished "
                        f"shards are kept in {folder}: run the command again to resume, with fewer "
                        "--workers if memory is short") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _cores() -> int:  # runs on a Dask worker
    return usable_cores()


def dask_threads(client) -> dict:
    """Dr.Jit threads per Dask worker address: its host's cores over the worker processes on that
    host (a process's task slots share its one Dr.Jit thread pool)."""
    workers = client.scheduler_info(n_workers=-1)["workers"]
    cores = client.run(_cores)
    processes: dict = {}
    for info in workers.values():
        processes[info["host"]] = processes.get(info["host"], 0) + 1
    return {addr: max(1, cores.get(addr, 1) // processes[info["host"]]) for addr, info in workers.items()}


def connect(address: str, timeout: float | None = None):
    """A Dask client for ``address`` with at least one worker; UserError naming the fix otherwise.

    ``timeout`` (seconds) bounds connecting and waiting for a worker (default :data:`DASK_TIMEOUT_S`).
    """
    timeout = DASK_TIMEOUT_S if timeout is None else timeout
    try:
        from distributed import Client
    except ImportError:
        raise UserError("--scheduler needs Dask distributed: pip install 'dask[distributed]'") from None
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise UserError(f"--scheduler {address}: cannot reach the Dask scheduler ({exc}); start it "
                        f"with `dask scheduler` and workers with `dask worker {address} --nthreads 1`") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        client.close()
        raise UserError(f"--scheduler {address}: no Dask worker joined within {timeout:.0f} s; start "
                        f"some with `dask worker {address} --nthreads 1`") from None
    return client


def run_dask(job: CellJob, folder: Path, cells: Iterable[int], client) -> Iterator[dict]:
    """Compute ``cells`` on a Dask cluster; shards come back to this process, which writes them
    (workers need not share its file system). Dask re-runs the cells of a worker that dies."""
    from distributed import as_completed

    if job.threads is None:
        job = CellJob(job.model, job.config, job.code, dask_threads(client))
    slots = sum(w["nthreads"] for w in client.scheduler_info(n_workers=-1)["workers"].values())
    window = 2 * max(1, slots)
    todo = iter(cells)
    live = {}
    finished = as_completed(loop=client.loop)

    def top_up():
        while len(live) < window:
            cell = next(todo, None)
            if cell is None:
                return
            future = client.submit(run_cell, job, cell, None, pure=False)
            live[future.key] = future
            finished.add(future)

    try:
        top_up()
        for future in finished:
            del live[future.key]
            try:
                shard = future.result()
            except ImportError as exc:
                raise UserError(f"a Dask worker cannot import splatlab ({exc}); install the same "
                                "splatlab version in every worker's environment") from None
            future.release()
            write_shard(folder, shard)
            yield summary(shard)
            top_up()
    finally:
        if live:
            client.cancel(list(live.values()))
