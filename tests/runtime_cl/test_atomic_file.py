"""Atomic files: whole or nothing, the old file kept on failure, a new file's permissions."""
import os

import pytest

from runtime_cl.atomic_file import atomic_path


def test_success_replaces_with_a_new_files_mode(tmp_path):
    target = tmp_path / "report.json"
    target.write_text("old")
    old = os.umask(0o027)
    try:
        with atomic_path(target) as tmp:
            assert tmp.parent == tmp_path and tmp != target
            tmp.write_text("new")
            assert target.read_text() == "old"          # not visible before the block ends
    finally:
        os.umask(old)
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_failure_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    target = tmp_path / "db.npz"
    target.write_bytes(b"intact")
    with pytest.raises(RuntimeError, match="killed"):
        with atomic_path(target, fsync=True) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("killed")
    assert target.read_bytes() == b"intact"
    assert [p.name for p in tmp_path.iterdir()] == ["db.npz"]


def test_explicit_mode(tmp_path):
    target = tmp_path / "lib.so"
    with atomic_path(target, mode=0o755) as tmp:
        tmp.write_bytes(b"\x7fELF")
    assert target.stat().st_mode & 0o777 == 0o755
