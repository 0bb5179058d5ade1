"""The layered benchmark's figures: LES10 Fig. 7 (quality against samples) and the time Mitsuba
takes for the same quality.

``equal_quality_speedup`` reads Mitsuba's low-spp renders as a curve of SSIM against time
(interpolated in log time between measured points) and asks what Mitsuba needs to reach the
layered pass's SSIM: the ratio of that time to the pass's is LES10's "time at equal quality".
Past Mitsuba's best measured point the ratio is only a lower bound, and it is marked so.
``ssim_at_time`` reads the layered pass's own curve the same way, for splatting with depth layers
beside layered tracing at equal time.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path

__all__ = ["equal_quality_speedup", "plot_layered", "ssim_at_time"]


def equal_quality_speedup(ssim: float, time_ms: float, mitsuba: dict) -> dict:
    """Mitsuba's time at ``ssim`` over ``time_ms``.

    Parameters
    ----------
    mitsuba : dict
        spp -> {"ssim", "time_ms"} of Mitsuba renders.

    Returns
    -------
    dict
        ``mitsuba_ms`` (interpolated, or the slowest measured one), ``speedup`` and ``bound``:
        ``"exact"`` (interpolated), ``"lower"`` (Mitsuba never reached ``ssim``: at least this) or
        ``"upper"`` (Mitsuba's fewest spp already beat it: at most this).
    """
    pts = sorted((float(v["time_ms"]), float(v["ssim"])) for v in mitsuba.values())
    t, s = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
    if ssim > s.max():
        ms, bound = float(t[np.argmax(s)]), "lower"
    elif ssim <= s[0]:
        ms, bound = float(t[0]), "upper"
    else:
        j = int(np.argmax(s >= ssim))          # first point at or above: interpolate from the one before
        f = (ssim - s[j - 1]) / (s[j] - s[j - 1])
        ms, bound = float(math.exp(math.log(t[j - 1]) + f * (math.log(t[j]) - math.log(t[j - 1])))), "exact"
    return {"mitsuba_ms": ms, "speedup": ms / time_ms, "bound": bound}


def ssim_at_time(time_ms: float, curve: list) -> dict:
    """The SSIM a method with points ``curve`` ([(time_ms, ssim), ...]) reaches in ``time_ms``,
    interpolated in log time; ``bound`` ``"exact"``, ``"faster"`` (``time_ms`` is below its
    fastest point: the SSIM given is that point's, more than it reaches) or ``"slower"`` (past its
    slowest: that point's SSIM, a lower bound)."""
    pts = sorted((float(t), float(s)) for t, s in curve)
    t, s = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
    if time_ms < t[0]:
        return {"ssim": float(s[0]), "time_ms": float(t[0]), "bound": "faster"}
    if time_ms >= t[-1]:
        return {"ssim": float(s[-1]), "time_ms": float(t[-1]), "bound": "slower"}
    j = int(np.argmax(t > time_ms))
    f = (math.log(time_ms) - math.log(t[j - 1])) / (math.log(t[j]) - math.log(t[j - 1]))
    return {"ssim": float(s[j - 1] + f * (s[j] - s[j - 1])), "time_ms": float(time_ms), "bound": "exact"}


def plot_layered(data: dict, path: Path) -> Path:
    """Quality against lens rays / spp and against time (the layered bench's ``data``) as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    peeled = sorted((m["rays"], m) for k, m in data["methods"].items() if k.startswith("peeled_"))
    mitsuba = sorted((int(k), v) for k, v in data["mitsuba_low_spp"].items())
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    left.plot([n for n, _ in peeled], [m["ssim"] for _, m in peeled], "o-", label="layered (peeled layers)")
    left.plot([n for n, _ in mitsuba], [m["ssim"] for _, m in mitsuba], "s--", label="Mitsuba (spp)")
    left.axhline(data["pinhole_input"]["ssim"], color="grey", lw=0.8, ls=":", label="pinhole input")
    left.set(xscale="log", xlabel="lens rays per pixel / Mitsuba spp", ylabel="SSIM vs reference",
             title="quality against samples (LES10 Fig. 7)")
    right.plot([m["time_ms"] for _, m in peeled], [m["ssim"] for _, m in peeled], "o-", label="layered")
    right.plot([m["time_ms"] for _, m in mitsuba], [m["ssim"] for _, m in mitsuba], "s--", label="Mitsuba")
    splats = sorted(data.get("equal_time", {}).items())
    if splats:
        right.plot([v["time_ms"] for _, v in splats], [v["ssim"] for _, v in splats], "^", color="C3",
                   label="spreadlets, depth layers")
        for i, (k, v) in enumerate(splats):   # staggered: the points often sit close together
            right.annotate(k.replace("spreadlets_", ""), (v["time_ms"], v["ssim"]), textcoords="offset points",
                           xytext=(4, 4 + 9 * (i % 3)), fontsize=7, color="C3")
    for n, m in peeled:
        right.annotate(f"{n}", (m["time_ms"], m["ssim"]), textcoords="offset points", xytext=(4, -10), fontsize=8)
    right.set(xscale="log", xlabel="time per frame (ms)", ylabel="SSIM vs reference", title="quality against time")
    for ax in (left, right):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{Path(data['scene']).name}: {data['input_layers']} peeled layers, "
                 f"{data['resolution'][0]}x{data['resolution'][1]}", fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return path
