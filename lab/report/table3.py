"""LSR18 Table 3 reproduced: reconstruction from a stochastic 1-spp path trace.

For each scene: the 1-spp stochastic input (:mod:`lab.reference.stochastic`: lens sample and
shutter time per pixel), reconstructed by spreadlets and by Splat on re-centred pixels
(:mod:`runtime_cl.passes.stochastic`), and denoised by BM3D (the ``bm3d`` package) as LSR18's
baseline; SSIM on the report tonemap against the scene's path-traced reference. Each pass
runs as LSR18 (the plain sum), normalised by the splatted sample density (``+norm``, see
:mod:`runtime_cl.passes.stochastic`) and as the full reconstruction (``+fill``: :data:`FULL`); a
medium's database (fog) as the plain sum alone, which its still pinhole's samples need (the pass
refuses to normalise by counts its PSFs attenuate). Also 4 spp: four independent 1-spp images,
reconstructed each and averaged (reconstruction is linear).

The ``input`` column and BM3D's input are what a path tracer shows with the same samples: the
stochastic input itself, but for a scene with a ``[medium]`` (which the methods' input leaves out,
for the volume PSFs to add) those samples traced through the medium.

BM3D runs on the tonemapped input (what a viewer sees; in linear radiance, clipped, it scored
lower on the demo) with an *oracle* noise level: the standard deviation of the tonemapped
input's difference from the reference, times the factor of :data:`BM3D_FACTORS` whose result
has the best SSIM against the reference (path-traced noise is heavy-tailed, so the plain
standard deviation under-smooths), i.e. the most favourable setting for the baseline. Its
output is mapped back through the inverse tonemap.

``--reference-spp N`` renders the references with N spp instead of the scene's, and every row
states the reference's noise floor: the SSIM between it and a second reference of an
independent seed (:func:`lab.pipeline.inputs_and_reference`), which no method can beat.

``python -m lab.report.table3 SCENE.toml ... --size 256 --out reports/table3`` (a scene is
rendered at ``--size`` pixels wide; its input, reference and databases are cached as the
scene reports' are).
"""
from __future__ import annotations

import argparse
import html
import json
import re
import time
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path, check_output_dir

from .html import STYLE
from .machine import machine_info
from .metrics import TONEMAP, psnr, ssim, tonemap

__all__ = ["LSR18_TABLE3", "bm3d_denoise", "scene_row", "main"]

# LSR18 Table 3 (reconstruction from 1 spp, 1024x1024, GTX 980 Ti): (time ms, SSIM) per method.
LSR18_TABLE3 = {
    "whirl": {"spreadlets": (75.8, 0.95), "bm3d": 0.93, "splat": (605.3, 0.95), "reference": "346 s"},
    "coins": {"spreadlets": (496.4, 0.94), "bm3d": 0.91, "splat": (2652.3, 0.94), "reference": "366 s"},
    "rain": {"spreadlets": (499.5, 0.96), "bm3d": 0.89, "splat": (2276.2, 0.96), "reference": "> 1000 s"},
    "gears": {"spreadlets": (1699.1, 0.91), "bm3d": 0.91, "splat": (3495.8, 0.92), "reference": "> 1000 s"},
}
BM3D_FACTORS = (1.0, 1.5, 2.0, 3.0)
# (pass, options, label suffix): LSR18's plain sum; divided by the splatted sample density
# (nearest-pixel samples, density clamped); and the full reconstruction (+fill: bilinear sample
# footprint, push-pull fill of low density, 4 depth layers composited by density)
FULL = {"normalize": True, "footprint": "bilinear", "fill": True, "depth_layers": 4}
METHODS = (("stochastic_spreadlets", {}, ""),
           ("stochastic_spreadlets", {"normalize": True, "fill": False}, "+norm"),
           ("stochastic_spreadlets", FULL, "+fill"),
           ("stochastic_splat", FULL, "+fill"))
TIMED_RUNS = 3


def inverse_tonemap(display: np.ndarray) -> np.ndarray:
    """The linear radiance of sRGB values in [0, 1] (:func:`lab.report.metrics.tonemap` inverted)."""
    y = np.clip(display, 0.0, 1.0)
    return np.where(y <= 0.04045, y / 12.92, ((y + 0.055) / 1.055) ** 2.4).astype(np.float32)


