"""The unit of precompute work: trace one cell of a PSF model, sparsify it, make its shard.

:func:`build_cell` does the work on a model instance. :func:`run_cell` is the same work as a
task any executor can ship to another process or machine: it carries the model by name and
configuration (a picklable :class:`CellJob`), rebuilds the model once per process, sets the
Dr.Jit thread count the job chose for that process, and refuses to run if the worker's code
differs from the job's (same hash, different code would silently mix results).

Determinism: the tracer seeds every launch from (seed, cell, launch) and counts hits in
integers; the sparsifier is seeded with ``seed * 1_000_003 + cell``. A cell's shard is therefore
bitwise the same whichever process, thread count or order computes it.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import UserError
from lab.parallel import set_threads, threads_here

from .naming import source_digest
from .shards import summary, write_shard

__all__ = ["dense_crop", "landed_rays", "build_cell", "CellJob", "run_cell"]


def dense_crop(psf: np.ndarray) -> np.ndarray:
    """The PSF cropped to the smallest (2r+1)^2 square around its centre holding every nonzero pixel."""
    c = psf.shape[0] // 2
    ys, xs = np.nonzero(np.any(psf != 0, axis=2))
    r = int(max(np.abs(ys - c).max(), np.abs(xs - c).max())) if len(ys) else 0
    return psf[c - r:c + r + 1, c - r:c + r + 1]


def landed_rays(traced):
    """The hit count behind each channel of a traced PSF (one int if monochrome), for the
    sparsifier's noise model: each channel is a histogram normalised by the hits it received,
    which excludes vignetted rays and rays that picked another channel; with weighted hits (a
    volume's roulette), the count of equal-weight hits as noisy (``effective_rays``)."""
    landed = [int(n) for n in np.floor(traced.effective_rays)]
    return landed[0] if len(landed) == 1 else landed


def build_cell(model, cell: int) -> dict:
    """Trace and sparsify one cell of ``model``; the arrays of its shard (see :mod:`.shards`).
    A ``"dual"`` model's cell is sparsified twice, as a Laplacian and as row differences
    (``row_*`` arrays; their statistics prefixed ``row_``).

    Parameters
    ----------
    model : PSFModel
        A configured model; its config supplies ``seed`` and ``density``.
    cell : int
        Cell index in ``0 .. model.grid.size - 1``.
    """
    from lab.sparsify.spreadlets import sparsify

    cfg = model.config
    t0 = time.perf_counter()
    traced = model.trace_checked(cell, seed=cfg.seed)
    t1 = time.perf_counter()
    psf = traced.psf
    fits = [sparsify(psf, density=cfg.density, seed=cfg.seed * 1_000_003 + cell, rays=landed_rays(traced),
                     basis=basis, denoise_tau=model.denoise_tau) for basis in model.fitted_bases]
    t2 = time.perf_counter()
    energy = model.energy(traced)
    # sparsified normalised (its thresholds are tuned so), then scaled: the Laplacian, the row
    # differences and their integration are linear, so the spreadlets draw exactly psf * energy
    e = None if energy is None else np.asarray(energy, np.float32)
    scale = (lambda a: a) if e is None else (lambda a: (a * e).astype(np.float32))
    sp, dense = fits[0], scale(dense_crop(psf))
    stats = {k: float(v) for k, v in sp.stats.items()}
    if e is not None:
        stats["energy"] = float(np.mean(energy))
    shard = {"cell": np.array(cell, np.int64), "points": sp.points, "values": scale(sp.values),
             "fast_track": np.array(sp.fast_track), "dense": dense, "rays": np.array(traced.n_rays, np.int64),
             "trace_s": np.array(t1 - t0), "sparsify_s": np.array(t2 - t1)}
    if len(fits) == 2:
        rows = fits[1]
        stats.update({f"row_{k}": float(v) for k, v in rows.stats.items()})
        shard.update(row_points=rows.points, row_values=scale(rows.values), row_fast_track=np.array(rows.fast_track))
    shard["stats"] = np.array(json.dumps(stats, sort_keys=True))
    return shard


@dataclass(frozen=True)
class CellJob:
    """What a worker needs to compute any cell of one job (picklable).

    Attributes
    ----------
    model : str
        Registered model name.
    config : dataclass
        The model's frozen configuration.
    code : str
        :func:`~lab.precompute.naming.source_digest` of the job's code.
    threads : int or dict or None
        Dr.Jit threads for the worker process: one number for every worker, a dict from Dask
        worker address to number, or None to keep Dr.Jit's default (all cores).
    """

    model: str
    config: object
    code: str
    threads: int | dict | None = None


_MODELS: dict = {}


def _model(job: CellJob):
    """This process's instance of the job's model (built once; compiled kernels are reused)."""
    key = (job.model, repr(job.config))
    if key not in _MODELS:
        from lab.psf_tracing.models import get_model

        _MODELS.clear()
        _MODELS[key] = get_model(job.model)(job.config)
    return _MODELS[key]


def run_cell(job: CellJob, cell: int, folder: str | None = None) -> dict:
    """Compute cell ``cell`` of ``job`` in this process.

    Parameters
    ----------
    job : CellJob
        The job's model, configuration, code digest and thread policy.
    cell : int
        The cell to compute.
    folder : str, optional
        Write the shard there (the worker shares the job's file system) and return only
        :func:`~lab.precompute.shards.summary`; None returns the whole shard for the caller
        to write (workers on other machines).

    Raises
    ------
    UserError
        The worker runs different splatlab code than the job, or the model rejects the cell.
    """
    mine = source_digest(job.model, cached=True)
    if mine != job.code:
        import socket

        raise UserError(f"precompute worker on {socket.gethostname()}: its splatlab code (digest "
                        f"{mine[:12]}) differs from the job's ({job.code[:12]}); install the same "
                        "splatlab version on every worker and restart them")
    set_threads(threads_here(job.threads))
    shard = build_cell(_model(job), int(cell))
    if folder is None:
        return shard
    write_shard(Path(folder), shard)
    return summary(shard)
