"""Interrupted jobs resume where they stopped and never leave a corrupt file."""
import os
import signal
import subprocess
import sys
import time

import pytest

from lab.paths import ROOT
from lab.precompute import build_cell, content_hash, precompute
from lab.precompute.naming import database_path, shard_dir
from lab.precompute.shards import read_shard, shard_path, write_shard
from runtime_cl.psf.database import SpreadletDatabase

from precompute_helpers import assert_same_database, small_model, cli_sets

# 21 cells; the 6 largest PSFs each take ~0.2 s to sparsify (they run first), the rest ~5 ms.
SLOW = {"max_coc_px": 24.0, "samples": 21, "psf_resolution": 53, "rays_per_psf": 2 ** 16,
        "rays_per_pixel": 256, "rays_per_launch": 2 ** 16}


def test_sigkill_mid_job_then_rerun_gives_the_uninterrupted_database(tmp_path):
    model = small_model(**SLOW)
    n = model.grid.size
    killed = tmp_path / "killed"
    env = dict(os.environ, SPLATLAB_CACHE=str(killed))
    folder = killed / "precompute" / f"simple_lens-{content_hash('simple_lens', model.config)}"
    proc = subprocess.Popen([sys.executable, "-m", "lab.cli", "precompute", "simple_lens",
                             *cli_sets(SLOW), "--quiet"], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while not (folder.is_dir() and len(list(folder.glob("cell*.npz"))) >= 2):
            assert proc.poll() is None, f"the job ended before it could be killed: {proc.stderr.read()}"
            assert time.monotonic() < deadline, "no shard appeared within 120 s"
            time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    done = sorted(folder.glob("cell*.npz"))
    assert 2 <= len(done) < n, f"{len(done)} shards of {n}: not interrupted mid-job"
    assert not (killed / "db").exists() or not list((killed / "db").iterdir())
    for path in done:  # every shard on disk is whole (temporary files are never read)
        assert read_shard(folder, int(path.stem[4:])) is not None, path

    # Resume in this process: only the missing cells are traced.
    os.environ["SPLATLAB_CACHE"] = str(killed)
    try:
        resumed = precompute(model, progress=False)
    finally:
        del os.environ["SPLATLAB_CACHE"]
    assert not resumed.reused and resumed.cells == n - len(done)
    assert not folder.exists()  # shards (and any orphaned temporary file) are gone

    os.environ["SPLATLAB_CACHE"] = str(tmp_path / "clean")
    try:
        clean = precompute(model, progress=False)
    finally:
        del os.environ["SPLATLAB_CACHE"]
    assert clean.cells == n
    assert_same_database(SpreadletDatabase.load(resumed.path), SpreadletDatabase.load(clean.path))


def test_torn_shard_and_orphaned_temp_file_are_retraced(reference, cache):
    """A shard cut short (a disk that lied about its flush) is traced again; stray temporary
    files are ignored and removed with the folder."""
    ref, _ = reference
    model = small_model()
    folder = shard_dir("simple_lens", content_hash("simple_lens", model.config))
    folder.mkdir(parents=True)
    for cell in range(model.grid.size):
        write_shard(folder, build_cell(model, cell))
    torn = shard_path(folder, 3)
    torn.write_bytes(torn.read_bytes()[: torn.stat().st_size // 2])
    (folder / ".cell000004.x1y2.tmp").write_bytes(b"half a shard")
    result = precompute(model, progress=False)
    assert result.cells == 1 and not folder.exists()
    assert_same_database(SpreadletDatabase.load(result.path), ref)


def test_a_damaged_cached_database_is_rebuilt(reference, cache):
    model = small_model()
    first = precompute(model, progress=False)
    data = first.path.read_bytes()
    first.path.write_bytes(data[: len(data) - 100])
    again = precompute(model, progress=False)
    assert not again.reused and again.path == first.path
    assert_same_database(SpreadletDatabase.load(again.path), reference[0])


def test_shard_of_another_cell_is_not_trusted(cache):
    model = small_model()
    folder = cache / "shards"
    folder.mkdir(parents=True)
    shard = build_cell(model, 2)
    write_shard(folder, shard)
    os.replace(shard_path(folder, 2), shard_path(folder, 5))
    assert read_shard(folder, 5) is None and read_shard(folder, 2) is None
    assert database_path("simple_lens", "abc").name == "simple_lens-abc.spdb"


@pytest.mark.parametrize("key", ["points", "stats"])
def test_shard_missing_an_array_counts_as_missing(cache, key):
    import numpy as np

    model = small_model()
    folder = cache / "shards"
    folder.mkdir(parents=True)
    shard = build_cell(model, 1)
    del shard[key]
    np.savez(shard_path(folder, 1), **shard)
    assert read_shard(folder, 1) is None


@pytest.mark.slow
def test_a_killed_worker_process_stops_the_job_cleanly_and_it_resumes(tmp_path):
    """SIGKILL one of `--workers 2`: exit status 2 with one line saying what to do; the rerun
    finishes from the shards that were kept."""
    import psutil

    model = small_model(**SLOW)
    cache = tmp_path / "cache"
    env = dict(os.environ, SPLATLAB_CACHE=str(cache))
    folder = cache / "precompute" / f"simple_lens-{content_hash('simple_lens', model.config)}"
    proc = subprocess.Popen([sys.executable, "-m", "lab.cli", "precompute", "simple_lens",
                             *cli_sets(SLOW), "--quiet", "--workers", "2"], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 180
        while not (folder.is_dir() and list(folder.glob("cell*.npz"))):
            assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
            time.sleep(0.005)
        workers = [c for c in psutil.Process(proc.pid).children(recursive=True)
                   if "spawn_main" in " ".join(c.cmdline())]
        assert len(workers) == 2, [c.cmdline() for c in workers]
        workers[0].send_signal(signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 2, err
    assert "a worker process died" in err and "run the command again to resume" in err
    kept = len(list(folder.glob("cell*.npz")))
    os.environ["SPLATLAB_CACHE"] = str(cache)
    try:
        resumed = precompute(model, progress=False)
    finally:
        del os.environ["SPLATLAB_CACHE"]
    assert resumed.cells == model.grid.size - kept
    SpreadletDatabase.load(resumed.path, expect_model="simple_lens")
