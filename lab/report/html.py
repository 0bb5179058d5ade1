"""index.html beside report.json: images side by side, tables, plots."""
from __future__ import annotations

import html
import json
from pathlib import Path

from runtime_cl.atomic_file import atomic_path

STYLE = """
body{font-family:system-ui,sans-serif;margin:2em;max-width:1400px;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 10px;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
.grid{display:flex;flex-wrap:wrap;gap:12px}.grid figure{margin:0;width:320px}
.grid img{width:320px;image-rendering:pixelated;border:1px solid #ddd}figcaption{font-size:.85em}
.bad{color:#b00;font-weight:bold}pre{background:#f7f7f7;padding:1em;overflow:auto;font-size:.8em}
"""


def _fmt(value, digits=4):
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return html.escape(str(value))


def _table(headers, rows) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _figure(src, caption) -> str:
    return (f'<figure><a href="{html.escape(src)}"><img src="{html.escape(src)}" alt="{html.escape(caption)}">'
            f"</a><figcaption>{html.escape(caption)}</figcaption></figure>")


def render_html(report: dict) -> str:
    """The report page for a report.json dictionary (see ``lab.pipeline`` for its fields)."""
    scene = report["scene"]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>splatlab: {html.escape(scene['name'])}"
             f"</title><style>{STYLE}</style></head><body>",
             f"<h1>splatlab report: {html.escape(scene['name'])}</h1>",
             f"<p>{scene['resolution'][0]}&times;{scene['resolution'][1]} px, camera "
             f"<code>{html.escape(json.dumps(scene['camera']))}</code>. Metrics on the tonemap "
             f"<code>{html.escape(report['tonemap'])}</code> against the Mitsuba reference.</p>"]
    if report.get("regressions"):
        items = "".join(f"<li>{html.escape(r)}</li>" for r in report["regressions"])
        parts.append(f"<h2 class='bad'>Regressions against the baseline</h2><ul class='bad'>{items}</ul>")
    methods = report["methods"]
    columns = ("time_ms", "device_ms", "transfer_ms", "host_ms", "compile_ms", "prepare_ms")
    rows = [[name] + [m[c] for c in columns] + [m["ssim"], m["psnr"]] for name, m in methods.items()]
    heads = ["method", "time [ms]", "device [ms]", "transfers [ms]", "host [ms]", "set-up [ms] (excluded)",
             "prepare [ms] (excluded)", "SSIM", "PSNR [dB]"]
    floor = report.get("reference", {}).get("noise_floor")
    if floor and all("noise_corrected_mse" in m for m in methods.values()):
        heads.append("noise-corrected PSNR [dB]")
        for row, m in zip(rows, methods.values()):
            row.append(m["noise_corrected_psnr"] if m["noise_corrected_psnr"] is not None else "below the noise")
    parts.append("<h2>Methods</h2>" + _table(heads, rows))
    if floor:
        parts.append(f"<p>Noise floor: two references with independent seeds agree at SSIM {floor['ssim']:.4f}, "
                     f"PSNR {floor['psnr']:.2f} dB; no method can score above that against one of them. The "
                     "noise-corrected PSNR is that of the method's MSE against the references' expectation: "
                     "its MSE against their mean less their own noise variance, estimated from their "
                     "difference (lab.report.metrics.noise_corrected_mse).</p>")
    timing = report.get("timing", {})
    if isinstance(timing, dict):
        items = "".join(f"<li><code>{html.escape(k)}</code>: {html.escape(v)}</li>" for k, v in timing.items())
        parts.append(f"<p>Timing columns:</p><ul>{items}</ul>")
    if report.get("plots"):
        parts.append("<div class='grid'>" + "".join(_figure(p, c) for c, p in report["plots"].items()) + "</div>")
    figs = [_figure(src, name) for name, src in report["images"].items()]
    for name, m in methods.items():
        figs.append(_figure(m["image"], f"{name}: SSIM {m['ssim']:.3f}, {m['time_ms']:.1f} ms"))
        figs.append(_figure(m["error_image"], f"{name}: |error| (tonemapped, x{m['error_scale']:g})"))
    parts.append("<h2>Images</h2><div class='grid'>" + "".join(figs) + "</div>")
    for title, key in (("PSF database", "database"), ("Reference", "reference"), ("Plan", "plan"),
                       ("Settings", "settings"), ("Machine", "machine")):
        if key in report:
            parts.append(f"<h2>{title}</h2><pre>{html.escape(json.dumps(report[key], indent=2))}</pre>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(report: dict, out_dir) -> Path:
    """Write report.json and index.html atomically into ``out_dir``; returns the HTML path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, text in (("report.json", json.dumps(report, indent=2, allow_nan=True)),
                       ("index.html", render_html(report))):
        with atomic_path(out_dir / name) as tmp:
            tmp.write_text(text)
    return out_dir / "index.html"
