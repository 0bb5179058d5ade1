"""An ``OSError`` on a user's file as one line: the file, what went wrong and what to do.

Used by the one reader (:mod:`runtime_cl.input_file`) and the one writer
(:mod:`runtime_cl.atomic_file`), so a missing file, a full disk or a read-only folder reads the
same wherever it happens.
"""
from __future__ import annotations

import errno

from runtime_cl.errors import InputError

__all__ = ["os_error"]

# errno -> (what happened, what to do), for reading and for writing.
_READ = {
    errno.ENOENT: ("no such file", "check the path"),
    errno.ENOTDIR: ("a part of the path is a file, not a folder", "check the path"),
    errno.EISDIR: ("is a folder, not a file", "pass a file"),
    errno.EACCES: ("permission denied", "make it readable (chmod) or copy it somewhere you can read"),
    errno.EPERM: ("permission denied", "make it readable (chmod) or copy it somewhere you can read"),
    errno.ENAMETOOLONG: ("the file name is too long", "use a shorter path"),
    errno.ELOOP: ("too many symbolic links", "check the path's links"),
}
_WRITE = {
    errno.ENOENT: ("its folder does not exist", "create the folder or choose another path"),
    errno.ENOTDIR: ("a part of the path is a file, not a folder", "choose a path inside a folder"),
    errno.EISDIR: ("is a folder", "name a file inside it"),
    errno.EACCES: ("permission denied", "choose a folder you can write or fix its permissions"),
    errno.EPERM: ("permission denied", "choose a folder you can write or fix its permissions"),
    errno.EROFS: ("the file system is read-only", "write to a writable folder"),
    errno.ENOSPC: ("no space left on the device", "free disk space or write to another disk"),
    errno.EDQUOT: ("disk quota exceeded", "free space in your quota or write elsewhere"),
    errno.EFBIG: ("the file is too large for the file system", "write to another file system"),
    errno.ENAMETOOLONG: ("the file name is too long", "use a shorter path"),
    errno.EBUSY: ("the path is busy (a mount point or the current folder)", "name a file"),
    errno.EXDEV: ("the temporary file and the target are on different devices", "write to a plain folder"),
}


def os_error(exc: OSError, path, what: str, fix: str = "", writing: bool = False) -> InputError:
    """The :class:`InputError` to raise for ``exc`` on ``path``.

    Parameters
    ----------
    exc : OSError
        The error the operating system gave.
    path : str or Path
        The user's file (not a temporary file beside it).
    what : str
        What the file is for, e.g. ``"--out"`` or ``"scene file"``.
    fix : str, optional
        The advice for a missing input, and for an errno without advice of its own.
    writing : bool, default False
        Word the message for an output.
    """
    table = _WRITE if writing else _READ
    happened, advice = table.get(exc.errno, (exc.strerror or type(exc).__name__, fix or "check the path"))
    if fix and not writing and exc.errno == errno.ENOENT:
        advice = fix
    return InputError(f"{what} {path}: {happened}; {advice}")
