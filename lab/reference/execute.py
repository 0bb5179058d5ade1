"""Run a render job's passes here, in local worker processes or on Dask; cache each, resume.

:func:`run_job` renders the passes of any :class:`~lab.reference.passes.RenderJob` (subclasses
included: it only calls ``job.passes()`` and ``job.render(p)``) where a
:class:`lab.parallel.Executor` says. Each finished pass is written as its own file, atomically
(:mod:`.pass_files`), so an interrupted render resumes with the passes it lacks. The passes are
added to an :class:`~lab.reference.passes.Accumulator` in index order, each read back from its
file as soon as every earlier pass is in: passes that finish early wait on disk, not in memory.
The mean is therefore bitwise the serial render's, whatever ran where (the pass images
themselves do not depend on the thread count, see :mod:`.passes`), on workers with the same CPU
and the same splatlab, Mitsuba and Dr.Jit.

A worker process loads the job's Mitsuba scene once: every task of one run carries the job with
the same token, and a process keeps the job it last unpickled under that token
(:class:`PassTask`). A worker whose rendering code differs from this process's refuses the task.
"""
from __future__ import annotations

import tempfile
import threading
import uuid
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from tqdm import tqdm

from runtime_cl.atomic_file import made_folder

from ..cache_key import PROJECT, cached_code_digest, code_digest
from ..errors import UserError
from ..parallel import Executor, set_threads, threads_here
from .pass_files import pass_ok, read_pass, write_pass
from .passes import Accumulator

__all__ = ["run_job", "PassTask"]

_LOADED: dict = {}                # token -> the job this process unpickled last (its scene stays loaded)
_RENDERING = threading.Lock()     # one render at a time per process: they would share its Dr.Jit pool


def _code_roots(job) -> tuple:
    """The project modules that define ``job``'s class and its bases (their imports make the render)."""
    return tuple(sorted({c.__module__ for c in type(job).__mro__ if c.__module__.partition(".")[0] in PROJECT}))


class PassTask:
    """Render one pass of ``job`` (picklable; what the executor calls with each pass).

    Parameters
    ----------
    job : RenderJob
    token : str
        Names this run: a worker process reuses the job (and its loaded scene) it unpickled for it.
    code : str
        Digest of the job's rendering code in the submitting process.
    folder : str, optional
        Write the pass image there and return None (workers that share the file system); None
        returns the image (Dask workers, possibly on other machines).
    threads : int or dict, optional
        Dr.Jit threads (:meth:`lab.parallel.Executor.worker_threads`).

    A task unpickled in another process (``shipped``) compares that process's code with ``code``.
    """

    def __init__(self, job, token: str, code: str, folder: str | None, threads=None):
        self.job, self.token, self.code, self.folder, self.threads = job, token, code, folder, threads
        self.shipped = False

    def __setstate__(self, state: dict) -> None:
        job = _LOADED.get(state["token"])
        if job is None:
            _LOADED.clear()  # a new run: let the previous job's scene go
            job = _LOADED[state["token"]] = state["job"]
        self.__dict__.update(state, job=job, shipped=True)

    def __call__(self, p) -> np.ndarray | None:
        mine = cached_code_digest(_code_roots(self.job)) if self.shipped else self.code
        if mine != self.code:
            import socket

            raise UserError(f"render worker on {socket.gethostname()}: its splatlab code (digest {mine[:12]}) "
                            f"differs from the job's ({self.code[:12]}); install the same splatlab version "
                            "on every worker and restart them")
        set_threads(threads_here(self.threads))
        with _RENDERING:
            image = self.job.render(p)
        if self.folder is None:
            return image
        write_pass(Path(self.folder), self.job, p, image)
        return None


@contextmanager
def _pass_folder(cache_dir):
    if cache_dir is None:
        with tempfile.TemporaryDirectory(prefix="splatlab-passes-") as tmp:
            yield Path(tmp)
    else:
        with made_folder(cache_dir) as folder:
            yield folder


def run_job(job, executor: Executor | None = None, cache_dir=None, progress: bool = True, stats: bool = False):
    """Render every pass of ``job`` where ``executor`` says and average them in pass order.

    Parameters
    ----------
    job : RenderJob
        Any render job: its ``passes()``, ``render(p)`` and ``desc`` are used.
    executor : lab.parallel.Executor, optional
        This process (default), ``Executor(workers=N)`` or ``Executor(scheduler="tcp://...")``.
        The caller closes it (a Dask client is connected only when a pass must be rendered).
    cache_dir : path, optional
        The job's pass folder: finished passes found there are reused, new ones are written there
        and kept (the caller removes the folder once the result is stored). It must belong to this
        job's content, e.g. be under the scene's render key (:mod:`.pass_files`). None renders in a
        temporary folder, removed at the end.
    progress : bool, default True
        A tqdm bar on stderr, in samples per pixel (cached passes count as done).
    stats : bool, default False
        Return the :class:`~lab.reference.passes.Accumulator` itself (its mean, channel weights and
        the variance of the mean from the passes' spread) instead of the mean.

    Returns
    -------
    (H, W, 3) float32
        The per-channel weighted mean of the passes, bitwise the same as ``job.run()`` (or the
        Accumulator, with ``stats``).

    Raises
    ------
    UserError
        A local worker died or the Dask cluster is unreachable (finished passes are kept); a
        pass's own error (e.g. Mitsuba's) is raised as is, after the passes already finished are
        stored.
    """
    executor = Executor() if executor is None else executor
    passes = job.passes()
    with _pass_folder(cache_dir) as folder:
        ready = {p.index for p in passes if pass_ok(folder, job, p)}
        todo = [p for p in passes if p.index not in ready]
        kind = executor.where(len(todo))
        threads = executor.worker_threads() if kind != "serial" else executor.threads
        task = PassTask(job, uuid.uuid4().hex, code_digest(_code_roots(job)),
                        None if kind == "dask" else str(folder), threads)
        acc = Accumulator()

        def add_ready() -> None:
            while acc.count < len(passes) and passes[acc.count].index in ready:
                p = passes[acc.count]
                acc.add(p, read_pass(folder, job, p))

        with tqdm(total=sum(p.spp for p in passes), initial=sum(p.spp for p in passes if p.index in ready),
                  unit="spp", desc=job.desc, disable=not progress, leave=False, dynamic_ncols=True) as bar:
            bar.set_postfix_str(f"{kind}, {len(ready)}/{len(passes)} passes cached", refresh=False)
            add_ready()
            results = executor.map(task, todo, job.desc, f"finished passes are kept in {folder}")
            try:
                for p, image in results:
                    if image is not None:
                        write_pass(folder, job, p, image)
                    ready.add(p.index)
                    bar.update(p.spp)
                    add_ready()
            finally:
                results.close()
        return acc if stats else acc.mean()
