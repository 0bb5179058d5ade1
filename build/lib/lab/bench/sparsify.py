"""Measure the sparsifier on analytic PSFs: seconds, sparsity and similarity vs radius and density.

``python -m lab.bench.sparsify [--radii 5,25,100,250] [--densities 0.5,1,2] [--rays N]
[--out DIR]`` prints a table, writes ``sparsify_bench.json`` and one check figure per radius
(PSF, Laplacian, spreadlets, reconstruction, error) to ``DIR`` (default /tmp/sparsify_check).
With ``--rays`` the discs are light-traced (multinomial histograms of N rays) first, as the PSF
tracer delivers them; similarity is then also reported against the noise-free disc.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from lab.sparsify import analytic
from lab.sparsify.figures import save_check_figure
from lab.sparsify.laplacian import psf_laplacian, working_box
from lab.sparsify.spreadlets import sparsify
from lab.sparsify.stats import similarity

__all__ = ["bench"]


def _histogram(psf: np.ndarray, rays: int, seed: int) -> np.ndarray:
    p = psf[..., 0].astype(np.float64).ravel()
    counts = np.random.default_rng(seed).multinomial(rays, p / p.sum())
    return (counts.reshape(psf.shape[:2]) / rays).astype(np.float32)[..., None]


def bench(radii=(5, 25, 100, 250), densities=(0.5, 1.0, 2.0), resolution: int = 512,
          width: float = 3.0, rays: int | None = None, out: str | Path | None = None,
          seed: int = 0) -> list[dict]:
    """Sparsify pre-filtered discs and time it.

    Parameters
    ----------
    radii : sequence of float
        Disc radii in px.
    densities : sequence of float
        ``density`` values passed to :func:`lab.sparsify.sparsify`.
    resolution : int, default 512
        PSF image edge in px.
    width : float, default 3.0
        Pre-filter ramp width in px.
    rays : int, optional
        Trace each disc with this many rays first (Monte Carlo noise as from the PSF tracer).
    out : str or Path, optional
        Directory for the check figures (density 1 only) and ``sparsify_bench.json``.
    seed : int, default 0
        Seed for the sparsifier (and the ray histogram).

    Returns
    -------
    list of dict
        One row per (radius, density): seconds, fast_track and the statistics.
    """
    rows = []
    for radius in radii:
        clean = analytic.prefiltered_disc(resolution, float(radius), width)
        psf = clean if rays is None else _histogram(clean, rays, seed)
        box = working_box(clean, psf_laplacian(clean))
        for density in densities:
            t = time.perf_counter()
            sp = sparsify(psf, density=float(density), seed=seed)
            row = dict(radius=float(radius), density=float(density),
                       seconds=time.perf_counter() - t, fast_track=sp.fast_track, **sp.stats)
            if rays is not None:
                row["ssim_clean"], row["l1_clean"] = similarity(
                    clean, sp.reconstruct(resolution), box)
            rows.append(row)
            if out is not None and density == 1.0:
                tag = f"disc_r{radius:g}" + ("" if rays is None else f"_rays{rays}")
                save_check_figure(psf, sp, Path(out) / f"{tag}.png",
                                  f"disc r={radius:g} px" + ("" if rays is None
                                                             else f", {rays:.2g} rays"))
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "sparsify_bench.json").write_text(json.dumps(rows, indent=1))
    return rows


def main(argv=None) -> None:
    """Command line entry: print the table of :func:`bench`."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--radii", default="5,25,100,250")
    ap.add_argument("--densities", default="0.5,1,2")
    ap.add_argument("--rays", type=int, default=None)
    ap.add_argument("--out", default="/tmp/sparsify_check")
    args = ap.parse_args(argv)
    rows = bench([float(r) for r in args.radii.split(",")],
                 [float(d) for d in args.densities.split(",")], rays=args.rays, out=args.out)
    extra = " ssim_clean" if args.rays else ""
    print(f"radius density  seconds fast n_points  n_dense sparsity   ssim     l1{extra}")
    for r in rows:
        print(f"{r['radius']:6g} {r['density']:7g} {r['seconds']:8.2f} {r['fast_track']!s:>5} "
              f"{r['n_points']:8.0f} {r['n_dense']:8.0f} {100 * r['sparsity']:7.2f}% "
              f"{r['ssim']:.4f} {r['l1']:.4f}" + (f" {r['ssim_clean']:.4f}" if args.rays else ""))


if __name__ == "__main__":
    main()