def bm3d_denoise(noisy: np.ndarray, reference: np.ndarray, factors=(1.0,)) -> tuple[np.ndarray, float]:
    """BM3D (``bm3d.bm3d_rgb``) of the tonemapped ``noisy`` image with the oracle noise level
    times each of ``factors``, the best by SSIM against ``reference`` (see the module
    docstring); (linear image, sigma)."""
    import bm3d

    shown = tonemap(noisy)
    sigma0 = float(np.std(shown - tonemap(reference)))
    tries = [(inverse_tonemap(bm3d.bm3d_rgb(shown, sigma0 * f)), sigma0 * f) for f in factors]
    return max(tries, key=lambda t: ssim(t[0], reference))


def scene_at(scene, width: int | None, reference_spp: int | None = None):
    """``scene`` rendered ``width`` pixels wide (same aspect) and its reference with
    ``reference_spp`` samples, or as it is."""
    if reference_spp is not None:
        scene = replace(scene, render=replace(scene.render, reference_spp=reference_spp))
    if width is None or width == scene.width:
        return scene
    height = max(1, round(scene.height * width / scene.width))
    return replace(scene, info=replace(scene.info, resolution=(width, height)))


def sizing_image(image, inputs):
    """What the databases are sized by: the labelled input, its depth and motion ranges widened to
    the stochastic inputs' (the stochastic samples also see what the pinhole does not: through the
    lens rim, at other times). A few pixels take the extremes; the frame keeps its size, which a
    lens's PSFs are traced for (eccentricity)."""
    from runtime_cl.stochastic import CHANNEL_DEPTHS

    from ..exr_io import LabelledImage

    names = [c for c in ("motion.X", "motion.Y") if c in image.extra]
    planes = {"Z": image.depth, **{c: image.extra[c] for c in names}}
    out = {}
    for name, plane in planes.items():
        if name == "Z":   # and the depth each channel's ray hit (a thick lens's Z.R, Z.B)
            stack = [plane] + [a for x in inputs for a in [x.depth] + [x.extra[c] for c in CHANNEL_DEPTHS if c in x.extra]]
        else:
            stack = [plane] + [x.extra[name] for x in inputs]
        flat = np.array(plane, np.float32).ravel()
        finite = [a[np.isfinite(a)] for a in map(np.asarray, stack)]
        lo, hi = min(float(a.min()) for a in finite if a.size), max(float(a.max()) for a in finite if a.size)
        live = np.flatnonzero(np.isfinite(flat))
        order = live[np.argsort(flat[live], kind="stable")]
        flat[order[0]], flat[order[-1]] = lo, hi   # one pixel each (a frame of one pixel: the far one)
        out[name] = flat.reshape(plane.shape)
    return LabelledImage(image.rgb, image.alpha, out["Z"], image.camera, {c: out[c] for c in names})


