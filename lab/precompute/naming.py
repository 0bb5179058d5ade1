"""Where precompute results live and what names them: the content hash.

A database is named ``<model>-<hash>.spdb`` under ``<cache>/db/``; its shards live under
``<cache>/precompute/<model>-<hash>/`` while the job runs. The hash covers the model name, its
configuration and the content of every module the result is made by: the model's own module,
the cell (trace + sparsify) and the consolidation, with everything they import
(:mod:`lab.cache_key`). An unchanged configuration is reused and any change - to a setting or to
that code - builds a new database. Modules that only schedule the work (executors, progress,
CLI) are not imported by those and not hashed: running on more workers must give, and gives,
the same database.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from lab.cache_key import cached_code_digest, code_digest
from lab.config import to_table
from lab.paths import cache_root

__all__ = ["code_roots", "source_digest", "content_hash", "database_path", "shard_dir"]

# What makes a database, beside its model's own module (their imports are found, not listed).
PIPELINE = ("lab.precompute.cell", "lab.precompute.consolidate")


def code_roots(model_name: str) -> tuple:
    """The modules whose imports make ``model_name``'s database: its model module and :data:`PIPELINE`."""
    from lab.psf_tracing.models import get_model

    return (get_model(model_name).__module__,) + PIPELINE


def source_digest(model_name: str, cached: bool = False) -> str:
    """sha256 (hex) of the code that makes ``model_name``'s database (:func:`code_roots`).

    Parameters
    ----------
    model_name : str
        Registered model name.
    cached : bool, default False
        Reuse this process's first answer (worker processes check every task against it;
        the job itself always reads the files afresh).
    """
    roots = code_roots(model_name)
    return cached_code_digest(roots) if cached else code_digest(roots)


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
                      "code": code or source_digest(model_name)}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def database_path(model_name: str, digest: str) -> Path:
    """The cached database of ``model_name`` with content hash ``digest``."""
    return cache_root() / "db" / f"{model_name}-{digest}.spdb"


def shard_dir(model_name: str, digest: str) -> Path:
    """The folder holding the per-cell shards of an unfinished job."""
    return cache_root() / "precompute" / f"{model_name}-{digest}"
