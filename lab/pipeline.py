"""The main job for one scene: plan -> inputs and reference -> PSF databases -> runtime -> report.

Every stage computes only what the plan lists and is cached by content hash under ``.cache/``:
renders by the scene's render-relevant contents and the rendering code, databases by model
configuration and the precompute code (:mod:`lab.precompute`). A warm run takes seconds.
"""
from __future__ import annotations

import hashlib
import json
import math
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from runtime_cl.psf.database import SpreadletDatabase

from .cache_key import code_digest
from .errors import UserError
from .exr_io import LabelledImage, read_labelled, read_rgb, write_labelled, write_rgb
from .paths import REPORTS, cache_root
from .plan import Plan, make_plan
from .precompute import precompute
from .scene import Scene, load_scene

# What renders the input and the reference (their imports, lab.optics included, are found, not listed).
RENDER_ROOTS = ("lab.reference.render", "lab.reference.labelled")
TIMED_RUNS = 3
DEPTH_LAYERS = 8   # global depth layers of the polygon passes (LSR18 section 6)


def render_key(scene: Scene, packages=None) -> str:
    """12 hex digits naming a scene's input and reference: the scene's render settings and the
    content of the code that renders them (:data:`RENDER_ROOTS` and what they import);
    ``packages`` as for :func:`lab.cache_key.code_digest`."""
    data = scene.to_dict()
    data.pop("psf", None)
    data.pop("precompute", None)
    key = json.dumps({"scene": data, "code": code_digest(RENDER_ROOTS, packages)}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def inputs_and_reference(scene: Scene, plan: Plan, progress: bool = True) -> tuple:
    """The labelled-pixel input and the reference of ``scene`` (cached); returns (input, reference, info)."""
    from .reference.labelled import render_labelled
    from .reference.render import render_reference

    folder = cache_root() / "renders" / f"{scene.name}-{render_key(scene)}"
    folder.mkdir(parents=True, exist_ok=True)
    info = {"cache": str(folder)}
    input_path, ref_path = folder / "input.exr", folder / "reference.exr"
    if input_path.exists():
        image = read_labelled(input_path)
        info["input_s"] = "cached"
    else:
        t = time.perf_counter()
        image = render_labelled(scene, progress=progress)
        write_labelled(input_path, image)
        info["input_s"] = round(time.perf_counter() - t, 2)
    if ref_path.exists():
        reference = read_rgb(ref_path)
        info["reference_s"] = "cached"
    elif plan.references[0].name == "pinhole":
        reference = image.rgb
        write_rgb(ref_path, reference)
        info["reference_s"] = 0.0
    else:
        t = time.perf_counter()
        reference = render_reference(scene, progress=progress)
        write_rgb(ref_path, reference)
        info["reference_s"] = round(time.perf_counter() - t, 2)
    info.update(reference_spp=scene.render.reference_spp, input_spp=scene.render.input_spp,
                steps=[s.name for s in plan.references])
    return image, reference, info


def model_table(scene: Scene, model_name: str, image: LabelledImage) -> dict:
    """The scene's ``[psf.<model>]`` table with what the scene decides filled in.

    For ``simple_lens``: ``max_coc_px`` defaults to the largest |CoC| of the input, rounded up to
    a multiple of 8 px (so small scene edits reuse the database), and ``psf_resolution`` to the
    smallest that holds it.
    """
    table = dict(scene.psf.get(model_name, {}))
    if model_name == "simple_lens":
        from .psf_tracing.models.simple_lens import min_psf_resolution
        from .reference.coc import coc_range

        if "max_coc_px" not in table:
            needed = coc_range(image, scene.camera.thin_lens()).max_abs_px
            table["max_coc_px"] = float(max(8, 8 * math.ceil(needed / 8.0)))
        table.setdefault("psf_resolution", min_psf_resolution(table["max_coc_px"]))
    return table


def build_databases(scene: Scene, plan: Plan, image: LabelledImage, force: bool = False,
                    progress: bool = True) -> dict:
    """Precompute (or reuse) every PSF model the plan lists; name -> PrecomputeResult."""
    from .psf_tracing.models import load_model

    results = {}
    for name in plan.psf_models:
        model = load_model(name, model_table(scene, name, image), f"{scene.source} [psf.{name}]")
        results[name] = precompute(model, force=force, progress=progress)
    return results


def run_method(renderer, image: LabelledImage, coords, method: str, runs: int = TIMED_RUNS) -> tuple:
    """Warm up once (kernel builds), then time ``runs`` renders; returns (image, timing summary).

    ``coords``: the :class:`runtime_cl.coords.maps.PsfCoords` of the image (coordinates, angles)."""
    first, warm = renderer.render(image.rgb, coords.coords, method, angle=coords.angle)
    samples = [renderer.render(image.rgb, coords.coords, method, angle=coords.angle)[1] for _ in range(runs)]

    def median(key):
        return float(np.median([s[key] for s in samples]))

    timing = {"time_ms": median("kernel_ms") + median("integrate_ms") + median("upload_ms")
              + median("download_ms"),
              "kernel_ms": median("kernel_ms"), "integrate_ms": median("integrate_ms"),
              "transfer_ms": median("upload_ms") + median("download_ms"),
              "compile_ms": warm["compile_ms"], "wall_ms": median("total_ms"), "runs": runs,
              "counts": {k: int(samples[0][k]) for k in ("pixels", "spreadlets", "dense_pixels")}}
    return first, timing


def run_polygon(plan: Plan, image: LabelledImage, runs: int = TIMED_RUNS, progress: bool = True) -> dict:
    """The polygon passes (``polygon``, ``polygon_layers``, ``polygon_layered_input``) with the
    camera header's iris: name -> (image, timing). Each is warmed up once (kernel builds, radius
    table), then timed ``runs`` times; ``time_ms`` is the median wall time of a render call
    (uploads, kernels, downloads and the layer compositing on the host)."""
    from runtime_cl.camera.thin_lens import ThinLens

    from tqdm import tqdm

    from .config import from_table
    from .optics.iris import Iris
    from .polygon_aperture import iris_aperture, render_polygon

    ThinLens.from_json(image.camera, "input camera header")
    aperture = iris_aperture(from_table(Iris, image.camera["aperture"], "input camera header aperture"))
    settings = {"polygon": {}, "polygon_layers": {"layers": DEPTH_LAYERS},
                "polygon_layered_input": {"layers": DEPTH_LAYERS, "layered_input": True}}
    out = {}
    for name in tqdm(plan.runtime_passes, desc="runtime", unit="method", disable=not progress):
        first, warm = render_polygon(image, aperture, **settings[name])
        samples = [render_polygon(image, aperture, **settings[name])[1] for _ in range(runs)]
        wall = float(np.median([x["wall_ms"] for x in samples]))
        timing = {"time_ms": wall, "kernel_ms": float(np.median([x["kernel_ms"] for x in samples])),
                  "compile_ms": max(0.0, warm["wall_ms"] - wall), "runs": runs,
                  "aperture": {"edges": aperture.edges, "rectify_s": round(aperture.rectify_s, 3),
                               "table_s": round(warm["table_s"], 3)},
                  "counts": {"pixels": image.width * image.height,
                             "max_radius_px": round(warm["max_radius_px"], 2)}}
        if "layers" in settings[name]:
            timing["counts"].update(depth_layers=DEPTH_LAYERS, used_layers=len(warm["layers"]),
                                    input_layers=len(image.layers()) if name.endswith("input") else 1)
        out[name] = (first, timing)
    return out


def run_runtime(plan: Plan, image: LabelledImage, databases: dict, runs: int = TIMED_RUNS,
                progress: bool = True) -> dict:
    """Every runtime pass of the plan on ``image``: name -> (image, timing)."""
    if plan.runtime_passes == ("identity",):
        return {"identity": (image.rgb, {"time_ms": 0.0, "kernel_ms": 0.0, "integrate_ms": 0.0,
                                         "transfer_ms": 0.0, "compile_ms": 0.0, "runs": 0})}
    if plan.runtime_passes[0] == "polygon":
        return run_polygon(plan, image, runs, progress)
    from runtime_cl.coords.maps import psf_coords
    from runtime_cl.spreadlets.renderer import Renderer
    from runtime_cl.camera.thin_lens import ThinLens

    from tqdm import tqdm

    db = SpreadletDatabase.load(databases["simple_lens"].path, expect_model="simple_lens")
    camera = ThinLens.from_json(image.camera, "input camera header")
    coords = psf_coords(camera, image.depth, db)
    renderer = Renderer(db)
    out = {}
    for method in tqdm(plan.runtime_passes, desc="runtime", unit="method", disable=not progress):
        out[method] = run_method(renderer, image, coords, method, runs)
    return out


def load_scene_and_plan(path) -> tuple:
    scene = load_scene(path)
    return scene, make_plan(scene)


def default_out_dir(scene: Scene) -> Path:
    return REPORTS / scene.name


def run_report(scene_path, out_dir=None, baseline=None, progress: bool = True) -> dict:
    """The whole job; writes ``report.json`` and ``index.html`` and returns the report dict."""
    from .report.build import assemble_report

    scene, plan = load_scene_and_plan(scene_path)
    out_dir = Path(out_dir) if out_dir else default_out_dir(scene)
    baseline_report = None
    if baseline is not None:
        from .report.regress import load_report

        baseline_report = load_report(baseline)  # fail early, before hours of work
    t0 = time.perf_counter()
    image, reference, ref_info = inputs_and_reference(scene, plan, progress)
    databases = build_databases(scene, plan, image, progress=progress)
    results = run_runtime(plan, image, databases, progress=progress)
    report = assemble_report(scene, plan, image, reference, ref_info, databases, results, out_dir,
                             baseline_report)
    report["settings"]["job_seconds"] = round(time.perf_counter() - t0, 2)
    report["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    from .report.html import write_report

    write_report(report, out_dir)
    return report


def read_motion(image: LabelledImage, path, model: str) -> np.ndarray:
    """The labelled image's per-pixel motion (H, W, 2): channels ``motion.X``, ``motion.Y`` in pixels
    over the shutter, X right, Y up (what a ``model`` database needs)."""
    missing = [c for c in ("motion.X", "motion.Y") if c not in image.extra]
    if missing:
        raise UserError(f"{path}: channel(s) {missing} missing; a {model!r} database needs per-pixel motion "
                        "(motion.X, motion.Y: pixels over the shutter, Y up); write them into the EXR")
    return np.stack([image.extra["motion.X"], image.extra["motion.Y"]], axis=-1)


def read_input(path, camera_file=None) -> LabelledImage:
    """A labelled-pixel EXR for ``splatlab render``; ``camera_file`` (TOML) overrides its header."""
    camera = None
    if camera_file is not None:
        from .scene import load_camera

        camera = load_camera(camera_file).camera_json()
    image = read_labelled(path, camera=camera)
    if image.camera.get("lens") != "thin":
        raise UserError(f"{path}: camera lens {image.camera.get('lens')!r}; `splatlab render` needs a thin "
                        "lens camera (pass --camera FILE.toml with a [camera] model = \"thin\" table)")
    return image