def scene_row(scene, out_dir: Path, progress: bool = True, spp4: bool = True, shading_spp: int = 1) -> dict:
    """Every figure of one scene's Table 3 row; writes its PNGs into ``out_dir``."""
    from runtime_cl.coords.maps import attenuates, needs_motion
    from runtime_cl.passes import get_pass, run_pass
    from runtime_cl.psf.database import SpreadletDatabase
    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    from ..pipeline import build_databases, inputs_and_reference, stochastic_input
    from ..plan import make_plan
    from ..psf_settings import check_tables
    from ..runtime_passes import far_field_option, frame_of, runtime_camera
    from .images import save_render

    # the stochastic passes take what lies outside the frame from their own samples (keep_outside);
    # a guarded labelled input would only size the databases and the camera for a wider image
    scene = replace(scene, render=replace(scene.render, guard_band=False))
    plan = make_plan(scene)
    check_tables(scene, plan.psf_models)
    image, reference, info = inputs_and_reference(scene, plan, progress, second=True)
    t0 = time.perf_counter()
    inputs = [stochastic_input(scene, i, shading_spp, image, progress) for i in range(4 if spp4 else 1)]
    input_s = round(time.perf_counter() - t0, 2)
    dbs = build_databases(scene, plan, sizing_image(image, inputs), progress=progress)
    dbs = {m: SpreadletDatabase.load(r.path, expect_model=m) for m, r in dbs.items()}
    far = dbs.pop(FAR_FIELD, None)   # completes the volume database's render (its halos beyond the window)
    # the passes' own reading of a stochastic EXR (lens samples, times, per-channel depths; motion
    # for a motion database: the re-centring moves each sample back along it)
    moving = next((db for db in dbs.values() if needs_motion(db.model)), None)
    frames = [frame_of(img, f"{scene.name} stochastic input {i}", db=moving, stochastic=True)
              for i, img in enumerate(inputs)]
    camera = runtime_camera(image)
    row = {"scene": scene.name, "size": [scene.width, scene.height], "models": sorted(dbs),
           "reference_spp": scene.render.reference_spp, "shading_spp": shading_spp,
           "reference_s": info.get("reference_s"), "noise_floor": info.get("noise_floor"),
           "stochastic_input_s": input_s, "methods": {}}
    # what a path tracer shows with these samples: the input, or with a medium (which the input leaves
    # to the volume PSFs) the same samples traced through it; BM3D denoises this
    shown = inputs if scene.medium is None else [
        stochastic_input(scene, i, shading_spp, image, progress, medium=True) for i in range(len(inputs))]
    if scene.medium is not None:
        row["shown"] = "the stochastic samples traced through the medium (the methods' input omits it)"
    save_render(reference, out_dir / f"{scene.name}-reference.png")
    save_render(shown[0].rgb, out_dir / f"{scene.name}-input-1spp.png")
    noisy = {1: shown[0].rgb, 4: np.mean([x.rgb for x in shown], axis=0)} if spp4 else {1: shown[0].rgb}
    for spp, img in noisy.items():
        row["methods"][f"input@{spp}"] = {"ssim": ssim(img, reference), "psnr": psnr(img, reference)}
    for name, options, suffix in METHODS:
        cls = get_pass(name)
        for model, db in dbs.items():
            if cls.database_models is not None and model not in cls.database_models:
                continue
            label = (name if len(dbs) == 1 else f"{name}:{model}") + suffix
            if options.get("normalize") and attenuates(model):
                continue   # the pass refuses it: a medium's PSFs carry its loss (no sample density)
            opts = dict(options, **far_field_option(cls, db, far))
            rendered, timing = run_pass(name, frames[0], camera, db, runs=TIMED_RUNS, **opts)
            entry = {"time_ms": timing.time_ms, "slots": timing.counts.get("slots"),
                     "ssim": ssim(rendered[..., :3], reference), "psnr": psnr(rendered[..., :3], reference)}
            save_render(rendered[..., :3], out_dir / f"{scene.name}-{label.replace(':', '-')}-1spp.png")
            row["methods"][f"{label}@1"] = entry
            if spp4:
                mean = np.mean([rendered] + [run_pass(name, f, camera, db, **opts)[0] for f in frames[1:]],
                               axis=0)
                row["methods"][f"{label}@4"] = {"ssim": ssim(mean[..., :3], reference),
                                                "psnr": psnr(mean[..., :3], reference)}
    for spp, img in noisy.items():
        t = time.perf_counter()
        den, sigma = bm3d_denoise(img, reference, BM3D_FACTORS)
        row["methods"][f"bm3d@{spp}"] = {"time_ms": (time.perf_counter() - t) * 1e3 / len(BM3D_FACTORS),
                                         "sigma": sigma,
                                         "ssim": ssim(den, reference), "psnr": psnr(den, reference)}
        if spp == 1:
            save_render(den, out_dir / f"{scene.name}-bm3d-1spp.png")
    row["paper"] = LSR18_TABLE3.get(scene.name)
    return row


