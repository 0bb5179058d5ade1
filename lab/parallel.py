"""Where independent tasks run: this process, local worker processes, or a Dask cluster.

An :class:`Executor` says where (``--workers N`` or ``--scheduler ADDRESS``, checked when it is
made) and :meth:`Executor.map` calls a picklable ``fn`` on each item there, yielding ``(item,
result)`` as each finishes. At most ``2 x slots`` tasks are in flight, so memory stays bounded
however many items a job has; a caller that needs an order (precompute shards, render passes)
restores it itself. Precompute cells (:mod:`lab.precompute.executors`) and reference render
passes (:mod:`lab.reference.execute`) both run through it.

Threads: Dr.Jit (and Mitsuba's LLVM variant) runs one thread pool per process, by default on
every core. ``N`` local workers each get ``max(1, cores // N)`` Dr.Jit threads so they do not
oversubscribe the CPU; on Dask every worker process gets ``max(1, cores of its host // worker
processes on its host)`` unless ``threads`` is given (:meth:`Executor.worker_threads`). Start
Dask workers with one task slot each (``dask worker ADDRESS --nthreads 1 --nworkers K``): tasks
sharing a process also share its one Dr.Jit pool.

Local workers are spawned (Dr.Jit's threads do not fork). They ignore Ctrl-C (the parent stops
them) and exit by themselves within :data:`PARENT_POLL_S` when the parent process is gone, even
after a SIGKILL that gave it no chance to stop them, so no idle worker outlives the command.
"""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import re
import signal
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Iterable, Iterator

from lab.errors import UserError

__all__ = ["Executor", "usable_cores", "check_workers", "check_threads", "check_scheduler", "connect",
           "dask_threads", "set_threads", "threads_here", "DASK_TIMEOUT_S", "PARENT_POLL_S"]

DASK_TIMEOUT_S = 20.0
PARENT_POLL_S = 0.25
_ADDRESS = re.compile(r"^(tcp|tls|inproc|ws|wss|ucx)://[^\s:/]+(:\d{1,5})?/?$")
_END = object()  # what next() returns when there are no more items


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers) -> int:
    """``--workers`` validated: an integer >= 1."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise UserError(f"--workers {workers!r}: must be an integer >= 1 (local worker processes), "
                        "e.g. --workers 2")
    return workers


def check_threads(threads) -> int | None:
    """``--threads`` validated: None or an integer >= 1."""
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise UserError(f"--threads {threads!r}: must be an integer >= 1 (Dr.Jit threads per worker)")
    return threads


def check_scheduler(address) -> str:
    """``--scheduler`` validated: a Dask address such as ``tcp://HOST:PORT``."""
    if not isinstance(address, str) or not _ADDRESS.match(address):
        raise UserError(f"--scheduler {address!r}: expected a Dask scheduler address such as "
                        "tcp://10.0.0.5:8786 (start one with `dask scheduler`)")
    return address


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


def set_threads(n: int | None) -> None:
    """Set Dr.Jit's thread pool to ``n`` threads (None: leave it)."""
    if n is None:
        return
    import drjit as dr

    if dr.thread_count() != n:
        dr.set_thread_count(int(n))


def threads_here(threads: int | dict | None) -> int | None:
    """This process's share of :meth:`Executor.worker_threads`: the number, or on a Dask worker its
    entry in the dict (None: keep Dr.Jit's default)."""
    if isinstance(threads, dict):
        try:
            from distributed import get_worker

            return threads.get(get_worker().address)
        except (ImportError, ValueError):
            return None
    return threads


