"""Where precompute results live and what names them: the content hash.

A database is named ``<model>-<hash>.spdb`` under ``<cache>/db/``; its shards live under
``<cache>/precompute/<model>-<hash>/`` while the job runs. The hash covers the model name, its
configuration and the source of every file whose code shapes the result (optics, tracer,
sparsifier, database format, shard format, consolidation), so an unchanged configuration is
reused and any change - to a setting or to that code - builds a new database. Files that only
schedule the work (executors, progress, CLI) are not hashed: running on more workers must give,
and gives, the same database.
"""
from __future__ import annotations

import hashlib
import json
import os
from functools import lru_cache
from pathlib import Path

from lab.config import to_table

__all__ = ["ROOT", "SOURCES", "cache_root", "source_digest", "content_hash", "database_path",
           "shard_dir"]

ROOT = Path(__file__).resolve().parents[2]

# The code whose output a database is: a change to any of these files rebuilds.
SOURCES = ("lab/optics", "lab/psf_tracing", "lab/sparsify", "runtime_cl/database.py",
           "runtime_cl/psf_space.py", "runtime_cl/integrate.py", "lab/precompute/cell.py",
           "lab/precompute/shards.py", "lab/precompute/consolidate.py")


def cache_root() -> Path:
    """Where renders, shards and databases are cached: ``$SPLATLAB_CACHE`` or ``<repo>/.cache/``."""
    return Path(os.environ.get("SPLATLAB_CACHE", ROOT / ".cache"))


def _digest_now() -> str:
    h = hashlib.sha256()
    for rel in SOURCES:
        path = ROOT / rel
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for f in files:
            h.update(str(f.relative_to(ROOT)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def source_digest(cached: bool = False) -> str:
    """sha256 (hex) over the path and bytes of every file in :data:`SOURCES`.

    Parameters
    ----------
    cached : bool, default False
        Reuse this process's first answer (worker processes check every task against it;
        the job itself always reads the files afresh).
    """
    return _digest_cached() if cached else _digest_now()


@lru_cache(maxsize=1)
def _digest_cached() -> str:
    return _digest_now()


def content_hash(model_name: str, config, code: str | None = None) -> str:
    """12 hex digits naming a database: model, configuration and producing code.

    Parameters
    ----------
    model_name : str
        Registered model name.
    config : dataclass
        The model's frozen configuration.
    code : str, optional
        :func:`source_digest` if already computed.
    """
    key = json.dumps({"model": model_name, "config": to_table(config),
                      "code": code or source_digest()}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def database_path(model_name: str, digest: str) -> Path:
    """The cached database of ``model_name`` with content hash ``digest``."""
    return cache_root() / "db" / f"{model_name}-{digest}.spdb"


def shard_dir(model_name: str, digest: str) -> Path:
    """The folder holding the per-cell shards of an unfinished job."""
    return cache_root() / "precompute" / f"{model_name}-{digest}"
