"""Regression check: compare a new report.json against a baseline report.json."""
from __future__ import annotations

from pathlib import Path

from runtime_cl.input_file import read_text
from runtime_cl.json_values import loads

from ..errors import UserError

MAX_REPORT_CHARS = 64 << 20   # a report.json is kilobytes; 64 MB is not one


def load_report(path) -> dict:
    path = Path(path)
    fix = "pass a report.json written by `splatlab report`"
    data = loads(read_text(path, "--baseline", fix), f"--baseline {path}", fix,
                 max_bytes=MAX_REPORT_CHARS, allow_nan=True)    # a figure a run could not measure is NaN
    if not isinstance(data, dict) or "methods" not in data:
        raise UserError(f"report {path}: has no 'methods' table; pass a report.json written by "
                        "`splatlab report`")
    return data


def compare(baseline: dict, new: dict, ssim_drop: float | None = None, slowdown: float | None = None) -> list[str]:
    """Regressions of ``new`` against ``baseline``: one message each, empty when none.

    ``ssim_drop`` and ``slowdown`` default to the baseline's own ``tolerances`` (the committed
    baselines carry them with the spreads they were derived from, :mod:`lab.report.baseline`),
    else 0.01 and 1.5.

    A method regresses when its SSIM falls by more than ``ssim_drop`` or its time grows by more than
    the factor ``slowdown``. Times on a shared machine are noisy, so the default factor is loose;
    the time is compared as a ratio to the report's timing reference (the pass that declares
    ``timing_reference``, LSR18's Splat) measured in the same run when both reports have the same
    one, which cancels most of the machine's load.
    """
    tolerances = baseline.get("tolerances") or {}
    ssim_drop = tolerances.get("ssim_drop", 0.01) if ssim_drop is None else ssim_drop
    slowdown = tolerances.get("slowdown", 1.5) if slowdown is None else slowdown
    out = []
    scene = new.get("scene", {}).get("name", "?")
    base_m, new_m = baseline["methods"], new["methods"]
    ref = baseline.get("timing_reference")
    ref = ref if ref == new.get("timing_reference") and ref in base_m and ref in new_m else None
    for name in sorted(set(base_m) & set(new_m)):
        b, n = base_m[name], new_m[name]
        if n["ssim"] < b["ssim"] - ssim_drop:
            out.append(f"{scene} {name}: SSIM {b['ssim']:.4f} -> {n['ssim']:.4f} (dropped more than {ssim_drop:.4g})")
        if name == ref:
            continue  # its own time is the machine's load; the others are measured against it
        bt = b["time_ms"] / base_m[ref]["time_ms"] if ref else b["time_ms"]
        nt = n["time_ms"] / new_m[ref]["time_ms"] if ref else n["time_ms"]
        if nt > bt * slowdown:
            unit = f"x {ref}" if ref else "ms"
            out.append(f"{scene} {name}: time {bt:.4g} -> {nt:.4g} {unit} (slower by more than {slowdown:.3g}x)")
    for name in sorted(set(base_m) - set(new_m)):
        out.append(f"{scene} {name}: present in the baseline, missing now")
    return out
