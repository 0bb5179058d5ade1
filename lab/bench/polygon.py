"""``splatlab bench polygon``: MHU21 exact polygonal bokeh, each figure a ratio from one run.

(a) Time against the largest radius (MHU21 Fig. 13, "DoF filtering"): 1920x1080, octagon, the
    thin-lens CoC of a depth-of-field scene (:func:`dof_scene_depth`: ground, back wall, a
    subject in focus at 3 m, bokeh in front and behind) with the f-number set so that the
    largest radius is R = 10 ... 200. Target: R = 200 within 1.3x of R = 25 (the median over
    repeats of the ratio in each repeat). The same sweep on a stress map,
    ``R |sin(x / 97) cos(y / 61)|``, whose radius changes by up to R/61 px per pixel everywhere
    (neighbouring pixels' terms land R/30 rows apart: the cost is in the caches, not the work)
    is reported beside it.
(b) Against the methods of MHU21 Fig. 11 on the scene of (a) with R = 60 as the image grows
    (and on the stress map at 1920x1080): brute-force dense
    splatting of the rasterised polygon, the Laplacian of it as the sparse kernel (LSR18
    spreadlets, FFT Poisson integration), dx dy (KTB09), all on the same radius table and fixed
    point (:mod:`runtime_cl.polygon.baselines`; dense and dx dy are checked bit-identical).
(c) Uniform blur against a scipy.fft convolution (MHU21 Fig. 8): r = 60, sizes 1024^2 ...
    4096^2, RGB float32, the kernel's spectrum precomputed (as in the paper), all channels in one
    rfft2/irfft2 call (the faster of per-channel and batched here), scipy on all cores. Two FFT
    paddings: the next fast length >= n + k - 1 (``fft``) and MHU21's power of two
    (``fft_pow2``). Hexagons: MHU21's 45-degree hexagon (``t1hex``, 8 terms) and the regular one
    rectified with D (16 terms). Target: >= 5x (median over repeats).

Every time is a wall-clock call from a host image to a host image (both sides: validation,
kernels or FFTs, output allocation), the methods of a row interleaved in every repeat (their
order rotating in (c), alternating in (a)), on a shared 2-core machine: ratios are taken within
a repeat and reported as median and range (``ratio_*``), single times as the best of the
repeats; ``kernel_ms`` are OpenCL event times.
"""
from __future__ import annotations

import time

import numpy as np

__all__ = ["bench_polygon", "dof_radius", "dof_scene_depth", "scene_radius", "fft_blur"]


def dof_radius(h: int, w: int, r_max: float) -> np.ndarray:
    """A smooth radius map with every radius in [0, r_max] (px), steep everywhere."""
    y, x = np.mgrid[0:h, 0:w]
    return (r_max * np.abs(np.sin(x / 97.0) * np.cos(y / 61.0))).astype(np.float32)


# (centre x, y, z, radius) in metres, camera at the origin looking along +z, y up: a subject in
# focus at 3 m, two objects in front (bokeh up to R), three behind.
_SPHERES = ((0.1, -0.25, 3.0, 0.35), (-0.42, -0.3, 1.1, 0.16), (0.33, -0.27, 1.5, 0.09),
            (1.7, -0.3, 7.0, 0.7), (-2.6, 0.2, 12.0, 1.4), (-0.6, -0.7, 5.0, 0.3))


