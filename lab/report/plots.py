"""Report plots: what accuracy costs in time."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def accuracy_vs_time(methods: dict, path) -> None:
    """Scatter of SSIM against run time (log scale) per method, saved atomically as PNG."""
    fig, ax = plt.subplots(figsize=(5.5, 3.6), dpi=120)
    for name, m in methods.items():
        ax.scatter(m["time_ms"], m["ssim"], s=40)
        ax.annotate(name, (m["time_ms"], m["ssim"]), textcoords="offset points", xytext=(6, 4))
    ax.set_xscale("log")
    ax.set_xlabel("time per frame [ms] (log)")
    ax.set_ylabel("SSIM vs reference")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title("accuracy vs time")
    fig.tight_layout()
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, format="png")
        os.replace(tmp, path)
    finally:
        plt.close(fig)
        Path(tmp).unlink(missing_ok=True)
