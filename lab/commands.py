"""Implementations of the ``splatlab`` subcommands (argument parsing lives in :mod:`lab.cli`)."""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

from .errors import UserError
from .paths import DEMO_SCENE, REPORTS


def _say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def cmd_plan(args) -> int:
    from .pipeline import load_scene_and_plan

    _, plan = load_scene_and_plan(args.scene)
    print(plan.describe())
    return 0


def _scene_models(scene_path) -> list:
    """The configured models a scene's plan needs (renders its labelled-pixel input for the CoC range)."""
    from .pipeline import inputs_and_reference, load_scene_and_plan, model_table
    from .psf_tracing.models import load_model

    scene, plan = load_scene_and_plan(scene_path)
    if not plan.psf_models:
        return []
    image, _, _ = inputs_and_reference(scene, plan)
    return [load_model(name, model_table(scene, name, image), f"{scene.source} [psf.{name}]")
            for name in plan.psf_models]


def cmd_precompute(args) -> int:
    from .precompute import precompute
    from .precompute.executors import check_scheduler, check_workers
    from .precompute.target import load_target_model, resolve_target

    check_workers(args.workers)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    target = resolve_target(args.target)
    if target.kind == "model":
        models = [load_target_model(target.name, args.sets)]
    else:
        if args.sets:
            raise UserError(f"--set with scene {target.path}: --set configures a model name; edit the "
                            "scene's [psf.<model>] table instead")
        models = _scene_models(target.path)
        if not models:
            print(f"{target.path}: the plan needs no PSF database (see `splatlab plan {target.path}`)")
            return 0
        if args.out and len(models) > 1:
            raise UserError(f"--out {args.out}: the scene needs {len(models)} databases; drop --out "
                            "(each is cached under .cache/db/) or precompute one model by name")
    for model in models:
        r = precompute(model, force=args.force, progress=not args.quiet, workers=args.workers,
                       scheduler=args.scheduler, threads=args.threads)
        if r.reused:
            state = "reused"
        else:
            pace = f", {r.rays / r.trace_seconds / 1e6:.1f} M rays/s per worker" if r.trace_seconds else ""
            state = f"built in {r.seconds:.1f} s: {r.cells} PSFs on {r.executor}{pace}"
        print(f"{model.name}: {r.path} ({state})")
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(r.path, args.out)
            print(f"{model.name}: copied to {args.out}")
        if args.atlas:
            from runtime_cl.psf.database import SpreadletDatabase

            from .report.atlas import write_atlas

            written = write_atlas(SpreadletDatabase.load(r.path), args.atlas / model.name)
            print(f"{model.name}: atlas {written.png}, table {written.markdown}")
    return 0


def cmd_reference(args) -> int:
    from .exr_io import write_labelled, write_rgb
    from .pipeline import default_out_dir, inputs_and_reference, load_scene_and_plan

    scene, plan = load_scene_and_plan(args.scene)
    out = args.out_dir or default_out_dir(scene)
    out.mkdir(parents=True, exist_ok=True)
    image, reference, _ = inputs_and_reference(scene, plan)
    write_labelled(out / "input.exr", image)
    write_rgb(out / "reference.exr", reference)
    print(f"input (labelled pixels): {out / 'input.exr'}\nreference: {out / 'reference.exr'}")
    return 0