def dof_scene_depth(h: int, w: int, fov_x_deg: float = 40.0) -> np.ndarray:
    """Camera-space depth (m) of a pinhole view of a depth-of-field scene: a ground plane 1 m
    below the camera, a wall 30 m away, spheres from 1.1 m to 12 m (:data:`_SPHERES`)."""
    f = 0.5 * w / np.tan(np.radians(fov_x_deg) / 2)
    y, x = np.mgrid[0:h, 0:w]
    d = np.stack([(x + 0.5 - w / 2) / f, (h / 2 - y - 0.5) / f, np.ones((h, w))], -1)
    z = np.full((h, w), 30.0)                                   # the wall (z along the ray's z)
    with np.errstate(divide="ignore"):
        ground = np.where(d[..., 1] < 0, -1.0 / d[..., 1], np.inf)
    z = np.minimum(z, ground)
    a = (d * d).sum(-1)
    for cx, cy, cz, r in _SPHERES:               # ray p = t d, |p - c| = r; depth = t (d_z = 1)
        b = d[..., 0] * cx + d[..., 1] * cy + d[..., 2] * cz   # (not BLAS: its threads spin on)
        disc = b * b - a * (cx * cx + cy * cy + cz * cz - r * r)
        t = (b - np.sqrt(np.maximum(disc, 0))) / a
        z = np.where((disc > 0) & (t > 0) & (t < z), t, z)
    return z


def scene_radius(depth: np.ndarray, r_max: float, focus_m: float = 3.0) -> np.ndarray:
    """``|CoC|`` (px) of a thin lens focused at ``focus_m``, its f-number set so that the
    largest radius over ``depth`` is ``r_max``."""
    from runtime_cl.camera.thin_lens import ThinLens

    coc = np.abs(ThinLens(50.0, 1.0, focus_m).coc_radius_px(depth, depth.shape[1]))
    return (coc * (r_max / coc.max())).astype(np.float32)


def _best(fn, repeats: int):
    best, info = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        out, info = fn()
        best = min(best, (time.perf_counter() - t) * 1e3)
    return best, out, info


def _spread(values) -> dict:
    """Median, min and max of repeated measurements."""
    v = np.asarray(values, np.float64)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def fft_blur(image: np.ndarray, kernel: np.ndarray, origin, pow2: bool):
    """``run() -> (blurred, info)``: linear convolution of every channel of ``image`` (H, W, C)
    by FFT, the kernel's spectrum precomputed, all channels in one batched call."""
    import scipy.fft as sf

    h, w, _ = image.shape
    kh, kw = kernel.shape
    if pow2:
        sh, sw = (1 << int(np.ceil(np.log2(n + k - 1))) for n, k in ((h, kh), (w, kw)))
    else:
        sh, sw = sf.next_fast_len(h + kh - 1, real=True), sf.next_fast_len(w + kw - 1, real=True)
    spectrum = sf.rfft2(kernel.astype(np.float32), s=(sh, sw), workers=-1)
    oy, ox = origin

    def run():
        s = sf.rfft2(image, s=(sh, sw), axes=(0, 1), workers=-1)
        s *= spectrum[..., None]
        out = sf.irfft2(s, s=(sh, sw), axes=(0, 1), workers=-1)[oy:oy + h, ox:ox + w]
        return np.ascontiguousarray(out), {"fft_shape": [sh, sw]}

    return run


def _sweep(sp, img, maps, repeats):
    """Wall and kernel times of ``sp.render`` over ``maps`` (R -> radius map), interleaved."""
    radii = list(maps)
    for r in radii:
        sp.render(img, maps[r])                                  # builds, warms up
    wall = {r: [] for r in radii}
    kern = {r: [] for r in radii}
    for i in range(repeats):
        for r in (radii if i % 2 == 0 else radii[::-1]):   # no radius always runs first
            t = time.perf_counter()
            _, info = sp.render(img, maps[r])
            wall[r].append((time.perf_counter() - t) * 1e3)
            kern[r].append(info["kernel_ms"])
    ratio = np.array(wall[200]) / np.array(wall[25])
    kratio = np.array(kern[200]) / np.array(kern[25])
    nnz = {r: float(np.mean([sp.table.terms[e].nnz for e in np.unique(sp.table.entry(maps[r]))]))
           for r in radii}
    return {"wall_ms": {r: min(v) for r, v in wall.items()},
            "wall_ms_spread": {r: _spread(v) for r, v in wall.items()},
            "kernel_ms": {r: min(v) for r, v in kern.items()}, "mean_terms_per_entry": nnz,
            "ratio_wall_200_over_25": float(np.median(ratio)), "ratio_wall_spread": _spread(ratio),
            "ratio_kernel_200_over_25": float(np.median(kratio)), "ratio_kernel_spread": _spread(kratio)}


