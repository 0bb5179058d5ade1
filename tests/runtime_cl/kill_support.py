"""SIGKILL a `splatlab` command once it is busy and check what it leaves running.

A killed command gets no chance to stop its worker pool; its local workers watch their parent
(``lab.parallel``) and must exit by themselves.
"""
import os
import signal
import subprocess
import sys
import time

import pytest

from lab.paths import ROOT


def sigkill_when_busy(argv, cache, busy_glob: str, workers: int = 2, timeout_s: float = 180) -> None:
    """Run ``splatlab argv`` with ``SPLATLAB_CACHE=cache``; once a file matches ``busy_glob``
    under ``cache``, check it has ``workers`` spawned workers, SIGKILL it, and assert every child
    process exits within 15 s."""
    psutil = pytest.importorskip("psutil")
    proc = subprocess.Popen([sys.executable, "-m", "lab.cli", *map(str, argv)], cwd=ROOT,
                            env=dict(os.environ, SPLATLAB_CACHE=str(cache)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    children = []
    try:
        deadline = time.monotonic() + timeout_s
        while not list(cache.glob(busy_glob)):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline, f"nothing matched {busy_glob} within {timeout_s} s"
            time.sleep(0.01)
        children = psutil.Process(proc.pid).children(recursive=True)
        spawned = [c for c in children if "spawn_main" in " ".join(c.cmdline())]
        assert len(spawned) == workers, [c.cmdline() for c in children]
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
        _, alive = psutil.wait_procs(children, timeout=15)   # they poll their parent every 0.25 s
        assert not alive, [c.cmdline() for c in alive]
    finally:
        if proc.poll() is None:
            proc.kill()
        for child in children:
            if child.is_running():
                child.kill()
    assert proc.returncode == -signal.SIGKILL
