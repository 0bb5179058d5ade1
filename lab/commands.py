"""Implementations of the ``splatlab`` subcommands (argument parsing lives in :mod:`lab.cli`)."""
from __future__ import annotations

import inspect
import json
import shutil
import sys
from pathlib import Path

from runtime_cl.atomic_file import atomic_path, check_output, check_output_dir

from .errors import UserError
from .paths import DEMO_SCENE, REPORTS


def _say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def cmd_plan(args) -> int:
    from .pipeline import load_scene_and_plan

    _, plan = load_scene_and_plan(args.scene)
    print(plan.describe())
    return 0


def _executor(args):
    """Where the command's tasks run, from ``--workers``, ``--scheduler`` (and ``--threads``)."""
    from .parallel import Executor

    return Executor(args.workers, args.scheduler, getattr(args, "threads", None))


def _scene_models(scene_path) -> list:
    """The configured models a scene's plan needs (renders its labelled-pixel input for the CoC
    and motion ranges; not its reference, which only `splatlab reference|report` need)."""
    from .pipeline import input_only, load_scene_and_plan
    from .psf_settings import model_table
    from .psf_tracing.models import load_model

    scene, plan = load_scene_and_plan(scene_path)
    if not plan.psf_models:
        return []
    image = input_only(scene)
    return [load_model(name, model_table(scene, name, image), f"{scene.source} [psf.{name}]")
            for name in plan.psf_models]


def cmd_precompute(args) -> int:
    from .precompute import precompute
    from .precompute.target import load_target_model, resolve_target

    _executor(args)   # bad --workers / --scheduler / --threads: exit 2 before the input renders
    if args.out is not None:
        check_output(args.out, "--out", suffix=".spdb")
    if args.atlas is not None:
        check_output_dir(args.atlas, "--atlas")
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
            with atomic_path(args.out, fsync=True, what="--out") as tmp:
                shutil.copyfile(r.path, tmp)
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

    executor = _executor(args)
    scene, plan = load_scene_and_plan(args.scene)
    out = check_output_dir(args.out_dir or default_out_dir(scene))   # created by the writers
    with executor:
        image, reference, _ = inputs_and_reference(scene, plan, progress=not args.quiet, executor=executor)
    write_labelled(out / "input.exr", image)
    if reference is None:   # an expressive focal surface: nothing physical to render
        print(f"input (labelled pixels): {out / 'input.exr'}\nreference: none ({plan.references[0].detail})")
        return 0
    write_rgb(out / "reference.exr", reference)
    print(f"input (labelled pixels): {out / 'input.exr'}\nreference: {out / 'reference.exr'}")
    return 0


def cmd_stochastic(args) -> int:
    from .exr_io import write_labelled
    from .pipeline import default_out_dir, load_scene_and_plan, stochastic_input

    for flag, value, low, high in (("--index", args.index, 0, 2 ** 31 - 1),
                                   ("--shading-spp", args.shading_spp, 1, 4096)):
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise UserError(f"{flag} {value}: give an integer in [{low}, {high}]")
    scene, _ = load_scene_and_plan(args.scene)
    out = args.out or default_out_dir(scene) / f"stochastic-{args.index}.exr"
    check_output(out, "--out", (args.scene,), ".exr")
    image = stochastic_input(scene, args.index, args.shading_spp, progress=not args.quiet)
    write_labelled(out, image)
    print(f"stochastic input ({scene.width}x{scene.height}, image {args.index}, {args.shading_spp} shading "
          f"path(s) per pixel, channels {', '.join(sorted(image.extra))}): {out}")
    return 0


def _render_aperture(args, image):
    """The rectified polygon a pass that draws the aperture gets: ``--aperture NAME``, else the
    camera header's iris, else the hexagon."""
    from .polygon_aperture import polygon_aperture
    from .runtime_passes import camera_aperture

    if args.aperture is None:
        iris = camera_aperture(image, f"{args.input} camera", args.directions, args.edges)
        if iris is not None:
            return iris
    return polygon_aperture(args.aperture or "hexagon", args.directions, args.edges)