def _time_vs_radius(repeats, quick):
    from lab.polygon_aperture import polygon_aperture

    h, w = (270, 480) if quick else (1080, 1920)
    radii = (10, 25, 50, 100, 150, 200)
    sp = polygon_aperture("octagon").splatter
    sp.table.ensure(200.0)
    img = np.random.default_rng(0).random((h, w, 3)).astype(np.float32)
    depth = dof_scene_depth(h, w)
    out = {"image": [w, h], "shape": "octagon",
           "radius_map": "thin-lens |CoC| of dof_scene_depth, focus 3 m, scaled to max R",
           **_sweep(sp, img, {r: scene_radius(depth, r) for r in radii}, repeats)}
    # The stress map, and one radius everywhere (the same radius-map path and work per pixel).
    # With one radius neighbouring pixels' terms stream along rows; with a steep map they land
    # in different cache lines and a buffer line is revisited by pixels up to 2R apart: that
    # reuse fits L2 at R = 25 and spills to L3 at R = 200 (72 bytes per pixel for 3 directions
    # x RGB).
    out["stress"] = {"radius_map": "R |sin(x/97) cos(y/61)|",
                     **_sweep(sp, img, {r: dof_radius(h, w, r) for r in radii}, repeats)}
    flat = {}
    for r in (25, 200):
        m = np.full((h, w), r, np.float32)
        flat[r], _, _ = _best(lambda m=m: sp.render(img, m), repeats)
    out.update({"constant_map_wall_ms": flat, "constant_map_ratio_200_over_25": flat[200] / flat[25],
                "table_entries_to_200": len(sp.table), "table_build_s": sp.table.build_seconds})
    return out


def _methods(repeats, quick):
    from runtime_cl.polygon.baselines import BaselineSplatter

    from lab.polygon_aperture import polygon_aperture

    sizes = [(270, 480)] if quick else [(270, 480), (540, 960), (1080, 1920), (2160, 3840)]
    dense_max = 540 * 960
    sp = polygon_aperture("octagon").splatter
    base = {m: BaselineSplatter(sp, m) for m in ("dense", "laplacian", "dxdy")}
    rows = []
    rng = np.random.default_rng(1)
    for h, w in sizes:
        img = rng.random((h, w, 3)).astype(np.float32)
        rows.append(_method_row(sp, base, img, scene_radius(dof_scene_depth(h, w), 60.0), "scene",
                                repeats, dense_max))
        if (h, w) == (1080, 1920):
            rows.append(_method_row(sp, base, img, dof_radius(h, w, 60.0), "stress", repeats,
                                    dense_max))
    return {"shape": "octagon", "max_radius_px": 60, "rows": rows,
            "note": "dense (O(r^2) terms) only up to 960x540"}


def _method_row(sp, base, img, rad, radius_map, repeats, dense_max):
    """One image of (b): every method's best wall time, and the bit-exactness checks."""
    h, w, _ = img.shape
    row = {"image": [w, h], "radius_map": radius_map}
    ref, _ = sp.render(img, rad, fixed=True)
    methods = {"polygon": lambda: sp.render(img, rad)}
    for m, b in base.items():
        if m != "dense" or h * w <= dense_max:
            methods[m] = (lambda b=b: b.render(img, rad))
    for m, fn in methods.items():
        fn()                                                  # warm-up (tables, compiles)
        ms, out, info = _best(fn, repeats if m != "dense" else 1)
        row[m] = {"wall_ms": ms, "kernel_ms": info["kernel_ms"],
                  "terms_per_pixel": info.get("terms_per_pixel")}
    for m in ("dense", "dxdy"):
        if m in row:
            same, _ = base[m].render(img, rad, fixed=True)
            row[m]["bit_identical_to_polygon"] = bool(np.array_equal(same, ref))
    row["speedup_over"] = {m: row[m]["wall_ms"] / row["polygon"]["wall_ms"] for m in methods if m != "polygon"}
    return row


