"""index.html beside report.json (the page itself is :mod:`lab.report.page`); the style and
cell format the Table 2 page shares."""
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


def render_html(report: dict) -> str:
    """The report page for a report.json dictionary (:func:`lab.report.page.render_page`)."""
    from .page import render_page

    return render_page(report)


def write_report(report: dict, out_dir) -> Path:
    """Write report.json and index.html atomically into ``out_dir``; returns the HTML path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, text in (("report.json", json.dumps(report, indent=2, allow_nan=True)),
                       ("index.html", render_html(report))):
        with atomic_path(out_dir / name) as tmp:
            tmp.write_text(text)
    return out_dir / "index.html"
