"""One shard per PSF sample: the cell's spreadlets, dense crop and statistics, written atomically.

A shard is an uncompressed ``.npz`` named ``cell<index>.npz``. It is written to a temporary file
in the same folder, flushed to disk and renamed into place (``os.replace`` is atomic on POSIX),
so a shard either exists whole or not at all: a job killed at any instant leaves finished shards
and at most one orphaned temporary file (``.cell*.tmp``), which is never read and is removed with
the folder after consolidation. A shard that still cannot be read (a disk that lied about its
flush) counts as missing and is traced again.

Arrays: ``cell`` (int64 scalar), ``points`` int16 (k, 2), ``values`` float32 (k, C),
``fast_track`` bool, ``dense`` float32 (2r+1, 2r+1, C), ``stats`` (JSON string of floats),
``rays`` int64, ``trace_s`` and ``sparsify_s`` float64 (timings, not part of the database); a
``"dual"`` model's shards add ``row_points``, ``row_values`` and ``row_fast_track`` (the same cell as
row differences).
"""
from __future__ import annotations

import json
import zipfile
import zlib
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path

__all__ = ["KEYS", "shard_path", "write_shard", "read_shard", "shard_ok", "summary"]

KEYS = ("cell", "points", "values", "fast_track", "dense", "stats", "rays", "trace_s", "sparsify_s")
ROW_KEYS = ("row_points", "row_values", "row_fast_track")
_UNREADABLE = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error)


def shard_path(folder: Path, cell: int) -> Path:
    """Path of cell ``cell``'s shard in ``folder``."""
    return Path(folder) / f"cell{int(cell):06d}.npz"


def write_shard(folder: Path, shard: dict) -> Path:
    """Write ``shard`` (the arrays of :data:`KEYS`) atomically; returns its path."""
    path = shard_path(folder, int(shard["cell"]))
    with atomic_path(path, fsync=True) as tmp, open(tmp, "wb") as f:
        np.savez(f, **{k: shard[k] for k in KEYS + ROW_KEYS if k in shard})   # a file object: savez adds no ".npz"
    return path


def read_shard(folder: Path, cell: int) -> dict | None:
    """The shard of ``cell`` as a dict of arrays, or None when missing, torn or foreign."""
    try:
        with np.load(shard_path(folder, cell), allow_pickle=False) as z:
            shard = {k: z[k] for k in KEYS + ROW_KEYS if k in KEYS or k in z.files}
        json.loads(str(shard["stats"]))
    except _UNREADABLE:
        return None
    return shard if int(shard["cell"]) == int(cell) else None


def shard_ok(folder: Path, cell: int) -> bool:
    """Cheap resume check: the shard's zip directory is readable and lists every array.

    The directory sits at the end of the file, so a truncated file fails here; consolidation
    reads the arrays in full (:func:`read_shard`).
    """
    try:
        with zipfile.ZipFile(shard_path(folder, cell)) as z:
            names = set(z.namelist())
    except _UNREADABLE:
        return False
    return all(f"{k}.npy" in names for k in KEYS)


def summary(shard: dict) -> dict:
    """The small part of a shard the job's progress needs: cell, rays and timings."""
    return {"cell": int(shard["cell"]), "rays": int(shard["rays"]),
            "trace_s": float(shard["trace_s"]), "sparsify_s": float(shard["sparsify_s"])}
