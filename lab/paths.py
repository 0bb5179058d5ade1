"""Where the lab's files live: the repository, its scenes and reports, and the cache.

One module for every folder the lab reads or writes, so no other module works a path out from
its own ``__file__`` (the CLI, the commands, the pipeline, the benchmarks and the tests all ask
here). The repository is the folder that holds the ``lab`` package.
"""
from __future__ import annotations

import os
from pathlib import Path

__all__ = ["ROOT", "SCENES", "DEMO_SCENE", "REPORTS", "cache_root"]

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
DEMO_SCENE = SCENES / "demo.toml"
REPORTS = ROOT / "reports"


def cache_root() -> Path:
    """Where renders, shards and databases are cached: ``$SPLATLAB_CACHE`` or ``<repo>/.cache/``."""
    return Path(os.environ.get("SPLATLAB_CACHE", ROOT / ".cache"))
