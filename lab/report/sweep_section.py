"""The sweep's part of a scene report: run it, mark the Pareto fronts, plot, describe."""
from __future__ import annotations

from .pareto import front_sentence, pareto_front
from .sweep_plots import SCORES, accuracy_time_plot

__all__ = ["add_sweep", "describe_sweep", "PLOT"]

PLOT = "sweep_accuracy_vs_time.png"


def _sentences(points) -> dict:
    return {"ssim": front_sentence(points, "ssim", "SSIM", 3), "psnr": front_sentence(points, "psnr", "PSNR", 2, " dB")}


def add_sweep(report: dict, scene, plan, image, reference, reference_b, databases, knobs, out_dir,
              executor=None, progress: bool = True) -> None:
    """Run the sweep of ``scene`` (:func:`lab.report.sweep.run_sweep`) and put it into ``report``:
    ``report["sweep"]`` (points, each with ``on_front`` per score, the skipped knobs, the front
    sentences) and the plot ``sweep_accuracy_vs_time.png`` in ``out_dir``."""
    from .sweep import run_sweep

    sweep = run_sweep(scene, plan, image, reference, reference_b, databases, knobs, executor, progress)
    points = sweep["points"]
    swept = {p["method"] for p in points}
    for name, m in report["methods"].items():   # a method no knob turns is on the plot as the report ran it
        if name not in swept:
            points.append({"method": name, "knob": None, "key": None, "value": None, "base": True,
                           "time_ms": m["time_ms"], "ssim": m["ssim"], "psnr": m["psnr"],
                           "noise_corrected_psnr": m.get("noise_corrected_psnr"),
                           "timing": "runtime contract (median time_ms), the report's own run"})
    for key, _ in SCORES:
        front = set(pareto_front(points, score_key=key))
        for i, p in enumerate(points):
            p.setdefault("on_front", {})[key] = i in front
    sweep["sentences"] = _sentences(points)
    if points:
        accuracy_time_plot(points, out_dir / PLOT, f"{scene.name}: accuracy vs time, every knob")
        sweep["plot"] = PLOT
    report["sweep"] = sweep


def describe_sweep(sweep: dict) -> str:
    """The sweep as the CLI prints it: one line per point, the skipped knobs, the fronts."""
    lines = [f"  sweep: {len(sweep['points'])} points"]
    for p in sweep["points"]:
        nc = p.get("noise_corrected_psnr")
        star = "*" if p["on_front"]["ssim"] else " "
        value = "" if p["value"] is None else str(p["value"])
        lines.append(f"  {star} {p['method']:<12} {p['knob'] or 'as planned':<15} {value:>9}  {p['time_ms']:10.2f} ms"
                     f"   SSIM {p['ssim']:.4f}   PSNR {p['psnr']:.2f} dB"
                     + (f"   noise-corrected {nc:.2f} dB" if nc is not None else ""))
    for s in sweep["skipped"]:
        lines.append(f"    skipped {s['method']} / {s['knob']}: {s['reason']}")
    lines += [f"  {s}" for s in sweep.get("sentences", {}).values()]
    lines.append("  (* on the SSIM Pareto front)")
    return "\n".join(lines)