def render_html(data: dict) -> str:
    order = ["input", "bm3d"] + [name + suffix for name, _, suffix in METHODS]
    found = {k for r in data["scenes"] for k in r["methods"]}
    def rank(label):   # "name[:model][+norm]@spp" -> (spp, method order, label)
        method = re.sub(r":[^+]*", "", label.rpartition("@")[0])
        return label.rpartition("@")[2], order.index(method) if method in order else len(order), label

    cols = sorted(found, key=rank)
    head = "<tr><th>scene</th><th>size</th><th>paths per camera ray</th><th>reference spp, noise floor</th>" + "".join(f"<th>{html.escape(c)} SSIM</th>" for c in cols) + \
           "<th>LSR18: spreadlets / BM3D / Splat</th></tr>"
    body = []
    for r in data["scenes"]:
        p = r.get("paper")
        paper = f"{p['spreadlets'][1]:.2f} / {p['bm3d']:.2f} / {p['splat'][1]:.2f}" if p else "&ndash;"
        cells = "".join(f"<td>{r['methods'][c]['ssim']:.3f}</td>" if c in r["methods"] else "<td>&ndash;</td>"
                        for c in cols)
        body.append(f"<tr><td>{html.escape(r['scene'])}</td><td>{r['size'][0]}&times;{r['size'][1]}</td>"
                    f"<td>{r.get('shading_spp', 1)}</td><td>{r['reference_spp']}, "
                    f"{r['noise_floor']['ssim'] if r.get('noise_floor') else float('nan'):.3f}</td>"
                    f"{cells}<td>{paper}</td></tr>")
    imgs = "".join(f"<h3>{html.escape(r['scene'])}</h3>" + "".join(
        f"<img src='{html.escape(r['scene'])}-{k}.png' title='{k}' width=256> "
        for k in ("input-1spp", "bm3d-1spp", "stochastic_spreadlets-1spp", "stochastic_spreadlets+norm-1spp",
                  "stochastic_spreadlets+fill-1spp", "reference"))
        for r in data["scenes"])
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>splatlab: LSR18 Table 3</title>"
            f"<style>{STYLE}</style></head><body><h1>LSR18 Table 3, reproduced</h1>"
            f"<p>{html.escape(data['about'])} Tonemap: <code>{html.escape(TONEMAP)}</code>.</p>"
            f"<table>{head}{''.join(body)}</table><h2>Images (input, BM3D, spreadlets, normalised spreadlets, spreadlets +fill, reference)</h2>"
            f"{imgs}<h2>Machine</h2><pre>{html.escape(json.dumps(data['machine'], indent=2))}</pre></body></html>")


def main(argv=None) -> int:
    from ..scene import load_scene

    ap = argparse.ArgumentParser(prog="python -m lab.report.table3", description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", type=Path)
    ap.add_argument("--size", type=int, default=None, help="render width in pixels (default: the scene's)")
    ap.add_argument("--out", type=Path, default=Path("reports/table3"))
    ap.add_argument("--reference-spp", type=int, default=None, help="reference samples (default: the scene's)")
    ap.add_argument("--no-4spp", action="store_true", help="only the 1-spp input")
    ap.add_argument("--shading-spp", type=int, default=1,
                    help="paths per camera ray: 1 is a 1-spp path trace (LSR18 Fig. 9); more gives one "
                         "visibility sample per pixel with converged shading (a stochastic rasterizer)")
    args = ap.parse_args(argv)
    out = check_output_dir(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for path in args.scenes:
        scene = scene_at(load_scene(path), args.size, args.reference_spp)
        print(f"{scene.name} at {scene.width}x{scene.height}", flush=True)
        rows.append(scene_row(scene, out, spp4=not args.no_4spp, shading_spp=args.shading_spp))
        floor = rows[-1]["noise_floor"]
        print(json.dumps({"noise_floor": floor and round(floor["ssim"], 4)}
                         | {k: round(v["ssim"], 4) for k, v in rows[-1]["methods"].items()}), flush=True)
        data = {"schema": 1, "kind": "table3", "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "about": "LSR18 Table 3 reproduced: reconstruction from a stochastic image (one camera ray per "
                         "pixel with its own lens sample and time; 'paths per camera ray' shading paths from it: 1 "
                         "is a 1-spp path trace, more a stochastic rasterizer's converged shading), and from 4 of "
                         "them; every method and BM3D (oracle noise level) on those samples (BM3D's traced through "
                         "a medium, which the methods' volume PSFs add); SSIM against the "
                         "scene's path-traced reference; +norm: divided by the splatted sample density; +fill: "
                         "bilinear sample footprint, push-pull fill, 4 depth layers.",
                "tonemap": TONEMAP, "scenes": rows, "machine": machine_info()}
        for name, text in (("report.json", json.dumps(data, indent=2, allow_nan=True)),
                           ("index.html", render_html(data))):
            with atomic_path(out / name) as tmp:
                tmp.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
