"""Files written whole or not at all: a temporary file beside the target, then one rename.

Readers (and a job killed half-way) never see half a file. ``tempfile.mkstemp`` creates its file
with mode 0600; the finished file gets the mode a new file would have (0666 less the umask), so
databases and reports stay readable by the other users of a machine.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path"]


def _umask() -> int:
    """The process umask, read without changing it (``os.umask`` would, for every thread)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    return 0o022


@contextmanager
def atomic_path(path, fsync: bool = False, mode: int | None = None):
    """Yield a temporary path beside ``path``; it replaces ``path`` when the block ends without
    an error, and is removed otherwise.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist.
    fsync : bool, default False
        Flush the file to disk before the rename (databases and shards: a crash right after
        cannot leave an empty file under the final name).
    mode : int, optional
        Permission bits of the finished file (default ``0o666`` less the umask).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        if fsync:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask() if mode is None else mode)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
