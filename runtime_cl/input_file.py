"""The one way a user's file is opened: scene and camera TOML, baseline JSON, EXR, database.

Every failure is an :class:`~runtime_cl.errors.InputError` of one line naming what the file was
for, its path, what is wrong and the fix: a missing file, a folder, a FIFO or device (opened
without blocking and refused: reading a FIFO would wait forever for a writer), no permission,
text that is not UTF-8. The file is opened with ``O_NONBLOCK`` and checked with ``fstat`` on the
open descriptor, so nothing can swap it between the check and the read.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from runtime_cl.errors import InputError
from runtime_cl.file_errors import os_error

__all__ = ["check_input", "open_input", "read_bytes", "read_text"]


def _describe(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe), not a regular file"
    if stat.S_ISSOCK(mode):
        return "a socket, not a regular file"
    return "a device, not a regular file"


def open_input(path, what: str, fix: str):
    """Open a user's regular file for binary reading.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it is for, e.g. ``"scene file"``; starts the message.
    fix : str
        What to do instead, ending the message, e.g. ``"pass a scene .toml (see scenes/)"``.

    Returns
    -------
    io.BufferedReader
        Close it (``with open_input(...) as fh``).

    Raises
    ------
    InputError
        ``path`` is empty, missing, not a regular file or unreadable.
    """
    text = str(path)
    if not text or "\0" in text:
        raise InputError(f"{what} {text!r}: not a file name; {fix}")
    try:
        fd = os.open(text, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise os_error(exc, text, what, fix) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise InputError(f"{what} {text}: is {_describe(mode)}; {fix}")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def check_input(path, what: str, fix: str) -> Path:
    """``path`` as a Path once it is a readable regular file (for readers that take a file name,
    such as OpenEXR); InputError as :func:`open_input` otherwise."""
    open_input(path, what, fix).close()
    return Path(path)


def read_bytes(path, what: str, fix: str) -> bytes:
    """The whole content of a user's regular file (errors as :func:`open_input`)."""
    with open_input(path, what, fix) as fh:
        try:
            return fh.read()
        except OSError as exc:
            raise os_error(exc, str(path), what, fix) from None


def read_text(path, what: str, fix: str) -> str:
    """A user's UTF-8 text file; bytes that are not UTF-8 are an error naming the line and column."""
    data = read_bytes(path, what, fix)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise InputError(f"{what} {path}: not UTF-8 text (byte {data[exc.start:exc.start + 1]!r} at line "
                         f"{line}, column {column}); save it as UTF-8") from None
