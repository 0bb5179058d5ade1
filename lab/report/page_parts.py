"""Building blocks of the report page: its style, sortable tables, key/value tables, figures.

No CDN and no network: the style and the few lines of sorting script are inline, so the page
works from the file system and offline.
"""
from __future__ import annotations

import html
import math

__all__ = ["PAGE_STYLE", "SORT_SCRIPT", "fmt", "sortable", "key_values", "figure", "esc"]

PAGE_STYLE = """
:root{--ink:#1d232a;--soft:#5b6570;--line:#dde2e7;--head:#f2f4f7;--accent:#2b6cb0}
body{font:15px/1.55 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0;color:var(--ink);background:#fbfcfd}
main{max-width:1320px;margin:0 auto;padding:1.5em 2em 4em}
h1{font-size:1.7em;margin:.2em 0}h2{font-size:1.25em;margin:2em 0 .6em;border-bottom:2px solid var(--line);padding-bottom:.2em}
h3{font-size:1.02em;margin:1.2em 0 .4em}p.lead{color:var(--soft);max-width:75em}
nav{position:sticky;top:0;background:#fbfcfdee;border-bottom:1px solid var(--line);padding:.5em 2em;font-size:.9em;z-index:2}
nav a{margin-right:1.1em;color:var(--accent);text-decoration:none}
table{border-collapse:collapse;margin:.6em 0 1em;font-size:.9em;background:#fff}
td,th{border:1px solid var(--line);padding:4px 9px;text-align:right;vertical-align:top}
th{background:var(--head);font-weight:600;text-align:left;vertical-align:bottom}td:first-child{text-align:left}
td.text,th.text{text-align:left}
table.sortable th{cursor:pointer;user-select:none}table.sortable th:after{content:" \\2195";color:#aab}
table.sortable th[data-dir=asc]:after{content:" \\2191";color:var(--ink)}
table.sortable th[data-dir=desc]:after{content:" \\2193";color:var(--ink)}
tr.front td{background:#eef7ee}tr.base td:first-child{font-weight:600}
.plot img{width:100%;max-width:1300px;border:1px solid var(--line);background:#fff}
.caption{color:var(--soft);font-size:.93em;margin:.3em 0 1.2em;max-width:75em}
.grid{display:flex;flex-wrap:wrap;gap:14px;margin-bottom:14px}.grid figure{margin:0;width:290px}
.grid img{width:290px;image-rendering:pixelated;border:1px solid var(--line);background:#fff}
.pair{display:flex;gap:8px;padding:8px;background:#fff;border:1px solid var(--line)}
.pair figure,.pair img{width:276px}
figcaption{font-size:.83em;color:var(--soft)}
.strip{display:flex;gap:10px;flex-wrap:wrap;align-items:flex-start;margin-bottom:1em}
.strip figure{margin:0}.strip img{width:200px;height:200px;image-rendering:pixelated;border:1px solid var(--line)}
.overview img{width:512px;max-width:100%;image-rendering:pixelated;border:1px solid var(--line)}
.bad{color:#b00;font-weight:600}details{margin:.5em 0}summary{cursor:pointer;color:var(--accent)}
code{font-size:.92em;background:#f0f2f5;padding:0 3px;border-radius:3px}
"""

# Click a header: sort its table's rows by that column (numbers by value, text after), again: reverse.
SORT_SCRIPT = """
document.querySelectorAll("table.sortable").forEach(function (t) {
  t.querySelectorAll("thead th").forEach(function (th, i) {
    th.addEventListener("click", function () {
      var asc = th.dataset.dir !== "asc", body = t.tBodies[0];
      t.querySelectorAll("thead th").forEach(function (h) { delete h.dataset.dir; });
      th.dataset.dir = asc ? "asc" : "desc";
      var key = function (row) {
        var c = row.cells[i], v = c.dataset.v !== undefined ? c.dataset.v : c.textContent, n = parseFloat(v);
        return isNaN(n) ? [1, v] : [0, n];
      };
      Array.from(body.rows).sort(function (a, b) {
        var x = key(a), y = key(b), d = x[0] - y[0] || (x[1] < y[1] ? -1 : x[1] > y[1] ? 1 : 0);
        return asc ? d : -d;
      }).forEach(function (r) { body.appendChild(r); });
    });
  });
});
"""


def esc(value) -> str:
    return html.escape(str(value))


def fmt(value, digits: int = 4) -> str:
    """A cell's text: floats to ``digits`` significant digits, None as a dash, the rest as text."""
    if value is None:
        return "&ndash;"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if not math.isfinite(value):
            return esc(value)
        return f"{value:.{digits}g}" if abs(value) < 1e6 else f"{value:.3e}"
    if isinstance(value, (list, tuple)):
        return esc(", ".join(str(v) for v in value))
    return esc(value)


def _cell(value, digits) -> str:
    sort_key = f' data-v="{value!r}"' if isinstance(value, (int, float)) and not isinstance(value, bool) \
        and math.isfinite(value) else ""
    cls = "" if isinstance(value, (int, float)) or value is None else ' class="text"'
    return f"<td{cls}{sort_key}>{fmt(value, digits)}</td>"


def sortable(headers, rows, row_classes=None, digits: int = 4, table_id: str | None = None) -> str:
    """A table whose columns sort on a click (:data:`SORT_SCRIPT`); ``rows`` of plain values."""
    head = "".join(f"<th>{esc(h)}</th>" for h in headers)
    classes = row_classes or [""] * len(rows)
    body = "".join(f'<tr class="{c}">' + "".join(_cell(v, digits) for v in row) + "</tr>"
                   for row, c in zip(rows, classes))
    ident = f' id="{esc(table_id)}"' if table_id else ""
    return f'<table class="sortable"{ident}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _flat(data, prefix="") -> list[tuple[str, object]]:
    """Nested dicts as (dotted key, value) rows; short lists of numbers stay one value."""
    rows = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            rows += _flat(value, name + ".")
        else:
            rows.append((name, value))
    return rows


def key_values(data: dict) -> str:
    """A two-column table of ``data`` (nested keys dotted), a readable view of JSON."""
    rows = "".join(f'<tr><th class="text">{esc(k)}</th><td class="text">{fmt(v)}</td></tr>'
                   for k, v in _flat(data))
    return f"<table>{rows}</table>"


def figure(src: str, caption: str) -> str:
    return (f'<figure><a href="{esc(src)}"><img src="{esc(src)}" alt="{esc(caption)}"></a>'
            f"<figcaption>{esc(caption)}</figcaption></figure>")
