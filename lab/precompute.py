"""Precompute jobs: light-trace every cell of a PSF model, sparsify it, write the database.

Each cell's result is written as its own shard, atomically, under
``.cache/precompute/<model>-<hash>/``: an interrupted job resumes at the first missing shard and
never leaves a corrupt file. The final step consolidates the shards into one database through
:mod:`runtime_cl.database` (atomic too). The hash covers the model name, its configuration and
the source of the code that produces the PSFs (optics, tracer, sparsifier, database format), so an
unchanged configuration is reused and any change rebuilds.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from runtime_cl.database import DatabaseBuilder, SpreadletDatabase

from .config import to_table

ROOT = Path(__file__).resolve().parents[1]


def cache_root() -> Path:
    """Where renders, shards and databases are cached: ``$SPLATLAB_CACHE`` or ``.cache/``."""
    return Path(os.environ.get("SPLATLAB_CACHE", ROOT / ".cache"))

# The code whose output a database is: a change to any of these files rebuilds.
SOURCES = ("lab/optics", "lab/psf_tracing", "lab/sparsify", "runtime_cl/database.py",
           "runtime_cl/psf_space.py", "runtime_cl/integrate.py", "lab/precompute.py")


def _source_digest() -> str:
    h = hashlib.sha256()
    for rel in SOURCES:
        path = ROOT / rel
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for f in files:
            h.update(str(f.relative_to(ROOT)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def content_hash(model_name: str, config) -> str:
    """12 hex digits naming a database: model, configuration and producing code."""
    key = json.dumps({"model": model_name, "config": to_table(config), "code": _source_digest()},
                     sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def dense_crop(psf: np.ndarray) -> np.ndarray:
    """The PSF cropped to the smallest (2r+1)^2 square around its centre holding every nonzero pixel."""
    c = psf.shape[0] // 2
    ys, xs = np.nonzero(np.any(psf != 0, axis=2))
    r = int(max(np.abs(ys - c).max(), np.abs(xs - c).max())) if len(ys) else 0
    return psf[c - r:c + r + 1, c - r:c + r + 1]


def _write_npz(path: Path, **arrays) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".npz")
    os.close(fd)
    try:
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _read_shard(path: Path):
    """A finished shard, or None when missing or unreadable (then it is traced again)."""
    try:
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, KeyError):
        return None
    except Exception:  # zipfile.BadZipFile and friends from a torn file
        return None


@dataclass
class PrecomputeResult:
    path: Path
    reused: bool
    seconds: float
    rays: int
    trace_seconds: float
    sparsify_seconds: float


def build_cell(model, cell: int) -> dict:
    """Trace and sparsify one cell; the arrays of its shard plus timings."""
    from .sparsify.spreadlets import sparsify

    cfg = model.config
    t0 = time.perf_counter()
    traced = model.trace_checked(cell, seed=cfg.seed)
    t1 = time.perf_counter()
    psf = traced.psf
    sp = sparsify(psf, density=cfg.density, seed=cfg.seed * 1_000_003 + cell, rays=traced.n_rays)
    t2 = time.perf_counter()
    stats = {k: float(v) for k, v in sp.stats.items()}
    return {"points": sp.points, "values": sp.values, "fast_track": np.array(sp.fast_track),
            "dense": dense_crop(psf), "stats": np.array(json.dumps(stats)),
            "trace_s": np.array(t1 - t0), "sparsify_s": np.array(t2 - t1), "rays": np.array(traced.n_rays)}


def precompute(model, *, force: bool = False, progress: bool = True) -> PrecomputeResult:
    """Build (or reuse) the spreadlet database of ``model`` (a :class:`PSFModel` instance)."""
    t_start = time.perf_counter()
    digest = content_hash(model.name, model.config)
    out = cache_root() / "db" / f"{model.name}-{digest}.spdb"
    if out.exists() and not force:
        SpreadletDatabase.load(out, expect_model=model.name)  # validates the checksum
        return PrecomputeResult(out, True, time.perf_counter() - t_start, 0, 0.0, 0.0)
    shard_dir = cache_root() / "precompute" / f"{model.name}-{digest}"
    shard_dir.mkdir(parents=True, exist_ok=True)
    cells = model.grid.size
    trace_s = sparsify_s = 0.0
    rays = 0
    bar = tqdm(range(cells), desc=f"precompute {model.name}", unit="PSF", disable=not progress)
    for cell in bar:
        path = shard_dir / f"cell{cell:06d}.npz"
        if not force and _read_shard(path) is not None:
            continue
        shard = build_cell(model, cell)
        _write_npz(path, **shard)
        trace_s += float(shard["trace_s"])
        sparsify_s += float(shard["sparsify_s"])
        rays += int(shard["rays"])
        if trace_s > 0:
            bar.set_postfix(Mrays_s=f"{rays / trace_s / 1e6:.0f}", refresh=False)
    builder = DatabaseBuilder(model.name, {"config": to_table(model.config), "hash": digest,
                                           "symmetries": list(model.symmetries)},
                              model.grid, model.channels, model.resolution)
    for cell in range(cells):
        shard = _read_shard(shard_dir / f"cell{cell:06d}.npz")
        if shard is None:
            raise RuntimeError(f"shard of cell {cell} in {shard_dir} vanished during the job")
        builder.add(shard["points"], shard["values"], shard["dense"], bool(shard["fast_track"]),
                    json.loads(str(shard["stats"])))
    out.parent.mkdir(parents=True, exist_ok=True)
    builder.build().save(out)
    shutil.rmtree(shard_dir, ignore_errors=True)  # the database now holds everything
    return PrecomputeResult(out, False, time.perf_counter() - t_start, rays, trace_s, sparsify_s)