def _render_polygon(args) -> int:
    from .config import from_table
    from .exr_io import write_rgb
    from .optics.iris import Iris
    from .pipeline import read_input
    from .polygon_aperture import iris_aperture, polygon_aperture, render_polygon

    if args.layers is not None and args.layers < 1:
        raise UserError(f"--layers {args.layers}: the number of depth layers must be >= 1 (1 splats "
                        "everything into one layer, without occlusion), e.g. --layers 8")
    image = read_input(args.input, args.camera)
    if args.aperture is None and "aperture" in image.camera:   # the camera's own iris
        iris = from_table(Iris, image.camera["aperture"], f"{args.input} camera aperture")
        aperture = iris_aperture(iris, args.directions, args.edges)
    else:
        aperture = polygon_aperture(args.aperture or "hexagon", args.directions, args.edges)
    layered = args.layers is not None and bool(image.layers(str(args.input)))
    rendered, info = render_polygon(image, aperture, args.layers, layered_input=layered)
    write_rgb(args.out, rendered)
    layers = "" if args.layers is None else \
        f", {len(info['layers'])} of {args.layers} depth layers used ({'layered' if layered else 'flat'} input)"
    print(f"{args.out}: polygon ({aperture.name}, {aperture.edges} edges, D m={aperture.directions_m}), "
          f"radius <= {info['max_radius_px']:.1f} px{layers}, {info['kernel_ms']:.1f} ms kernels "
          f"(+{info['table_s']:.2f} s radius table, {info['rectify_s']:.2f} s rectification)")
    return 0


def cmd_render(args) -> int:
    if args.method == "polygon":
        return _render_polygon(args)
    if args.layers is not None:
        raise UserError(f"--layers {args.layers}: depth layers are for --method polygon; drop --layers "
                        f"with --method {args.method}")
    if args.db is None:
        raise UserError(f"--db: --method {args.method} needs a spreadlet database (splatlab precompute "
                        "MODEL --out FILE); only --method polygon works without one")
    from runtime_cl.psf.database import SpreadletDatabase
    from runtime_cl.coords.maps import needs_motion, psf_coords
    from runtime_cl.spreadlets.renderer import Renderer
    from runtime_cl.camera.thin_lens import ThinLens

    from .exr_io import write_rgb
    from .pipeline import read_input, read_motion

    image = read_input(args.input, args.camera)
    db = SpreadletDatabase.load(args.db)
    camera = ThinLens.from_json(image.camera, f"{args.input} camera")
    motion = read_motion(image, args.input, db.model) if needs_motion(db.model) else None
    pc = psf_coords(camera, image.depth, db, motion)
    rendered, timing = Renderer(db).render(image.rgb, pc.coords, args.method, angle=pc.angle)
    write_rgb(args.out, rendered[..., :3])
    print(f"{args.out}: {args.method}, {timing['kernel_ms']:.1f} ms kernels + "
          f"{timing['integrate_ms']:.1f} ms integration (+{timing['compile_ms']:.0f} ms kernel builds)")
    return 0


def _report(scene_path, out_dir, baseline) -> int:
    from .pipeline import run_report

    report = run_report(scene_path, out_dir, baseline)
    out = Path(out_dir) if out_dir else REPORTS / report["scene"]["name"]
    for name, m in report["methods"].items():
        print(f"  {name:<11} {m['time_ms']:9.1f} ms   SSIM {m['ssim']:.4f}   PSNR {m['psnr']:.2f} dB")
    print(f"report: {out.resolve() / 'index.html'}\n        {out.resolve() / 'report.json'}")
    if report.get("regressions"):
        _say("regressions against the baseline:\n  " + "\n  ".join(report["regressions"]))
        return 1
    return 0


def cmd_report(args) -> int:
    return _report(args.scene, args.out_dir, args.baseline)


def cmd_demo(args) -> int:
    return _report(DEMO_SCENE, None, None)


def cmd_bench(args) -> int:
    if args.what == "polygon":
        from .bench_polygon import bench_polygon

        print(f"benchmark: {bench_polygon(args.repeats, quick=args.quick)}")
        return 0
    from .bench import run_bench

    for path in run_bench(args.what, args.scene, args.repeats, models=args.models,
                          build=not args.no_build, workers=args.workers):
        print(f"benchmark: {path}")
    return 0


def cmd_db(args) -> int:
    from runtime_cl.psf.database import SpreadletDatabase

    db = SpreadletDatabase.load(args.file)
    print(json.dumps(db.info(), indent=2))
    return 0


def cmd_doctor(args) -> int:
    from .doctor import diagnose

    problems = diagnose(print)
    return 1 if problems else 0
