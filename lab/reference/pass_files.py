"""One file per finished render pass, written atomically, so an interrupted render resumes.

A pass image is an ``.npy`` file (float32, (H, W, 3)) in the job's pass folder, named by the pass's
index and a digest of what makes the pass: the job's class, index, spp, seed, channel weights and
variant (:func:`pass_path`). The folder itself belongs to one job (the caller keys it by the scene's
render key, which covers the scene and the rendering code). A file is written to a temporary name
beside it, flushed to disk and renamed into place, so it exists whole or not at all; a job killed
at any instant leaves finished passes and at most a few orphaned temporary files
(``.pass*.tmp``), never read, removed with the folder.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path

from ..errors import UserError

__all__ = ["pass_path", "write_pass", "pass_ok", "read_pass"]


def pass_path(folder: Path, job, p) -> Path:
    """The file of pass ``p`` of ``job`` in ``folder``: ``pass<index>-<digest>.npy``."""
    what = repr((type(job).__qualname__, p.index, p.spp, p.seed, tuple(float(w) for w in p.weight), p.variant))
    return Path(folder) / f"pass{p.index:05d}-{hashlib.sha256(what.encode()).hexdigest()[:16]}.npy"


def write_pass(folder: Path, job, p, image) -> Path:
    """Write pass ``p``'s image, (H, W, 3) float32, atomically; returns its path."""
    path = pass_path(folder, job, p)
    with atomic_path(path, fsync=True) as tmp, open(tmp, "wb") as f:
        np.save(f, np.ascontiguousarray(image, dtype=np.float32))
    return path


def _header(path: Path):
    """(shape, Fortran order, dtype, data offset) of an ``.npy`` file; ValueError when it is not one."""
    fmt = np.lib.format
    with open(path, "rb") as f:
        version = fmt.read_magic(f)
        if version not in ((1, 0), (2, 0)):
            raise ValueError(f".npy version {version}")
        read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, fortran, dtype = read(f)
        return shape, fortran, dtype, f.tell()


def pass_ok(folder: Path, job, p) -> bool:
    """Cheap resume check: pass ``p``'s file is a whole float32 (H, W, 3) ``.npy`` (its header
    says so and its size matches)."""
    path = pass_path(folder, job, p)
    try:
        shape, fortran, dtype, offset = _header(path)
        size = path.stat().st_size
    except (OSError, ValueError, EOFError):
        return False
    return (dtype == np.float32 and not fortran and len(shape) == 3 and shape[2] == 3
            and size == offset + int(np.prod(shape)) * 4)


def read_pass(folder: Path, job, p) -> np.ndarray:
    """Pass ``p``'s image from its file (one :func:`pass_ok` accepted).

    Raises
    ------
    UserError
        The file vanished or was cut short since (another process cleaning the cache).
    """
    path = pass_path(folder, job, p)
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise UserError(f"{path}: a finished render pass can no longer be read ({exc}); was the cache "
                        "cleaned while rendering? Run the command again: missing passes are rendered anew") from None
