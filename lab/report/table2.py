"""LSR18 Table 2 reproduced: several scene reports side by side, the paper's figures beside ours.

``splatlab report SCENE SCENE ...`` writes each scene's own report and then this summary: for
every scene, Filter / Splat / spreadlets (time and SSIM), the reference's render time, and the
speed-up of spreadlets over Splat measured in the same run; where the scene is one of the
paper's, its row of LSR18 Table 2 sits beside ours (their times: a GTX 980 Ti; ours: this CPU).
"""
from __future__ import annotations

import html
import json
import os
from datetime import datetime, timezone
from pathlib import Path

from runtime_cl.atomic_file import atomic_path

from .html import STYLE, _fmt
from .machine import machine_info
from .metrics import CONVERGED_FLOOR

__all__ = ["LSR18_TABLE2", "summary", "write_summary"]

METHODS = ("filter", "splat", "spreadlets")
# LSR18 Table 2 (synthesis, 1024x1024, Xeon E5-1607 + GTX 980 Ti): PSF model, then per method
# (time ms, SSIM), and the reference's time. None where the paper gives no figure.
LSR18_TABLE2 = {
    "whirl": {"model": "combined", "spreadlets": (88.0, 0.94), "filter": (299.6, 0.81),
              "splat": (722.8, 0.94), "reference": "592 s"},
    "coins": {"model": "combined", "spreadlets": (163.0, 0.96), "filter": (368.1, 0.92),
              "splat": (1930.9, 0.96), "reference": "232 s"},
    "rain": {"model": "physical_lens", "spreadlets": (126.3, 0.90), "filter": None,
             "splat": (7170.4, 0.88), "reference": "> 1000 s"},
    "gears": {"model": "combined", "spreadlets": (65.9, 0.94), "filter": (186.2, 0.87),
              "splat": (783.8, 0.96), "reference": "> 1000 s"},
}


def _row(report: dict) -> dict:
    """One scene's figures from its report.json."""
    methods = report["methods"]
    row = {"scene": report["scene"]["name"], "models": report["plan"]["psf_models"],
           "effects": report["plan"]["effects"],
           "reference_s": report["reference"].get("reference_s"),
           "reference_spp": report["reference"].get("reference_spp")}
    for name in METHODS:
        m = methods.get(name)
        row[name] = None if m is None else {"time_ms": m["time_ms"], "ssim": m["ssim"], "psnr": m["psnr"]}
    if row["splat"] and row["spreadlets"] and row["spreadlets"]["time_ms"]:
        row["speedup_vs_splat"] = row["splat"]["time_ms"] / row["spreadlets"]["time_ms"]
    noise = report["reference"].get("noise_floor")
    if noise is not None:
        row["noise_floor"] = noise
    row["paper"] = LSR18_TABLE2.get(row["scene"])
    return row


def summary(reports: list[dict]) -> dict:
    """The summary dictionary (``report.json`` of the Table 2 page) of several scene reports."""
    return {"schema": 1, "kind": "table2",
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "about": "LSR18 Table 2 reproduced: time (median wall time of a render call) and SSIM on the "
                     "stated tonemap against the path-traced reference; the paper's figures are from a "
                     "GTX 980 Ti, ours from this CPU (PoCL), so compare the ratios, not the times.",
            "tonemap": reports[0]["tonemap"] if reports else None,
            "scenes": [_row(r) for r in reports], "machine": machine_info()}


def _cell(entry) -> tuple[str, str]:
    if entry is None:
        return "&ndash;", "&ndash;"
    if isinstance(entry, tuple):
        return f"{entry[0]:.1f}", f"{entry[1]:.2f}"
    return f"{entry['time_ms']:.1f}", f"{entry['ssim']:.3f}"


def _floor(noise) -> str:
    if not noise:
        return "not measured"
    low = noise["ssim"] < CONVERGED_FLOOR
    return f"{noise['ssim']:.3f}" + (f" (below {CONVERGED_FLOOR}: not converged enough to validate)" if low else "")


def render_html(data: dict, links: dict) -> str:
    """The Table 2 page; ``links`` maps a scene name to its report page (relative URL)."""
    head = ("<tr><th rowspan=2>scene</th><th rowspan=2>model</th><th rowspan=2>source</th>"
            + "".join(f"<th colspan=2>{m}</th>" for m in ("Filter", "Splat", "spreadlets (ours)"))
            + "<th rowspan=2>spreadlets vs Splat</th><th rowspan=2>reference</th>"
              "<th rowspan=2>reference noise floor (SSIM of two seeds)</th></tr><tr>"
            + "<th>ms</th><th>SSIM</th>" * 3 + "</tr>")
    body = []
    for row in data["scenes"]:
        name = html.escape(row["scene"])
        link = f"<a href='{html.escape(links[row['scene']])}'>{name}</a>" if row["scene"] in links else name
        cells = [c for m in METHODS for c in _cell(row[m])]
        speed = row.get("speedup_vs_splat")
        noise = row.get("noise_floor")
        ours = ([link, html.escape(", ".join(row["models"])), "splatlab"] + cells
                + [f"{speed:.1f}&times;" if speed else "&ndash;",
                   f"{_fmt(row['reference_s'])} s, {row['reference_spp']} spp",
                   _floor(noise)])
        body.append("<tr>" + "".join(f"<td>{c}</td>" for c in ours) + "</tr>")
        paper = row.get("paper")
        if paper:
            cells = [c for m in METHODS for c in _cell(paper[m])]
            t = [paper[m][0] for m in ("splat", "spreadlets") if paper[m]]
            ratio = f"{t[0] / t[1]:.1f}&times;" if len(t) == 2 else "&ndash;"
            body.append("<tr style='color:#666'>" + "".join(
                f"<td>{c}</td>" for c in ["", html.escape(paper["model"]), "LSR18 Table 2"] + cells
                + [ratio, html.escape(paper["reference"]), ""]) + "</tr>")
    return "\n".join([
        f"<!doctype html><html><head><meta charset='utf-8'><title>splatlab: LSR18 Table 2</title>"
        f"<style>{STYLE}</style></head><body><h1>LSR18 Table 2, reproduced</h1>",
        f"<p>{html.escape(data['about'])} Tonemap: <code>{html.escape(str(data['tonemap']))}</code>.</p>",
        f"<table>{head}{''.join(body)}</table>",
        f"<h2>Machine</h2><pre>{html.escape(json.dumps(data['machine'], indent=2))}</pre></body></html>"])


def write_summary(reports: list[dict], report_dirs: list[Path], out_dir) -> Path:
    """Write ``report.json`` and ``index.html`` of the Table 2 page into ``out_dir`` (atomically);
    returns the HTML path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = summary(reports)
    links = {r["scene"]["name"]: os.path.relpath(Path(d).resolve() / "index.html", out_dir.resolve())
             for r, d in zip(reports, report_dirs)}
    for name, text in (("report.json", json.dumps(data, indent=2, allow_nan=True)),
                       ("index.html", render_html(data, links))):
        with atomic_path(out_dir / name) as tmp:
            tmp.write_text(text)
    return out_dir / "index.html"
