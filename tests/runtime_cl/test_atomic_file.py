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


def test_folders_made_for_a_failed_write_are_removed(tmp_path):
    target = tmp_path / "a" / "b" / "out.exr"
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            assert tmp.parent == target.parent
            raise RuntimeError("render failed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("code, needle", [(28, "no space left on the device; free disk space"),
                                          (30, "the file system is read-only"),
                                          (13, "permission denied; choose a folder you can write")])
def test_os_errors_become_one_line_naming_the_target(tmp_path, code, needle):
    from runtime_cl.errors import InputError

    target = tmp_path / "out.spdb"
    target.write_bytes(b"old")
    with pytest.raises(InputError) as exc:
        with atomic_path(target, what="--out") as tmp:
            tmp.write_bytes(b"half")
            raise OSError(code, os.strerror(code))
    assert str(exc.value).startswith(f"--out {target}: ") and needle in str(exc.value)
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["out.spdb"]


def test_check_output(tmp_path):
    from runtime_cl.atomic_file import check_output, check_output_dir
    from runtime_cl.errors import InputError

    (tmp_path / "in.exr").write_bytes(b"x")
    os.mkfifo(tmp_path / "pipe")
    assert check_output(tmp_path / "new" / "deeper" / "o.exr") == tmp_path / "new" / "deeper" / "o.exr"
    assert not (tmp_path / "new").exists()               # checked, not created
    for path, inputs, needle in [("", (), "not a file name"), (tmp_path, (), "is a folder"),
                                 (tmp_path / "in.exr" / "o.exr", (), "is a file, not a folder"),
                                 (tmp_path / "pipe", (), "not a regular file"),
                                 (tmp_path / "." / "in.exr", (tmp_path / "in.exr",), "also this command's input")]:
        with pytest.raises(InputError, match=needle):
            check_output(path, "--out", inputs)
    with pytest.raises(InputError, match="is a file, not a folder"):
        check_output_dir(tmp_path / "in.exr")
    assert check_output_dir(tmp_path / "reports" / "x") == tmp_path / "reports" / "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.exr", "pipe"]   # no probe left


def test_check_output_sees_a_full_disk(tmp_path, monkeypatch):
    from runtime_cl import atomic_file
    from runtime_cl.errors import InputError

    class Full:
        f_bavail = 0

    monkeypatch.setattr(atomic_file.os, "statvfs", lambda path: Full())
    with pytest.raises(InputError, match="no space left on the device"):
        atomic_file.check_output(tmp_path / "o.exr")


def test_made_folder_keeps_only_used_folders(tmp_path):
    from runtime_cl.atomic_file import made_folder

    with made_folder(tmp_path / "a" / "b"):
        pass
    assert list(tmp_path.iterdir()) == []
    with made_folder(tmp_path / "a" / "b") as folder:
        (folder / "shard").write_bytes(b"x")
    assert (tmp_path / "a" / "b" / "shard").exists()


def test_stale_temps_of_dead_writers_are_removed(tmp_path):
    """A killed writer's temporary is removed; a live writer's (this process) and other files stay."""
    import subprocess
    import sys
    import time

    from runtime_cl.atomic_file import OLD_TEMP_AGE_S, _HOST, remove_stale_temps

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    names = {"dead": f".db.spdb.{_HOST}.{dead}.abcd1234.tmp", "live": f".db.spdb.{_HOST}.{os.getpid()}.x1y2z3w4.tmp",
             "other_host": f".db.spdb.elsewhere.{dead}.abcd1234.tmp", "old": ".db.spdb.k8o_g1kc.tmp",
             "young": ".db.spdb.a1b2c3d4.tmp", "db": "db.spdb"}
    for name in names.values():
        (tmp_path / name).write_bytes(b"x")
    past = time.time() - OLD_TEMP_AGE_S - 60
    os.utime(tmp_path / names["old"], (past, past))
    removed = sorted(p.name for p in remove_stale_temps(tmp_path))
    assert removed == sorted([names["dead"], names["old"]])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(set(names.values()) - set(removed))
