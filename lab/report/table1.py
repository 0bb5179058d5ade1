"""LSR18 Table 1 ("The PSF model zoo") for our databases, beside the paper's figures.

Columns as in the paper: name, ns, colour, samples, beta, database size, mean sparsity; plus mean
similarity (SSIM of what is stored, LSR18 section 7.3), spreadlet and fast-track counts. Sparsity
is what the runtime draws per input pixel relative to dense splatting, averaged over samples:
spreadlets / nonzero dense pixels, and 100 % for a fast-tracked sample (it is splatted dense).
"Sparse only" averages the samples that are stored as spreadlets, as LSR18 Fig. 10 shows them: a
database whose small PSFs take the dense fast track counts them at 100 % in the mean.
This differs from ``splatlab db info``'s ``mean_sparsity``, which averages the sparsifier's point
count also where the fast track won (> 100 % there). Size is the file size (the paper's is its
GPU buffer size).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path

__all__ = ["LSR18_TABLE1", "table1_row", "table1_markdown", "write_table1"]

# LSR18 Tbl. 1: ns, colour, samples, beta, size (MB), sparsity (%).
LSR18_TABLE1 = {
    "simplelens": (1, False, 100, [2.0], 1.1, 31.3),
    "combined": (2, False, 400, [2.0, 1.0], 4.2, 9.3),
    "physicallens": (2, True, 4000, [2.5, 1.2], 30.8, 2.2),
    "volume": (1, True, 200, [1.0], 5.3, 18.4),
    "stylized": (1, True, 200, [1.5], 9.0, 24.9),
}


def _paper_key(model: str) -> str:
    return model.lower().replace("_", "").replace("-", "")


def _drawn_fraction(db) -> np.ndarray:
    """Per sample: splats drawn / nonzero dense pixels (1 for fast-tracked samples)."""
    if "drawn" in db.stats and "n_dense" in db.stats:
        return db.stats["drawn"].astype(np.float64) / np.maximum(db.stats["n_dense"], 1)
    return np.where(db.fast_track, 1.0, db.stats["sparsity"])


def table1_row(db) -> dict:
    """Our Table 1 row for a loaded :class:`~runtime_cl.psf.database.SpreadletDatabase`."""
    size = os.path.getsize(db.path) if db.path and os.path.exists(db.path) else db.nbytes()
    drawn = _drawn_fraction(db)
    row = {"model": db.model, "ns": db.grid.ns, "color": db.channels == 3, "samples": db.n_samples,
           "beta": list(db.grid.beta), "size_MB": size / 1e6,
           "mean_sparsity_percent": 100.0 * float(np.mean(drawn)),
           "sparse_only_sparsity_percent": (100.0 * float(np.mean(drawn[~db.fast_track]))
                                            if not db.fast_track.all() else None),
           "mean_similarity_ssim": float(np.mean(db.stats["ssim"])),
           "spreadlets": db.n_spreadlets, "fast_track": int(db.fast_track.sum()),
           "psf_resolution": int(db.psf_resolution), "hash": db.params.get("hash")}
    paper = LSR18_TABLE1.get(_paper_key(db.model))
    if paper:
        row["lsr18"] = dict(zip(("ns", "color", "samples", "beta", "size_MB", "mean_sparsity_percent"),
                                paper))
    return row


def table1_markdown(rows: list[dict]) -> str:
    """Rows of :func:`table1_row` as a markdown table, each followed by LSR18's row if known."""
    head = ("| model | ns | colour | samples | beta | size | sparsity | sparse only | similarity (SSIM) "
            "| spreadlets | fast track |\n|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        beta = ", ".join(f"{b:g}" for b in r["beta"])
        only = r.get("sparse_only_sparsity_percent")
        sparse = "all fast-tracked" if only is None else f"{only:.1f} %"
        lines.append(f"| {r['model']} (ours) | {r['ns']} | {'yes' if r['color'] else 'no'} | {r['samples']} "
                     f"| {beta} | {r['size_MB']:.2f} MB | {r['mean_sparsity_percent']:.1f} % | {sparse} "
                     f"| {r['mean_similarity_ssim']:.3f} | {r['spreadlets']} | {r['fast_track']} |")
        p = r.get("lsr18")
        if p:
            pbeta = ", ".join(f"{b:g}" for b in p["beta"])
            lines.append(f"| {r['model']} (LSR18) | {p['ns']} | {'yes' if p['color'] else 'no'} "
                         f"| {p['samples']} | {pbeta} | {p['size_MB']} MB | {p['mean_sparsity_percent']} % | "
                         "| .97 (mean over all models) | | |")
    return head + "\n".join(lines) + "\n"


def _atomic_text(path: Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_table1(rows: list[dict], out_dir, name: str = "table1") -> tuple[Path, Path]:
    """Write ``<name>.md`` and ``<name>.json`` into ``out_dir``; returns both paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md, js = out / f"{name}.md", out / f"{name}.json"
    _atomic_text(md, "LSR18 Table 1 (the PSF model zoo) for this build\n\n" + table1_markdown(rows))
    _atomic_text(js, json.dumps({"rows": rows}, indent=2))
    return md, js
