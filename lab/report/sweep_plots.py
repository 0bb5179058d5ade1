"""The accuracy-vs-time plot: SSIM and PSNR against time (log), knob curves, the Pareto front."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

from runtime_cl.atomic_file import atomic_path

from .pareto import pareto_front

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import LogFormatter  # noqa: E402

__all__ = ["accuracy_time_plot", "SCORES"]

SCORES = (("ssim", "SSIM vs reference"), ("psnr", "PSNR vs reference [dB]"))
MARKERS = "osD^v<>Ph*X"


def _curves(points):
    """(method, knob) -> point indices in knob order (numbers by value, names as swept)."""
    groups: dict[tuple, list[int]] = {}
    for i, p in enumerate(points):
        groups.setdefault((p["method"], p.get("knob")), []).append(i)
    for key, idx in groups.items():
        if all(isinstance(points[i].get("value"), (int, float)) for i in idx):
            idx.sort(key=lambda i: points[i]["value"])
    return groups


def _finite(p, key) -> bool:
    v = p.get(key)
    return v is not None and math.isfinite(v) and p.get("time_ms") is not None and p["time_ms"] > 0


def _short(value) -> str:
    """A knob value as a point label: large counts as 4M / 262k, the rest as they are."""
    if isinstance(value, int) and not isinstance(value, bool) and value >= 10_000:
        return f"{value / 1e6:.3g}M" if value >= 1_000_000 else f"{value / 1e3:.3g}k"
    return str(value)


def accuracy_time_plot(points, path, title: str) -> None:
    """Two panels (SSIM, PSNR) of ``points`` (dicts with ``method``, ``time_ms``, ``ssim``,
    ``psnr`` and optionally ``knob``, ``value``, ``base``) against time on a log axis: each
    method's points joined along its knob, the report's own run ringed, the Pareto front drawn.
    When the path tracer's points are there, a second row shows the runtime methods alone, zoomed
    (the path tracer's low-spp scores would squeeze them to a line). Saved atomically as PNG."""
    from .knobs import REFERENCE

    methods = list(dict.fromkeys(p["method"] for p in points))
    knobs = list(dict.fromkeys(p.get("knob") for p in points))
    colours = {m: plt.get_cmap("tab10")(i % 10) for i, m in enumerate(methods)}
    marks = {k: MARKERS[i % len(MARKERS)] for i, k in enumerate(knobs)}
    runtime = [p for p in points if p["method"] != REFERENCE]
    rows = [(points, "")] + ([(runtime, "runtime methods only: ")] if 0 < len(runtime) < len(points) else [])
    fig, grid = plt.subplots(len(rows), 2, figsize=(12.5, 4.8 * len(rows)), dpi=110, squeeze=False)
    axes = grid[0]
    for (row, prefix), row_axes in zip(rows, grid):
        _panels(row, prefix, row_axes, axes, colours, marks)
    fig.suptitle(title)
    fig.legend(loc="center right", fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 0.8, 1))
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)


def _panels(points, prefix, row_axes, first_axes, colours, marks) -> None:
    """One row: SSIM and PSNR against time of ``points``; the legend labels come from the first row."""
    for ax, (key, ylabel) in zip(row_axes, SCORES):
        legend = ax is first_axes[0]
        usable = [p for p in points if _finite(p, key)]
        for (method, knob), idx in _curves(usable).items():
            xs = [usable[i]["time_ms"] for i in idx]
            ys = [usable[i][key] for i in idx]
            label = method if knob is None else f"{method} · {knob}"
            ax.plot(xs, ys, marker=marks[knob], color=colours[method], lw=1.2, ms=6, alpha=0.9,
                    label=label if legend else None)
            for n, i in enumerate(idx):
                p = usable[i]
                if knob is not None:   # labels alternate above and below, so close points stay legible
                    ax.annotate(_short(p["value"]), (p["time_ms"], p[key]), textcoords="offset points",
                                xytext=(5, 5 if n % 2 == 0 else -11), fontsize=7.5, color=colours[method])
                if knob is None or p.get("base"):
                    ax.plot(p["time_ms"], p[key], marker="o", ms=11, mfc="none", mec="black", mew=0.8)
        front = [usable[i] for i in pareto_front(usable, score_key=key)]
        if front:
            ax.step([p["time_ms"] for p in front], [p[key] for p in front], where="post", color="black",
                    lw=2.2, alpha=0.35, zorder=0, label="Pareto front" if legend else None)
        ax.set_xscale("log")
        for axis_set in (ax.xaxis.set_major_formatter, ax.xaxis.set_minor_formatter):   # "3", not "3 x 10^0"
            axis_set(LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
        ax.set_xlabel("time per frame [ms] (log)")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{prefix}{'SSIM' if key == 'ssim' else 'PSNR'} against time", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