def _check_render_options(args, cls) -> None:
    from runtime_cl.integrate import get_integrator
    from runtime_cl.passes import get_pass, integrating_passes, pass_names

    if args.integrator is not None:
        get_integrator(args.integrator)   # an unknown name: InputError naming the valid ones
        if not cls.integrates:
            raise UserError(f"--integrator {args.integrator}: --method {args.method} integrates no Laplacian; "
                            f"--integrator is for --method {' / '.join(integrating_passes())}")
    if args.layers is not None and args.layers < 1:
        raise UserError(f"--layers {args.layers}: the number of depth layers must be >= 1 (1 splats "
                        "everything into one layer, without occlusion), e.g. --layers 8")
    if args.layers is not None and not cls.layered:
        layered = " / ".join(n for n in pass_names() if get_pass(n).layered)
        raise UserError(f"--layers {args.layers}: depth layers are for --method {layered}; drop --layers "
                        f"with --method {args.method}")
    if cls.database_models != () and args.db is None:
        free = " / ".join(n for n in pass_names() if get_pass(n).database_models == ())
        raise UserError(f"--db: --method {args.method} needs a spreadlet database (splatlab precompute "
                        f"MODEL --out FILE); only --method {free} work without one")
    if cls.database_models == () and args.db is not None:
        raise UserError(f"--db {args.db}: --method {args.method} uses no PSF database; drop --db")
    if args.rays is not None and "rays" not in inspect.signature(cls.configure).parameters:
        raise UserError(f"--rays {args.rays}: --method {args.method} traces no lens rays; drop --rays")
    if getattr(args, "cone", False) and "cone" not in inspect.signature(cls.configure).parameters:
        raise UserError(f"--cone: --method {args.method} traces no lens rays to widen into cones; drop --cone "
                        "or use --method layered")
    if args.far_db is not None and not cls.far_field:
        raise UserError(f"--far-db {args.far_db}: --method {args.method} does not add far fields; use it with "
                        "--method spreadlets, splat or filter and a volume --db")
    if not cls.draws_aperture and args.aperture is not None:
        raise UserError(f"--aperture {args.aperture}: --method {args.method} draws its database's PSFs; "
                        "--aperture is for a method that draws the aperture (--method polygon)")


# Pass options that have their own flag (or are decided from the input), so not --set.
FLAGGED_OPTIONS = {"integrator": "--integrator NAME", "rays": "--rays N", "cone": "--cone", "max_layers": "--layers N",
                   "aperture": "--aperture NAME", "far_field": "--far-db FILE",
                   "layered_input": "--layers N (the EXR's layerN.* channels decide)"}


def _pass_sets(args, cls) -> dict:
    """``--set KEY=VALUE`` as options of the pass ``cls``: a key it does not take, or one with its
    own flag, is an error naming the options it does take (the pass checks the values)."""
    from runtime_cl.passes import pass_options

    from .precompute.target import parse_sets

    table = parse_sets(getattr(args, "sets", None), example="soft_layers=0.5")
    free = [k for k in pass_options(cls) if k not in FLAGGED_OPTIONS]
    for key, value in table.items():
        if key in FLAGGED_OPTIONS:
            raise UserError(f"--set {key}={value!r}: give it as {FLAGGED_OPTIONS[key]}")
        if key not in free:
            raise UserError(f"--set {key}={value!r}: --method {args.method} has no option {key!r}; "
                            + (f"its options are {', '.join(free)}" if free else "it takes no options"))
    return table


