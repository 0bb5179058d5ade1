"""Report plots: what accuracy costs in time."""
from __future__ import annotations

from pathlib import Path

import matplotlib

from runtime_cl.atomic_file import atomic_path

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
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
