"""The last step of a precompute job: every shard, in cell order, into one database file.

Shards are read one at a time; what accumulates is exactly what the database stores (spreadlets
and dense crops), never the full R x R traced images. The database header records the model,
its configuration, the content hash and the symmetries, and nothing about how the job ran
(workers, timings), so the same configuration gives the same file checksum on any executor.
"""
from __future__ import annotations

import json
from pathlib import Path

from runtime_cl.psf.database import DatabaseBuilder

from lab.config import to_table
from lab.errors import UserError

from .shards import read_shard, shard_path

__all__ = ["database_params", "consolidate"]


def database_params(model, digest: str) -> dict:
    """The ``params`` the database header stores for ``model`` built under hash ``digest``."""
    return {"config": to_table(model.config), "hash": digest, "symmetries": list(model.symmetries),
            "fingerprint": model.fingerprint(), "basis": model.basis}


def consolidate(model, digest: str, folder: Path, out: Path) -> None:
    """Build ``out`` (atomically, through :mod:`runtime_cl.psf.database`) from the shards in ``folder``.

    Raises
    ------
    UserError
        A shard is missing or unreadable (it is deleted, so running the job again retraces it).
    """
    builder = DatabaseBuilder(model.name, database_params(model, digest), model.grid,
                              model.channels, model.resolution)
    for cell in range(model.grid.size):
        shard = read_shard(folder, cell)
        if shard is None:
            shard_path(folder, cell).unlink(missing_ok=True)
            raise UserError(f"precompute {model.name}: the shard of cell {cell} in {folder} is missing "
                            "or unreadable; run the same command again to retrace it")
        rows = (shard["row_points"], shard["row_values"], bool(shard["row_fast_track"])) \
            if model.basis == "dual" else None
        builder.add(shard["points"], shard["values"], shard["dense"], bool(shard["fast_track"]),
                    json.loads(str(shard["stats"])), rows=rows)
    out.parent.mkdir(parents=True, exist_ok=True)
    builder.build().save(out)
