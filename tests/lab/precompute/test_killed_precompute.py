"""A precompute killed with SIGKILL leaves no worker process behind, and the next run removes
the temporary file a killed database write left in the cache."""
import os
import subprocess
import sys

import pytest
from kill_support import sigkill_when_busy

from lab.precompute import content_hash, precompute
from lab.precompute.naming import database_path
from runtime_cl.atomic_file import _HOST

from precompute_helpers import cli_sets, small_model

# 21 cells, the largest sparsify for ~0.2 s each: two workers are busy for a few seconds.
SLOW = {"max_coc_px": 24.0, "samples": 21, "psf_resolution": 53, "rays_per_psf": 2 ** 16,
        "rays_per_pixel": 256, "rays_per_launch": 2 ** 16}


@pytest.mark.slow
def test_sigkill_of_precompute_workers_2_leaves_no_worker(tmp_path):
    sigkill_when_busy(["precompute", "simple_lens", *cli_sets(SLOW), "--workers", "2", "--quiet"],
                      tmp_path / "cache", "precompute/*/cell*.npz")


def test_a_killed_database_write_leaves_a_temp_the_next_run_removes(cache):
    """A temporary from a writer that is gone (killed during the final write) is removed by the
    next precompute; one of a live writer (another job on this host) stays."""
    model = small_model()
    out = database_path("simple_lens", content_hash("simple_lens", model.config))
    out.parent.mkdir(parents=True)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    stale = out.parent / f".{out.name}.{_HOST}.{dead}.k8o2g1kc.tmp"
    live = out.parent / f".other.spdb.{_HOST}.{os.getpid()}.a1b2c3d4.tmp"
    stale.write_bytes(b"half a database")
    live.write_bytes(b"being written")
    precompute(model, progress=False)
    assert not stale.exists() and live.exists()
    assert sorted(p.name for p in out.parent.iterdir()) == sorted([out.name, live.name])


def test_a_failed_precompute_leaves_no_empty_folder(cache, monkeypatch):
    import lab.precompute.job as job

    def fail(*args, **kwargs):
        raise RuntimeError("the tracer failed")

    monkeypatch.setattr(job, "_run", fail)
    with pytest.raises(RuntimeError):
        precompute(small_model(), progress=False)
    assert not (cache / "precompute").exists()


def test_a_cached_database_with_a_bad_header_is_rebuilt(cache, reference):
    """A re-saved cache entry with a valid checksum but ``stats = 7`` is rebuilt, not fatal."""
    import json

    import numpy as np

    from runtime_cl.psf.database import SpreadletDatabase, _checksum, _header_bytes

    first = precompute(small_model(), progress=False)
    with np.load(first.path) as z:
        arrays = {k: z[k] for k in z.files}
    header = dict(json.loads(bytes(arrays["header"])), stats=7)
    hb = _header_bytes(header)
    arrays["header"] = np.frombuffer(hb, np.uint8)
    names = [k for k in arrays if k not in ("header", "checksum")]
    arrays["checksum"] = np.frombuffer(_checksum(hb, {n: arrays[n] for n in names}).encode(), np.uint8)
    with open(first.path, "wb") as fh:
        np.savez(fh, **arrays)
    again = precompute(small_model(), progress=False)
    assert not again.reused and again.path == first.path
    assert SpreadletDatabase.load(again.path).stats.keys() == reference[0].stats.keys()
