"""Files written whole or not at all, and the checks an output gets before any work starts.

:func:`atomic_path` writes a temporary file beside the target, then renames it: readers (and a
job killed half-way) never see half a file. ``tempfile.mkstemp`` creates its file with mode 0600;
the finished file gets the mode a new file would have (0666 less the umask), so databases and
reports stay readable by the other users of a machine. Folders it had to create are removed
again when the write fails, and an ``OSError`` (full disk, read-only folder, no permission)
becomes one :class:`~runtime_cl.errors.InputError` line naming the file and the fix.

Temporary names carry the host and process id (``.NAME.HOST.PID.XXXX.tmp``), so
:func:`remove_stale_temps` can remove those of a killed writer without touching a live one's.

:func:`check_output` is what a command calls on its ``--out`` before it starts working.
"""
from __future__ import annotations

import errno
import os
import re
import socket
import stat
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from runtime_cl.errors import InputError
from runtime_cl.file_errors import os_error

__all__ = ["atomic_path", "check_output", "check_output_dir", "made_folder", "remove_stale_temps"]

_HOST = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname())[:40] or "host"
_TEMP = re.compile(r"\.(?P<name>.+)\.(?P<host>[A-Za-z0-9-]+)\.(?P<pid>\d+)\.[^.]+\.tmp")
_OLD_TEMP = re.compile(r"\..+\.[A-Za-z0-9_]{8}\.tmp")      # before host and pid were in the name
OLD_TEMP_AGE_S = 24 * 3600    # an old-style temporary this old has no live writer (writes take seconds)


def _umask() -> int:
    """The process umask, read without changing it (``os.umask`` would, for every thread)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    return 0o022


def _make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; the ones created, deepest first."""
    missing = []
    while not folder.exists():
        missing.append(folder)
        if folder.parent == folder:
            break
        folder = folder.parent
    for f in reversed(missing):
        f.mkdir(exist_ok=True)
    return missing


def _remove_empty(folders) -> None:
    for f in folders:
        try:
            f.rmdir()
        except OSError:
            break  # not empty (someone else wrote there) or gone: keep the rest too


@contextmanager
def made_folder(path):
    """Create the folder ``path`` (and missing parents) for the block; the folders it created are
    removed again when the block ends and they are still empty (a failed run leaves none)."""
    path = Path(path)
    created = _make_parents(path)
    try:
        yield path
    finally:
        _remove_empty(created)


@contextmanager
def atomic_path(path, fsync: bool = False, mode: int | None = None, what: str = "output"):
    """Yield a temporary path beside ``path``; it replaces ``path`` when the block ends without
    an error, and is removed otherwise (with the folders created for it).

    Parameters
    ----------
    path : str or Path
        The file to write; missing folders are created.
    fsync : bool, default False
        Flush the file to disk before the rename (databases and shards: a crash right after
        cannot leave an empty file under the final name).
    mode : int, optional
        Permission bits of the finished file (default ``0o666`` less the umask).
    what : str, default "output"
        Names the file in an error, e.g. ``"--out"``.

    Raises
    ------
    InputError
        An ``OSError`` with an errno while creating, writing or renaming (full disk, read-only
        folder, no permission): one line naming ``path`` and the fix.
    """
    path = Path(path)
    created: list[Path] = []
    tmp = None
    try:
        created = _make_parents(path.parent)
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{_HOST}.{os.getpid()}.",
                                    suffix=".tmp")
        os.close(fd)
        tmp = Path(name)
        yield tmp
        if fsync:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask() if mode is None else mode)
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        _remove_empty(created)
        if isinstance(exc, OSError) and exc.errno is not None:
            raise os_error(exc, path, what, writing=True) from None
        raise


def _samefile(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


def check_output(path, what: str = "--out", inputs=(), suffix: str = "") -> Path:
    """Check before any work starts that ``path`` can be written by :func:`atomic_path`.

    Parameters
    ----------
    path : str or Path
        The output file.
    what : str, default "--out"
        The option or thing that named it, for messages.
    inputs : iterable of str or Path
        The command's input files (``None`` entries are skipped); writing over one is refused.
    suffix : str, optional
        An example suffix for the messages, e.g. ``".exr"``.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        An empty name, a folder, a FIFO or device, one of ``inputs``, a path under a regular
        file, or a folder that cannot be written (probed with a temporary file, removed again).
    """
    text = str(path)
    example = f"e.g. out{suffix}" if suffix else "e.g. out.dat"
    if not text or text in (".", "..") or "\0" in text:
        raise InputError(f"{what} {text!r}: not a file name; name the output file, {example}")
    path = Path(text)
    for source in inputs:
        if source is not None and _samefile(path, Path(source)):
            raise InputError(f"{what} {path}: is also this command's input {source}; writing would "
                             "destroy it, choose another output name")
    try:
        st = path.stat()
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise os_error(exc, path, what, writing=True) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what} {path}: is a folder; name a file inside it, e.g. {path / ('out' + suffix)}")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise InputError(f"{what} {path}: is not a regular file (a FIFO, socket or device); name a file")
    _probe(path, path.parent, what)
    return path


def _probe(path: Path, folder: Path, what: str) -> None:
    """Create and remove a temporary file in ``folder``'s nearest existing ancestor (creating no
    folder): the one test of writability that sees read-only mounts and ACLs, also as root."""
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    if not folder.is_dir():
        raise InputError(f"{what} {path}: {folder} is a file, not a folder; choose a path inside a folder")
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=f".splatlab-probe.{_HOST}.{os.getpid()}.", suffix=".tmp")
        os.close(fd)
        os.unlink(probe)
        if os.statvfs(folder).f_bavail == 0:       # an empty file fits on a full disk; nothing else does
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    except OSError as exc:
        if exc.errno == errno.ENOENT:               # the folder is there (/proc, a vanished mount)
            raise InputError(f"{what} {path}: {folder} accepts no new files; choose another folder") from None
        raise os_error(exc, path, what, writing=True) from None


def check_output_dir(path, what: str = "--out-dir") -> Path:
    """Check before any work starts that the folder ``path`` can hold a command's outputs
    (it need not exist: the writers create it, and remove it again if they fail).

    Raises
    ------
    InputError
        An empty name, an existing file, a path under a regular file, or no permission to write.
    """
    text = str(path)
    if not text or "\0" in text:
        raise InputError(f"{what} {text!r}: not a folder name; name the output folder, e.g. reports/mine")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise InputError(f"{what} {path}: is a file, not a folder; name a folder (it is created if missing)")
    _probe(path, path, what)
    return path


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's live process
    return True


def remove_stale_temps(folder) -> list[Path]:
    """Remove the temporary files in ``folder`` that no live writer owns: this host's whose
    process is gone, and old-style ones older than a day. Returns those removed."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for entry in entries:
        m = _TEMP.fullmatch(entry.name)
        if m:
            stale = m["host"] == _HOST and not _alive(int(m["pid"]))
        else:
            try:
                stale = bool(_OLD_TEMP.fullmatch(entry.name)) and now - entry.stat().st_mtime > OLD_TEMP_AGE_S
            except OSError:
                stale = False
        if stale and entry.is_file(follow_symlinks=False):
            try:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
            except OSError:
                pass
    return removed