def _worker_start(parent: int) -> None:
    """Initializer of local worker processes: leave Ctrl-C to the parent, and exit as soon as the
    parent is gone (the worker is then re-parented, so ``getppid`` changes)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="splatlab-parent-watch", daemon=True).start()


def _map_here(fn: Callable, items: list) -> Iterator[tuple]:
    for item in items:
        yield item, fn(item)


def _map_processes(fn: Callable, items: list, workers: int, label: str, kept: str) -> Iterator[tuple]:
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=_worker_start, initargs=(os.getpid(),))
    todo, live = iter(items), {}
    try:
        while True:
            while len(live) < 2 * workers and (item := next(todo, _END)) is not _END:
                live[pool.submit(fn, item)] = item
            if not live:
                return
            done, _ = cf.wait(live, return_when=cf.FIRST_COMPLETED)
            for future in done:
                yield live.pop(future), future.result()
    except BrokenProcessPool:
        raise UserError(f"{label}: a worker process died (out of memory or killed); {kept}: run the "
                        "command again to resume, with fewer --workers if memory is short") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _map_dask(fn: Callable, items: list, client) -> Iterator[tuple]:
    from distributed import as_completed

    slots = sum(w["nthreads"] for w in client.scheduler_info(n_workers=-1)["workers"].values())
    window = 2 * max(1, slots)
    todo, live = iter(items), {}
    finished = as_completed(loop=client.loop)

    def top_up():
        while len(live) < window and (item := next(todo, _END)) is not _END:
            future = client.submit(fn, item, pure=False)
            live[future.key] = (future, item)
            finished.add(future)

    try:
        top_up()
        for future in finished:
            _, item = live.pop(future.key)
            try:
                result = future.result()
            except ImportError as exc:
                raise UserError(f"a Dask worker cannot import splatlab ({exc}); install the same "
                                "splatlab version in every worker's environment") from None
            future.release()
            yield item, result
            top_up()
    finally:
        if live:
            client.cancel([f for f, _ in live.values()])


class Executor:
    """Where a job's tasks run: ``workers`` local processes (1: this process) or a Dask cluster.

    Parameters
    ----------
    workers : int, default 1
        Local worker processes; 1 runs every task in this process.
    scheduler : str, optional
        Dask scheduler address (``tcp://HOST:PORT``); exclusive with ``workers > 1``.
    threads : int, optional
        Dr.Jit threads per worker process (default: see :meth:`worker_threads`).

    Raises
    ------
    UserError
        A bad ``workers``, ``scheduler`` or ``threads`` (checked here, before any work).

    Use it as a context manager: the Dask client, connected on first use, is closed on exit.
    """

    def __init__(self, workers: int = 1, scheduler: str | None = None, threads: int | None = None):
        self.workers = check_workers(workers)
        self.scheduler = None if scheduler is None else check_scheduler(scheduler)
        self.threads = check_threads(threads)
        if self.scheduler is not None and workers != 1:
            raise UserError(f"--workers {workers} with --scheduler {scheduler}: choose one; the "
                            "cluster's workers are started with `dask worker`")
        self._client = None

    def __repr__(self) -> str:
        return f"Executor(workers={self.workers}, scheduler={self.scheduler!r}, threads={self.threads})"

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the Dask client, if one was connected."""
        if self._client is not None:
            self._client.close()
            self._client = None

    def client(self):
        """The Dask client (connected on first call; :func:`connect`'s errors)."""
        if self._client is None:
            self._client = connect(self.scheduler)
        return self._client

    def describe(self) -> str:
        """Where tasks run, for reports: "this process", "N local processes" or "Dask at ADDRESS"."""
        if self.scheduler is not None:
            return f"Dask at {self.scheduler}"
        return "this process" if self.workers == 1 else f"{self.workers} local processes"

    def where(self, n_tasks: int) -> str:
        """Where ``n_tasks`` tasks would run: ``"dask"``, ``"processes"`` or ``"serial"`` (one task,
        or none, runs here: a worker process would only add its start-up)."""
        if self.scheduler is not None and n_tasks > 0:
            return "dask"
        return "processes" if self.workers > 1 and n_tasks > 1 else "serial"

    def worker_threads(self) -> int | dict | None:
        """Dr.Jit threads per worker process: ``threads`` if given, else cores / workers for local
        processes, a dict by worker address on Dask (:func:`dask_threads`), None (Dr.Jit's default)
        in this process."""
        if self.threads is not None or (self.scheduler is None and self.workers == 1):
            return self.threads
        if self.scheduler is not None:
            return dask_threads(self.client())
        return max(1, usable_cores() // self.workers)

    def map(self, fn: Callable, items: Iterable, label: str = "job",
            kept: str = "finished work is kept") -> Iterator[tuple]:
        """Call ``fn(item)`` for every item where :meth:`where` says; yield ``(item, result)`` in the
        order they finish.

        Parameters
        ----------
        fn : callable
            Picklable (a module-level function, a ``functools.partial`` of one, or an instance of a
            module-level class) for processes and Dask.
        items : iterable
            Picklable task arguments.
        label, kept : str
            The job's name and what survives a dead local worker, for the error (e.g.
            ``"reference"``, ``"finished passes are kept in DIR"``).

        Raises
        ------
        UserError
            A local worker died, a Dask worker cannot import splatlab, or the scheduler is
            unreachable; a task's own exception is raised as is.
        """
        items = list(items)
        kind = self.where(len(items))
        if kind == "dask":
            return _map_dask(fn, items, self.client())
        if kind == "processes":
            return _map_processes(fn, items, min(self.workers, len(items)), label, kept)
        return _map_here(fn, items)