def cmd_render(args) -> int:
    from runtime_cl.passes import get_pass, run_pass
    from runtime_cl.psf.database import SpreadletDatabase
    from runtime_cl.psf.fingerprint import check_header

    from .exr_io import write_rgb
    from .runtime_passes import aperture_info, frame_of, read_input, runtime_camera

    cls = get_pass(args.method)
    _check_render_options(args, cls)
    sets = _pass_sets(args, cls)
    check_output(args.out, "--out", (args.input, args.db, args.far_db, args.camera), ".exr")
    image = read_input(args.input, args.camera)
    if getattr(args, "focus_point", None) is not None:
        from .focus import refocus_option

        image = refocus_option(image, args.focus_point, f"{args.input} camera")
    db = None if args.db is None else SpreadletDatabase.load(args.db)
    if db is not None:
        check_header(db, image.camera, f"{args.input} camera")
    options, said = dict(sets), ""
    if args.integrator is not None:
        options["integrator"] = args.integrator
        said = f" ({args.integrator} integration)"
    takes = inspect.signature(cls.configure).parameters
    if args.layers is not None and "max_layers" in takes:   # a pass that traces the input's own layers
        options["max_layers"] = args.layers
    elif args.layers is not None:
        options["layers"] = args.layers
        options["layered_input"] = cls.layered and bool(image.layers(str(args.input)))
    if args.rays is not None:
        options["rays"] = args.rays
    if getattr(args, "cone", False):
        options["cone"] = True
    if "rays" in takes:   # lens rays: through the layers the input has
        options.setdefault("layered_input", bool(image.layers(str(args.input))))
    if cls.draws_aperture:
        aperture = _render_aperture(args, image)
        options["aperture"] = aperture.splatter
    if args.far_db is not None:
        options["far_field"] = SpreadletDatabase.load(args.far_db, expect_model="volume_far")
        check_header(options["far_field"], image.camera, f"{args.input} camera")
    frame = frame_of(image, str(args.input), db, options.get("layered_input", False), "lens.U" in cls.channels)
    rendered, timing = run_pass(args.method, frame, runtime_camera(image, f"{args.input} camera"), db, **options)
    write_rgb(args.out, rendered[..., :3])
    if cls.draws_aperture:
        a = aperture_info(aperture)
        said = (f" ({aperture.name}, {aperture.edges} edges, D m={aperture.directions_m}; "
                f"+{a['table_s']:.2f} s radius table, {a['rectify_s']:.2f} s rectification)")
    c = timing.counts
    if "max_radius_px" in c:
        said += f", radius <= {c['max_radius_px']:.1f} px"
    if "rays_hit" in c:
        said += (f", {c['rays']} rays per pixel through {c['input_layers']} layer(s) (occupancy "
                 f"{', '.join(f'{x:.2f}' for x in c['occupancy'])}), {c['rays_left_image']} rays left the image")
    if "used_layers" in c:
        said += (f", {c['used_layers']} of {c['depth_layers']} depth layers used "
                 f"({'layered' if options['layered_input'] else 'flat'} input)")
    print(f"{args.out}: {args.method}{said}: {timing.time_ms:.1f} ms ({timing.device_ms:.1f} ms device, "
          f"{timing.transfer_ms:.1f} ms transfers, {timing.host_ms:.1f} ms host; one call, kernel builds "
          "included)")
    return 0


def _report(scene_path, out_dir, baseline, executor=None, noise: bool = True, sweep=None, options=None,
            layers: int | None = None) -> tuple:
    from .pipeline import run_report

    report = run_report(scene_path, out_dir, baseline, executor=executor, noise=noise, sweep=sweep,
                        options=options, depth_layers=layers)
    out = Path(out_dir) if out_dir else REPORTS / report["scene"]["name"]
    for name, m in report["methods"].items():
        corrected = m.get("noise_corrected_psnr")
        said = f"   noise-corrected PSNR {corrected:.2f} dB" if corrected is not None else ""
        if m.get("ssim") is None:
            print(f"  {name:<11} {m['time_ms']:9.1f} ms   unscored (no reference)")
            continue
        print(f"  {name:<11} {m['time_ms']:9.1f} ms   SSIM {m['ssim']:.4f}   PSNR {m['psnr']:.2f} dB{said}")
    floor = report["reference"].get("noise_floor")
    if floor:
        from .report.metrics import CONVERGED_FLOOR

        low = (f" (below {CONVERGED_FLOOR}: not converged enough to validate; raise [render] reference_spp)"
               if floor["ssim"] < CONVERGED_FLOOR else "")
        print(f"  noise floor: two reference seeds agree at SSIM {floor['ssim']:.4f}, PSNR {floor['psnr']:.2f} dB{low}")
    elif report["reference"].get("noise_floor_skipped"):
        print(f"  noise floor: not measured ({report['reference']['noise_floor_skipped']})")
    if "sweep" in report:
        from .report.sweep_section import describe_sweep

        print(describe_sweep(report["sweep"]))
    print(f"report: {out.resolve() / 'index.html'}\n        {out.resolve() / 'report.json'}")
    if report.get("regressions"):
        _say("regressions against the baseline:\n  " + "\n  ".join(report["regressions"]))
        return 1, report, out
    return 0, report, out


