"""The papers' published accuracy and time figures, by our method name, for the report page.

Each row: the paper, where in it (table and page or section), its scene and setting, its time
(on its own GPU), SSIM and PSNR; None where the paper gives no figure. The texts are in
``shared/papers/`` (see ``DESIGN.md``). The times are the papers' GPUs', so a page compares
accuracy and time ratios, never times across machines.
"""
from __future__ import annotations

from .table2 import LSR18_TABLE2

__all__ = ["PUBLISHED", "published_for", "published_range"]


def _lsr18() -> list[dict]:
    rows = []
    for scene, entry in LSR18_TABLE2.items():
        for method in ("spreadlets", "splat", "filter"):
            if entry.get(method) is None:
                continue
            t, s = entry[method]
            rows.append({"paper": "LSR18", "where": "Table 2 (Sec. 7.2, synthesis of Fig. 8)", "scene": scene,
                         "method": method, "setting": f"{entry['model']} model, 1024x1024, GTX 980 Ti",
                         "time_ms": t, "ssim": s, "psnr": None})
    return rows


# LES10 Table 1 (p. 65:5): 100 lens rays, 4 layers, 800x600, GTX 285, PRE + RT total; quality
# against the accumulation-buffer reference (Haeberli and Akeley 1990).
_LES10 = (("Town (98K tri.)", 10.0, 34.8, 0.98), ("Angels (407K tri.)", 24.0, 36.9, 0.97),
          ("Dragon (935K tri.)", 31.0, 35.0, 0.98))

PUBLISHED: list[dict] = _lsr18() + [
    {"paper": "LES10", "where": "Table 1 (p. 65:5)", "scene": scene, "method": "layered",
     "setting": "100 lens rays, 4 layers, 800x600, GTX 285", "time_ms": t, "ssim": s, "psnr": p}
    for scene, t, p, s in _LES10
] + [
    {"paper": "MHU21", "where": "Sec. 1 and Sec. 3", "scene": "any (uniform and depth-varying blur)",
     "method": "polygon", "setting": "exact: the same output as brute-force polygon filtering; times only "
     "as plots (Figs. 8-9, CPU, r = 60 px)", "time_ms": None, "ssim": 1.0, "psnr": None},
]


def published_for(method: str) -> list[dict]:
    """The published rows of our method ``method`` (a report label; ``label:model`` uses the label)."""
    label = method.split(":")[0]
    base = "polygon" if label.startswith("polygon") else label
    return [r for r in PUBLISHED if r["method"] == base]


def published_range(method: str) -> str:
    """A short 'paper: SSIM lo-hi' note for the methods table, or '' when no paper has figures."""
    rows = [r for r in published_for(method) if r["ssim"] is not None]
    if not rows:
        return ""
    papers = sorted({r["paper"] for r in rows})
    lo, hi = min(r["ssim"] for r in rows), max(r["ssim"] for r in rows)
    span = f"{lo:.2f}" if lo == hi else f"{lo:.2f}-{hi:.2f}"
    psnrs = [r["psnr"] for r in rows if r["psnr"] is not None]
    extra = f", PSNR {min(psnrs):.1f}-{max(psnrs):.1f} dB" if psnrs else ""
    return f"{'/'.join(papers)} {rows[0]['where'].split(' (')[0]}: SSIM {span}{extra}"
