"""Throughput of the three render methods on the synthetic disc database.

Kernel times come from OpenCL event profiling, best of ``repeats`` after one warm-up render,
so they do not include compilation or other processes' bursts on a shared machine. Usable
without the lab: ``python -m runtime_cl.bench`` prints the figures as JSON.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from .device import Device, get_device
from .errors import InputError
from .render import METHODS, Renderer
from .synthetic import disc_database


def bench_scene(db, height: int, width: int, channels: int, spreadlets: int, layout: str, seed: int):
    """Colour and PSF coordinates whose cells all have ``spreadlets`` spreadlets.

    ``layout`` "ramp": coordinates grow smoothly along the image diagonal (a depth ramp);
    "random": independent per pixel (worst case for caches).
    """
    counts = np.diff(db.C)
    full = np.nonzero(counts >= spreadlets)[0]
    if not len(full):
        raise InputError(f"spreadlets = {spreadlets}: no cell of the database has that many; "
                         f"the largest has {int(counts.max())}")
    lo = float(db.grid.from_grid([full[0] * (full[0] + 1) / 2.0 + 1e-3])[0])  # cell start, 1-D grid
    hi = db.grid.ranges[0][1]
    rng = np.random.default_rng(seed)
    colour = rng.random((height, width, channels)).astype(np.float32)
    if layout == "ramp":
        yy, xx = np.mgrid[0:height, 0:width]
        t = (xx + yy) / max(height + width - 2, 1)
    elif layout == "random":
        t = rng.random((height, width))
    else:
        raise InputError(f"layout = {layout!r}: must be 'ramp' or 'random'")
    coords = (lo + t * (hi - lo)).astype(np.float32)[..., None]
    return colour, coords


def run(height: int = 1024, width: int = 1024, spreadlets: int = 50, r_max: float = 32.0,
        channels: int = 3, methods=METHODS, layout: str = "ramp", repeats: int = 3, seed: int = 0,
        device: Device | None = None) -> dict:
    """Render the benchmark scene with each method and report times and rates.

    Parameters
    ----------
    height, width : int
        Image size in pixels (default 1024^2).
    spreadlets : int
        Spreadlets per pixel (default 50: every cell keeps its 50 largest Laplacian values).
    r_max : float
        Largest CoC radius in pixels (default 32); the dense PSFs are discs up to this radius.
    channels : int
        Colour channels, 1 or 3 (default 3).
    methods : sequence of str
        Any of ``spreadlets``, ``splat``, ``filter``.
    layout : {"ramp", "random"}
        How PSF coordinates vary over the image (see :func:`bench_scene`).
    repeats : int
        Timed renders per method after one warm-up; the fastest kernel time is kept.

    Returns
    -------
    dict
        ``device`` (:meth:`Device.describe`), ``settings`` and per method the best render's
        timings plus ``M_spreadlets_per_s`` (spreadlets / splat kernel time) and
        ``M_dense_pixels_per_s`` (dense PSF pixels / kernel time).
    """
    device = device or get_device()
    db = disc_database(r_max, samples=32, max_spreadlets=spreadlets)
    colour, coords = bench_scene(db, height, width, channels, spreadlets, layout, seed)
    renderer = Renderer(db, device)
    out = {"device": device.describe(),
           "settings": {"height": height, "width": width, "spreadlets": spreadlets, "r_max": r_max,
                        "channels": channels, "layout": layout, "repeats": repeats},
           "methods": {}}
    for method in methods:
        _, first = renderer.render(colour, coords, method)  # warm-up; carries the compile time
        best = None
        for _ in range(repeats):
            _, t = renderer.render(colour, coords, method)
            best = t if best is None or t["kernel_ms"] < best["kernel_ms"] else best
        best["compile_ms"] = first["compile_ms"]
        splat_ms = best.get("splat_ms", best["kernel_ms"])
        best["M_spreadlets_per_s"] = best["spreadlets"] / splat_ms / 1e3 if best["spreadlets"] else 0.0
        best["M_dense_pixels_per_s"] = best["dense_pixels"] / best["kernel_ms"] / 1e3 if best["dense_pixels"] else 0.0
        out["methods"][method] = best
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=1024)
    p.add_argument("--spreadlets", type=int, default=50)
    p.add_argument("--r-max", type=float, default=32.0)
    p.add_argument("--channels", type=int, default=3, choices=(1, 3))
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--layout", default="ramp", choices=("ramp", "random"))
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args(argv)
    print(json.dumps(run(a.size, a.size, a.spreadlets, a.r_max, a.channels, a.methods.split(","), a.layout,
                         a.repeats), indent=1))


if __name__ == "__main__":
    main()