def cmd_report(args) -> int:
    """One scene: its report; several: each scene's report, then LSR18 Table 2 over them."""
    scenes = list(args.scene)
    if len(scenes) > 1 and args.baseline is not None:
        raise UserError(f"--baseline {args.baseline}: a baseline is one scene's report.json; check one "
                        "scene at a time")
    from .pipeline import load_scene_and_plan
    from .precompute.target import parse_sets
    from .report.table2 import write_summary
    from .runtime_passes import with_pass_options
    from .scene import MAX_DEPTH_LAYERS

    sweep, noise = None, args.noise_floor
    if getattr(args, "sweep", False):
        from .report.knobs import select_knobs

        if noise is False:
            raise UserError("--sweep --no-noise-floor: the sweep scores its points by the noise-corrected PSNR, "
                            "which needs the second reference; drop --no-noise-floor")
        sweep = select_knobs(args.knobs)
    elif getattr(args, "knobs", None) is not None:
        raise UserError(f"--knobs {','.join(args.knobs)}: --knobs chooses what --sweep turns; add --sweep")
    options = parse_sets(args.sets, example="spreadlet_rotation=bank") if getattr(args, "sets", None) else {}
    layers = getattr(args, "layers", None)
    if layers is not None and not 1 <= layers <= MAX_DEPTH_LAYERS:
        raise UserError(f"--layers {layers}: the number of depth layers must be between 1 and {MAX_DEPTH_LAYERS} "
                        "(1 splats everything into one layer, without occlusion), e.g. --layers 2")
    loaded = [load_scene_and_plan(s, layers) for s in scenes]       # every scene valid before hours of work
    for _, plan in loaded:
        with_pass_options(plan, options)                            # every option taken, before hours of work
    names = [scene.name for scene, _ in loaded]
    for path, (_, plan) in zip(scenes, loaded):
        if not plan.scored and (noise or sweep is not None or len(scenes) > 1 or args.baseline is not None):
            what = ("--sweep" if sweep is not None else "--noise-floor" if noise else
                    "--baseline" if args.baseline is not None else "LSR18 Table 2 over several scenes")
            raise UserError(f"{path}: {what} scores against a reference, and this scene has none "
                            f"({plan.references[0].detail}); report it alone without {what}")
    if len(set(names)) < len(names):
        raise UserError(f"scenes {[str(s) for s in scenes]} share a name ({names}); each report needs its own")
    if len(scenes) > 1:
        check_output_dir(args.out_dir or REPORTS / "table2")   # before hours of work
    with _executor(args) as executor:
        if len(scenes) == 1:
            return _report(scenes[0], args.out_dir, args.baseline, executor, _noise(noise, loaded[0][1]), sweep,
                           options, layers)[0]
        root = Path(args.out_dir) if args.out_dir else None
        codes, reports, dirs = [], [], []
        for path, name, (_, plan) in zip(scenes, names, loaded):
            code, report, out = _report(path, root / name if root else None, None, executor, _noise(noise, plan),
                                        sweep, options, layers)
            codes.append(code), reports.append(report), dirs.append(out)
    page = write_summary(reports, dirs, root or REPORTS / "table2")
    print(f"LSR18 Table 2 over {len(reports)} scenes: {page.resolve()}")
    return max(codes)


def _noise(asked, plan) -> bool:
    """--noise-floor as given, else on wherever there is a reference to measure it against."""
    return plan.scored if asked is None else asked


def cmd_demo(args) -> int:
    return _report(DEMO_SCENE, None, None)[0]


def cmd_bench(args) -> int:
    from .bench import run_bench

    for path in run_bench(args.what, args.scene, args.repeats, models=args.models,
                          build=not args.no_build, workers=args.workers, quick=args.quick,
                          passes=args.passes, sets=args.sets):
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
