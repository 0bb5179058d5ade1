"""The one reader of a user's file: one InputError line per failure, a FIFO refused without blocking."""
import os
import threading

import pytest

from runtime_cl.errors import InputError
from runtime_cl.input_file import check_input, open_input, read_bytes, read_text


def test_reads_a_regular_file(tmp_path):
    (tmp_path / "a.toml").write_text("x = 'é'\n", encoding="utf-8")
    assert read_text(tmp_path / "a.toml", "scene file", "fix") == "x = 'é'\n"
    assert read_bytes(tmp_path / "a.toml", "scene file", "fix") == "x = 'é'\n".encode()
    assert check_input(tmp_path / "a.toml", "scene file", "fix") == tmp_path / "a.toml"
    with open_input(tmp_path / "a.toml", "scene file", "fix") as fh:
        assert fh.read(1) == b"x"


@pytest.mark.parametrize("make, needle", [
    (lambda d: d / "missing.toml", "no such file; pass a scene"),
    (lambda d: d, "is a folder, not a file; pass a scene"),
    (lambda d: "", "not a file name"),
    (lambda d: str(d / "a\0b"), "not a file name"),
    (lambda d: (d / "f").write_text("x") and d / "f" / "x.toml", "a part of the path is a file"),
])
def test_bad_paths(tmp_path, make, needle):
    with pytest.raises(InputError) as exc:
        read_text(make(tmp_path), "scene file", "pass a scene")
    assert needle in str(exc.value) and str(exc.value).startswith("scene file ")
    assert "\n" not in str(exc.value)


def test_a_fifo_is_refused_at_once(tmp_path):
    """Opening a FIFO for reading blocks until a writer comes; the reader must not wait."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    result = []

    def read():
        try:
            read_text(fifo, "scene file", "pass a scene")
        except InputError as exc:
            result.append(str(exc))

    t = threading.Thread(target=read, daemon=True)
    t.start()
    t.join(10)
    assert not t.is_alive(), "blocked on the FIFO"
    assert result and "is a FIFO (named pipe)" in result[0]


def test_not_utf8_names_line_and_column(tmp_path):
    (tmp_path / "s.toml").write_bytes(b"a = 1\nname = \"x\xe9\"\n")
    with pytest.raises(InputError, match=r"not UTF-8 text \(byte b'\\xe9' at line 2, column 10\); save it as UTF-8"):
        read_text(tmp_path / "s.toml", "scene file", "fix")


def test_no_permission(tmp_path, monkeypatch):
    """EACCES (root reads everything, so the refusal is injected where the file is opened)."""
    import errno

    import runtime_cl.input_file as input_file

    (tmp_path / "s.toml").write_text("x = 1")

    def refuse(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(input_file.os, "open", refuse)
    with pytest.raises(InputError, match=r"s.toml: permission denied; make it readable"):
        read_text(tmp_path / "s.toml", "scene file", "fix")