def _uniform_vs_fft(repeats, quick):
    from runtime_cl.polygon.kernel import rasterize_polygon
    from runtime_cl.polygon.shapes import shape
    from runtime_cl.polygon.splat import PolygonSplatter

    from lab.polygon.rectify import direction_set, rectify
    from lab.polygon.table import table1_polygon

    sizes = (512, 1024) if quick else (1024, 2048, 4096)
    t1_unit, t1_dirs = table1_polygon("hexagon")
    shapes = {"t1hex": (t1_unit / np.linalg.norm(t1_unit, axis=1).max(), t1_dirs),   # circumradius 1
              "hexagon": rectify(shape("hexagon"), direction_set(2), 6).unit()}
    out = {}
    rng = np.random.default_rng(2)
    for name, (unit, dirs) in shapes.items():
        sp = PolygonSplatter(unit, dirs)
        k, x0, y0 = rasterize_polygon(sp.polygon(60.0))
        kernel = k / k.sum()
        rows = []
        for n in sizes:
            img = rng.random((n, n, 3)).astype(np.float32)
            runs = {"polygon": lambda img=img: sp.render(img, 60.0),
                    "fft": fft_blur(img, kernel, (-y0, -x0), pow2=False),
                    "fft_pow2": fft_blur(img, kernel, (-y0, -x0), pow2=True)}
            res = {m: None for m in runs}
            for m in runs:
                runs[m]()
            times = {m: [] for m in runs}
            names = list(runs)
            for i in range(repeats):
                # rotate: each method follows each other one (whose memory traffic leaves the
                # caches cold and fresh pages to fault in) equally often
                for m in names[i % len(names):] + names[:i % len(names)]:
                    t = time.perf_counter()
                    res[m] = runs[m]()
                    times[m].append((time.perf_counter() - t) * 1e3)
            pm = np.array(times["polygon"])
            diff = float(np.abs(res["polygon"][0] - res["fft"][0]).max())
            rows.append({"n": n, "wall_ms": {m: min(v) for m, v in times.items()},
                         "kernel_ms": res["polygon"][1]["kernel_ms"],
                         "fft_shape": res["fft"][1]["fft_shape"],
                         "fft_pow2_shape": res["fft_pow2"][1]["fft_shape"],
                         "max_abs_diff_vs_fft": diff,
                         "speedup_vs_fft": float(np.median(np.array(times["fft"]) / pm)),
                         "speedup_vs_fft_spread": _spread(np.array(times["fft"]) / pm),
                         "speedup_vs_fft_pow2": float(np.median(np.array(times["fft_pow2"]) / pm))})
            del img, runs, res
        out[name] = {"terms": sp.kernel_terms(60.0).nnz, "area_px": int(k.sum()), "rows": rows}
    return out


def bench_polygon(repeats: int = 3, quick: bool = False):
    """Run (a), (b), (c) and write ``reports/bench/polygon-*.json``; returns its path."""
    from lab.bench.output import write_bench
    from lab.errors import UserError

    if not (isinstance(repeats, int) and repeats >= 1):
        raise UserError(f"--repeats {repeats}: must be an integer >= 1")
    a = _time_vs_radius(repeats, quick)
    b = _methods(repeats, quick)
    c = _uniform_vs_fft(repeats, quick)
    worst = min(r["speedup_vs_fft"] for v in c.values() for r in v["rows"])
    data = {"repeats": repeats, "quick": quick,
            "a_time_vs_radius": a, "b_methods": b, "c_uniform_vs_fft": c,
            "targets": {"a_ratio_wall_200_over_25": "<= 1.3", "c_speedup_vs_fft": ">= 5"},
            "met": {"a": a["ratio_wall_200_over_25"] <= 1.3, "c": worst >= 5}}
    return write_bench("polygon", data)
