"""Throughput of the three render methods on synthetic disc databases.

Two kinds of scene: ``ramp``/``random`` give every pixel a PSF with exactly ``spreadlets``
spreadlets (the kernel's raw rate at a chosen count); ``defocus`` is laid out like a shallow
depth-of-field photograph (:func:`runtime_cl.psf.synthetic.defocus_scene`: most pixels with CoC
radii of 0.55-0.9 ``r_max``, some in focus) and uses the exact Laplacian of every disc, so the
spreadlets-vs-Splat ratio is the one a real scene with such PSFs would see. With the command
line's defaults (r_max 100, discs with a 1-pixel soft rim) a disc of radius 80 has 1884
spreadlets against ~20 600 dense pixels (the non-zero part of its 163^2 crop, which is all the
Splat baseline adds).

Kernel times come from OpenCL event profiling, best of ``repeats`` after one warm-up render,
so they do not include compilation or other processes' bursts on a shared machine. Usable
from the shell: ``python -m lab.bench.spreadlet_throughput`` prints the figures as JSON (``--rotation``: the
cost of per-pixel PSF rotation, :func:`rotation`).
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from runtime_cl.device.opencl import Device, get_device
from runtime_cl.errors import InputError
from runtime_cl.spreadlets.renderer import METHODS, Renderer
from runtime_cl.spreadlets.splat import RUN_MAX
from runtime_cl.psf.synthetic import defocus_scene, disc_database

LAYOUTS = ("ramp", "random", "defocus")


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


def run(height: int = 1024, width: int = 1024, spreadlets: int | None = 50, r_max: float = 32.0,
        channels: int = 3, methods=tuple(METHODS), layout: str = "ramp", repeats: int = 3, seed: int = 0,
        device: Device | None = None, samples: int = 32, run_max: int = RUN_MAX, edge: float = 0.0) -> dict:
    """Render the benchmark scene with each method and report times and rates.

    Parameters
    ----------
    height, width : int
        Image size in pixels (default 1024^2).
    spreadlets : int or None
        ``ramp``/``random``: spreadlets per pixel (default 50: every cell keeps its 50 largest
        Laplacian values). ``defocus``: None (exact Laplacians) or a cap per cell.
    r_max : float
        Largest CoC radius in pixels (default 32); the dense PSFs are discs up to this radius.
    channels : int
        Colour channels, 1 or 3 (default 3).
    methods : sequence of str
        Any of ``spreadlets``, ``splat``, ``filter``.
    layout : {"ramp", "random", "defocus"}
        How PSF coordinates vary over the image (see :func:`bench_scene` and the module).
    repeats : int
        Timed renders per method after one warm-up; the fastest kernel time is kept.
    samples : int
        PSF samples (cells) of the disc database (default 32).
    run_max : int
        Longest same-cell pixel run the splat kernels batch (default 32; 1: pixel by pixel).
    edge : float
        Soft rim of the discs in pixels (default 0: hard discs; see
        :func:`runtime_cl.psf.synthetic.disc_psf`): more exact spreadlets per PSF.

    Returns
    -------
    dict
        ``device`` (:meth:`Device.describe`), ``settings``, per method the best render's
        timings plus ``M_spreadlets_per_s`` (spreadlets / splat kernel time),
        ``M_dense_pixels_per_s`` (dense PSF pixels / kernel time) and ``method_ms`` (kernel +
        integration + transfers); with both splat methods, ``ratios``: Splat over spreadlets
        for kernel and method times, and the integration's share of the spreadlet method.
    """
    device = device or get_device()
    if layout == "defocus":
        db = disc_database(r_max, samples=samples, max_spreadlets=spreadlets, edge=edge)
        colour, coords = defocus_scene(height, width, r_max, channels, seed)
    elif spreadlets is None:
        raise InputError(f"layout = {layout!r} needs a spreadlet count per pixel (spreadlets=None)")
    else:
        db = disc_database(r_max, samples=samples, max_spreadlets=spreadlets, edge=edge)
        colour, coords = bench_scene(db, height, width, channels, spreadlets, layout, seed)
    renderer = Renderer(db, device, run_max=run_max)
    out = {"device": device.describe(),
           "settings": {"height": height, "width": width, "spreadlets": spreadlets, "r_max": r_max,
                        "channels": channels, "layout": layout, "repeats": repeats, "samples": samples,
                        "run_max": run_max, "edge": edge, "pad": db.pad,
                        "mean_spreadlets_per_sample": db.n_spreadlets / db.n_samples},
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
        best["method_ms"] = best["kernel_ms"] + best["integrate_ms"] + best["upload_ms"] + best["download_ms"]
        out["methods"][method] = best
    if "spreadlets" in out["methods"] and "splat" in out["methods"]:
        ours, splat = out["methods"]["spreadlets"], out["methods"]["splat"]
        out["ratios"] = {"splat_over_spreadlets_kernel": splat["kernel_ms"] / ours["kernel_ms"],
                         "splat_over_spreadlets_method": splat["method_ms"] / ours["method_ms"],
                         "integrate_share_of_spreadlets": ours["integrate_ms"] / ours["method_ms"]}
    return out


def rotation(height: int = 1024, width: int = 1024, r_max: float = 100.0, samples: int = 64, edge: float = 1.0,
             channels: int = 3, methods=("spreadlets",), repeats: int = 3, seed: int = 0,
             device: Device | None = None) -> dict:
    """The cost of turning every pixel's PSF (``Renderer.render(angle=...)``), same run.

    The ``defocus`` scene of :func:`run` (exact Laplacians of soft-rimmed discs) is rendered by
    each method without an angle, then with two angle fields: ``constant`` (0.3 rad everywhere:
    runs of same-cell pixels survive, so this is the cost of the turning arithmetic) and
    ``per_pixel`` (each pixel's azimuth about the image centre, as a ``physical_lens``
    database needs: every run is one pixel long). Spreadlets are turned three ways
    (``bilinear``, ``nearest``, ``bank``: pre-turned at quantised angles); the unrotated kernel pixel by pixel (``run_max`` 1) shows how
    much of the per-pixel cost is the lost runs. Renders are interleaved, best of ``repeats``.

    Returns
    -------
    dict
        ``device``, ``settings``, ``kernel_ms`` per configuration and ``ratios``: each rotated
        configuration's kernel time over the same method's unrotated one.
    """
    device = device or get_device()
    db = disc_database(r_max, samples=samples, edge=edge)
    colour, coords = defocus_scene(height, width, r_max, channels, seed)
    yy, xx = np.mgrid[0:height, 0:width]
    angles = {"constant": np.full((height, width), 0.3, np.float32),
              "per_pixel": np.arctan2(height / 2 - yy - 0.5, xx + 0.5 - width / 2).astype(np.float32)}
    renderers = {how: Renderer(db, device, spreadlet_rotation=how) for how in ("bilinear", "nearest", "bank")}
    renderers["run_max_1"] = Renderer(db, device, run_max=1, spreadlet_rotation="bilinear")
    configs = []
    for method in methods:
        spreadlets = METHODS[method].splats_spreadlets     # turned two ways, runs matter
        configs.append((method, "unrotated", "bilinear", None))
        if spreadlets:
            configs.append((method, "unrotated_run_max_1", "run_max_1", None))
        for field in angles:
            for how in (("bilinear", "nearest", "bank") if spreadlets else ("bilinear",)):
                configs.append((method, f"{field}_{how}" if spreadlets else field, how, field))
    best: dict = {}
    for rep in range(repeats + 1):  # the first round warms up (kernel builds)
        for method, name, how, field in configs:
            _, t = renderers[how].render(colour, coords, method, angle=None if field is None else angles[field])
            if rep:
                key = f"{method}/{name}"
                best[key] = min(best.get(key, np.inf), t["kernel_ms"])
    ratios = {f"{key}_over_unrotated": ms / best[f"{key.split('/')[0]}/unrotated"]
              for key, ms in best.items() if not key.endswith("/unrotated")}
    return {"device": device.describe(),
            "settings": {"height": height, "width": width, "r_max": r_max, "samples": samples, "edge": edge,
                         "channels": channels, "repeats": repeats, "pad": db.pad, "rotated_pad": db.rotated_pad,
                         "mean_spreadlets_per_sample": db.n_spreadlets / db.n_samples},
            "kernel_ms": best, "ratios": ratios}


def bench_rotation(repeats: int, size: int = 512, r_max: float = 50.0):
    """``splatlab bench rotation``: :func:`rotation` written as ``reports/bench/rotation-*.json``:
    spreadlets (and the pixel-by-pixel unrotated kernel) with a constant and a per-pixel angle
    over without, as kernel-time ratios measured in the same run."""
    from lab.bench.output import write_bench

    return write_bench("rotation", rotation(size, size, r_max=r_max, repeats=repeats))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=1024)
    p.add_argument("--spreadlets", type=int, default=None,
                   help="per pixel (ramp/random; default 50) or cap per cell (defocus; default: exact)")
    p.add_argument("--r-max", type=float, default=None, help="largest CoC radius (default 32; defocus 100)")
    p.add_argument("--samples", type=int, default=None, help="PSF samples (default 32; defocus 64)")
    p.add_argument("--channels", type=int, default=3, choices=(1, 3))
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--layout", default="ramp", choices=LAYOUTS)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--run-max", type=int, default=RUN_MAX)
    p.add_argument("--edge", type=float, default=None, help="soft disc rim in pixels (default 0; defocus 1)")
    p.add_argument("--rotation", action="store_true",
                   help="instead: the cost of per-pixel rotation (defocus scene, r-max default 50, spreadlets)")
    a = p.parse_args(argv)
    if a.rotation:
        print(json.dumps(rotation(a.size, a.size, a.r_max or 50.0, a.samples or 64,
                                  a.edge if a.edge is not None else 1.0, a.channels, repeats=a.repeats), indent=1))
        return
    defocus = a.layout == "defocus"
    spreadlets = a.spreadlets if a.spreadlets is not None or defocus else 50
    print(json.dumps(run(a.size, a.size, spreadlets, a.r_max or (100.0 if defocus else 32.0), a.channels,
                         a.methods.split(","), a.layout, a.repeats,
                         samples=a.samples or (64 if defocus else 32), run_max=a.run_max,
                         edge=a.edge if a.edge is not None else (1.0 if defocus else 0.0)), indent=1))


if __name__ == "__main__":
    main()
