"""Where benchmarks write: JSON under ``reports/bench/`` with the machine and versions."""
from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

from runtime_cl.atomic_file import atomic_path

from lab.paths import REPORTS
from lab.report.machine import machine_info

__all__ = ["BENCH_DIR", "write_bench"]

BENCH_DIR = REPORTS / "bench"


def write_bench(name: str, data: dict) -> Path:
    """Write ``data`` as ``<name>-<UTC stamp>.json`` and ``<name>-latest.json`` in :data:`BENCH_DIR`."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    data = dict(data, benchmark=name, created=stamp, machine=machine_info())
    path = BENCH_DIR / f"{name}-{stamp}.json"
    for target in (path, BENCH_DIR / f"{name}-latest.json"):
        with atomic_path(target) as tmp:
            tmp.write_text(json.dumps(data, indent=2))
    return path
