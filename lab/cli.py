"""The ``splatlab`` command line: plan, precompute, reference, render, report, bench, db, doctor, demo."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from runtime_cl.api import integrators as runtime_integrators
from runtime_cl.api import methods as runtime_methods
from runtime_cl.errors import InputError

from .bench import BENCHES
from .paths import DEMO_SCENE, ROOT

# Top-level modules of the `lab` extra (pyproject.toml): without them only the runtime commands run.
LAB_EXTRA = {"scipy", "drjit", "mitsuba", "skimage", "matplotlib", "PIL", "tqdm", "numba", "shapely",
             "dask", "distributed"}

EPILOG = """\
typical use:
  splatlab demo                                  the main job on the embedded scene (make demo)
  splatlab plan scenes/demo.toml                 what a scene calls for, what runs, what is skipped
  splatlab report scenes/demo.toml               precompute + reference + runtime + SSIM/timing report
  splatlab render in.exr --db simple_lens.spdb --method spreadlets --out out.exr
  splatlab render moving.exr --db combined.spdb --out out.exr   motion.X, motion.Y channels in pixels
  splatlab render in.exr --method polygon --aperture hexagon --out out.exr   exact polygonal bokeh
  splatlab render in.exr --method polygon --layers 8 --out out.exr   ... with occlusion (depth layers)
  splatlab render in.exr --db simple_lens.spdb --integrator pyramid --out out.exr   convolution pyramid
  splatlab render peeled.exr --method layered --rays 100 --out out.exr   lens rays through layers
  splatlab bench runtime                         method timings and kernel throughput -> reports/bench/
  splatlab doctor                                what is installed, what is missing and how to fix it

Bad input (a typo in a scene, an EXR without Z, a foreign database) exits with status 2 and
one line naming the file, the value and the fix.
"""


REFERENCE_EPILOG = """\
examples:
  splatlab reference scenes/demo.toml                                 passes one after the other
  splatlab reference scenes/demo.toml --workers 2                     passes in 2 local processes
  splatlab reference scenes/demo.toml --scheduler tcp://10.0.0.5:8786 passes on a Dask cluster

The reference renders as seeded passes, averaged in pass order: the image is bitwise the same
wherever the passes ran. Each finished pass is kept under .cache/renders/<scene>-<key>/
reference-passes/ until reference.exr is written: interrupt at any time, the same command
resumes. Dask workers: `dask worker tcp://HOST:8786 --nthreads 1 --nworkers K` (same splatlab).
"""


PRECOMPUTE_EPILOG = """\
examples:
  splatlab precompute simple_lens --set max_coc_px=64            one model, defaults + overrides
  splatlab precompute simple_lens --set max_coc_px=64 --workers 2 --atlas reports/atlas
  splatlab precompute scenes/demo.toml                           every model the scene's plan needs
  splatlab precompute simple_lens --set max_coc_px=250 --scheduler tcp://10.0.0.5:8786

A Dask cluster: `dask scheduler` on one machine, `dask worker tcp://HOST:8786 --nthreads 1
--nworkers K` on each worker machine (same splatlab version; workers need not share files).
Interrupt at any time (Ctrl-C, a killed job, a lost node): the same command resumes.
"""


def _add_scene(p):
    p.add_argument("scene", type=Path, help="scene file (TOML), e.g. scenes/demo.toml")


def _int_or_text(text: str):
    """An integer option's value, or its text for the command to reject in one line (exit 2)."""
    try:
        return int(text)
    except ValueError:
        return text


def _add_where(p, what: str):
    """``--workers N`` | ``--scheduler ADDRESS``: where ``what`` runs."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_int_or_text, default=1, metavar="N",
                       help=f"local worker processes for {what} (default 1: this process)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help=f"run {what} on this Dask distributed scheduler's workers")


DESCRIPTIONS = {
    "plan": "Read a scene file and print the effects it calls for (depth of field, motion, medium, "
            "chromatic aberration, aperture), the PSF models that will be precomputed, the references "
            "and runtime passes that will run, and what is skipped with the reason. Nothing is computed.",
    "precompute": "Light-trace (Dr.Jit LLVM) and sparsify (LSR18 5.5) the spreadlet database of one "
                  "registered PSF model (its defaults plus --set KEY=VALUE), or of every model a scene's plan "
                  "needs. Each PSF is written as its own shard, atomically, so an interrupted job resumes "
                  "where it stopped; cells run here, in --workers N local processes or on a Dask cluster "
                  "(--scheduler), with the same database bitwise. The result is cached under .cache/db/ by "
                  "a hash of the model, its configuration and the code: unchanged settings reuse it.",
    "reference": "Render the Mitsuba 3 path-traced reference (through the scene's own camera and "
                 "medium) and the pinhole labelled-pixel input EXR (R, G, B, A, Z and the "
                 "splatlab.camera header). The reference's seeded passes run here, in --workers N local "
                 "processes or on a Dask cluster (--scheduler), each cached so an interrupted render "
                 "resumes; both are cached by a hash of the scene and the rendering code.",
    "stochastic": "Path-trace a stochastic (1-spp) labelled-pixel EXR of a scene (LSR18 6.2, Table 3's "
                  "input): one camera ray per pixel through the scene's own thin lens (round, iris or "
                  "shaped aperture), thick lens (one ray per channel wavelength) or pinhole, each pixel "
                  "with its own lens sample and shutter time, "
                  "written as the channels lens.U, lens.V and time beside R, G, B, A, Z (and motion.X, "
                  "motion.Y for a moving scene). `splatlab render OUT.exr --method stochastic_spreadlets` "
                  "(or stochastic_splat) reconstructs it. Cached by a hash of the scene and the code.",
    "render": "Render a labelled-pixel EXR (from `splatlab reference` or any renderer that writes R, G, B, "
              "A, Z and a splatlab.camera header) with a spreadlet database on the OpenCL device, or "
              "with --method polygon exactly with a flat polygonal aperture (MHU21; no database): each "
              "pixel spreads over the rasterised polygon at its |CoC| from Z and the thin-lens header. "
              "Any model's database works: combined (depth of field + motion) reads the channels "
              "motion.X, motion.Y (pixels over the shutter, Y up); each pixel's PSF is turned as the "
              "database's symmetries say (motion direction, side of the focal plane, azimuth).",
    "report": "The whole job for one scene: plan, labelled-pixel input and Mitsuba reference, PSF "
              "databases, every runtime method, then SSIM/PSNR against the reference and timings in "
              "reports/<scene>/index.html and report.json. Every stage is cached by content hash. "
              "Several scenes: each scene's report, then LSR18 Table 2 over them (Filter / Splat / "
              "spreadlets: time and SSIM, the paper's figures beside ours) in reports/table2/. "
              "--workers N or --scheduler ADDRESS runs the reference's passes and the databases' PSFs "
              "in local processes or on a Dask cluster (same results bitwise).",
    "demo": "Run `splatlab report` on the embedded default scene scenes/demo.toml (1024x1024, 85 mm lens "
            "with large bokeh) and print where the report is. This is what `make demo` runs.",
    "bench": "Benchmarks written as JSON under reports/bench/ (with machine and versions). Methods are "
             "compared as ratios measured in the same run, since the machine is shared and noisy.",
    "db": "Tools for spreadlet database files (.spdb).",
    "info": "Print a database's model, PSF space, sample and spreadlet counts, mean sparsity and "
            "similarity, fast-track count and size as JSON, after verifying its format and checksum.",
    "doctor": "Check the Python packages, Dr.Jit's LLVM backend (needs LLVM >= 16), the Mitsuba variant and "
              "the OpenCL device; print what is missing and the command that installs it. Exit 1 if "
              "anything is missing.",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="splatlab", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Cinematic depth of field, fast and provably right: Dr.Jit light-traced PSFs, "
                    "sparse Laplacian spreadlets (LSR18), an OpenCL splatting runtime and Mitsuba 3 "
                    "references.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("plan", description=DESCRIPTIONS["plan"], help="print the effects a scene calls for and what will run or be skipped")
    _add_scene(p)

    p = sub.add_parser("precompute", description=DESCRIPTIONS["precompute"],
                       help="light-trace and sparsify a PSF model's database (or those a scene needs)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=PRECOMPUTE_EPILOG)
    p.add_argument("target", metavar="MODEL|SCENE",
                   help="a registered PSF model name (e.g. simple_lens) or a scene file (TOML)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets",
                   help="override a model setting (repeatable; TOML values: 64, 2.5, true, [2, 1], circle)")
    _add_where(p, "the cells (each process traces whole cells; also the reference of a scene target)")
    p.add_argument("--threads", type=int, metavar="T", help="Dr.Jit threads per worker process "
                   "(default: cores / workers; with --scheduler, a host's cores / its worker processes)")
    p.add_argument("--out", type=Path, help="copy the database here too (it is always cached by content hash)")
    p.add_argument("--atlas", type=Path, metavar="DIR", help="write the PSF atlas (PNG) and LSR18 Table 1 "
                   "(table.md, table.json) of each database to DIR/<model>/")
    p.add_argument("--force", action="store_true", help="rebuild even when a database with this hash exists")
    p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("reference", description=DESCRIPTIONS["reference"], help="render the Mitsuba reference and the pinhole labelled-pixel input",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=REFERENCE_EPILOG)
    _add_scene(p)
    p.add_argument("--out-dir", type=Path, help="write reference.exr and input.exr here "
                   "(default reports/<scene>/)")
    _add_where(p, "the reference's render passes")
    p.add_argument("--quiet", action="store_true", help="no progress bars")

    p = sub.add_parser("stochastic", description=DESCRIPTIONS["stochastic"],
                       help="path-trace a 1-spp stochastic input with lens samples and times")
    _add_scene(p)
    p.add_argument("--index", type=_int_or_text, default=0, metavar="N",
                   help="which independent image (its own seeds; default 0): average N of them for N spp")
    p.add_argument("--shading-spp", type=_int_or_text, default=1, metavar="S",
                   help="paths traced from each pixel's one camera ray (default 1: a 1-spp path trace; "
                        "more: one visibility sample with converged shading, a stochastic rasterizer's input)")
    p.add_argument("--out", type=Path, help="output EXR (default reports/<scene>/stochastic-<N>.exr)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")

    p = sub.add_parser("render", description=DESCRIPTIONS["render"], help="render a labelled-pixel EXR with a spreadlet database")
    p.add_argument("input", type=Path, help="labelled-pixel EXR: R,G,B,A,Z and the splatlab.camera header")
    p.add_argument("--db", type=Path, help="spreadlet database (splatlab precompute); needed by every "
                   "method but polygon")
    p.add_argument("--far-db", type=Path, help="with a volume --db: the volume_far database of the same scene, "
                   "whose halos reach beyond the volume PSFs' window (fog across a wide frame)")
    methods = runtime_methods()
    p.add_argument("--method", choices=list(methods), default="spreadlets",
                   help="; ".join(f"{name}: {summary}" for name, summary in methods.items())
                        + " (default: spreadlets)")
    p.add_argument("--integrator", metavar="NAME",
                   help="spreadlets: how the Laplacian canvas is integrated; "
                        + "; ".join(f"{name}: {summary}" for name, summary in runtime_integrators().items()))
    p.add_argument("--aperture", metavar="NAME",
                   help="polygon: built-in shape (hexagon, octagon, dodecagon, hexadecagon, heart, "
                        "clover, star; default: the camera header's iris, else hexagon)")
    p.add_argument("--layers", type=int, metavar="N",
                   help="polygon, spreadlets, splat, filter: occlusion with N global depth layers (LSR18), from the EXR's "
                        "layerN.* channels when it has them, else from its flat image; layered: trace "
                        "only the nearest N of the EXR's layers")
    p.add_argument("--rays", type=_int_or_text, metavar="N",
                   help="layered: lens rays per pixel (default 32), traced through the EXR's layerN.* "
                        "layers when it has them (--layers N: only the nearest N), else its flat image")
    p.add_argument("--cone", action="store_true",
                   help="layered: LES09's approximate cone tracing (colour + coverage mipmaps over the spread of "
                        "neighbouring lens rays, thin or thick lens): less grain at few rays")
    p.add_argument("--directions", type=int, default=2, metavar="M",
                   help="polygon: edge directions with run and rise up to M (default 2, MHU21's D)")
    p.add_argument("--edges", type=int, metavar="N",
                   help="polygon: most edges of the rectified aperture (default: its corners, <= 16)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets",
                   help="an option of the method (repeatable; VALUE is a TOML value), e.g. --set soft_layers=0.5 "
                        "(spreadlets, splat, filter with --layers), --set spreadlet_rotation=bank; stochastic_*: "
                        "--set normalize=true --set footprint=bilinear --set depth_layers=4 (the full "
                        "reconstruction of LSR18 Table 3's +fill column); layered: --set interpolate_hidden=false; "
                        "a name the method does not take is an error listing the ones it does")
    p.add_argument("--out", type=Path, required=True, help="output EXR (R, G, B)")
    p.add_argument("--camera", type=Path, help="camera TOML ([camera] table) overriding the EXR header")
    p.add_argument("--focus-point", metavar="X,Y",
                   help="focus on what pixel (X, Y) sees (column, row from the top; its Z), overriding the "
                        "header's focus (thin or thick lens)")

    p = sub.add_parser("report", description=DESCRIPTIONS["report"], help="the whole job for scenes: precompute, references, methods, report")
    p.add_argument("scene", type=Path, nargs="+", help="scene file(s) (TOML), e.g. scenes/whirl.toml scenes/gears.toml")
    p.add_argument("--out-dir", type=Path, help="report directory (default reports/<scene name>/); with several "
                   "scenes, the Table 2 page (default reports/table2/) with each scene's report in <dir>/<scene>/")
    p.add_argument("--baseline", type=Path, help="report.json to check for regressions (exit 1 if any; one scene)")
    p.add_argument("--noise-floor", action=argparse.BooleanOptionalAction, default=None,
                   help="render a second reference with an independent seed and report how far the two agree "
                   "(the SSIM no method can beat) and each method's noise-corrected MSE (default for every "
                   "scene with a reference; --no-noise-floor skips it and the page says so)")
    p.add_argument("--sweep", action="store_true", help="also run every method at each value of each knob that "
                   "applies to it (operating point, PSF samples, rays per PSF, layers, lens rays, integrator, "
                   "reference spp) and plot accuracy against time with the Pareto front; needs the noise floor")
    p.add_argument("--knobs", metavar="A,B", type=lambda s: s.split(","),
                   help="with --sweep: only these knobs (default all; see lab/report/knobs.py)")
    p.add_argument("--set", dest="sets", action="append", metavar="KEY=VALUE",
                   help="an option for every runtime pass of the plan that takes it (repeatable; VALUE is a "
                        "TOML value), e.g. --set spreadlet_rotation=bank; the report records the options")
    p.add_argument("--layers", type=int, metavar="N",
                   help="render the spreadlet passes in N global depth layers as well (LSR18 6.2), beside one: "
                        "replaces the scenes' [render] depth_layers (1-16)")
    _add_where(p, "the reference's render passes and the databases' PSFs")

    sub.add_parser("demo", description=DESCRIPTIONS["demo"], help=f"`report` on the embedded scene {DEMO_SCENE.relative_to(ROOT)}")

    p = sub.add_parser("bench", description=DESCRIPTIONS["bench"], help="benchmarks; JSON under reports/bench/")
    p.add_argument("what", choices=list(BENCHES),
                   help="runtime: every runtime pass of the scene's plan (default the demo: spreadlets vs "
                        "Splat vs Filter at 1024^2), times, SSIM and kernel throughput; precompute: M rays/s "
                        "per PSF model, and (unless --no-build) the wall time to build each model's "
                        "database at default settings, LSR18 Table 1 and a PSF atlas per model; polygon: "
                        "MHU21 exact polygonal bokeh (time vs radius, against brute force / Laplacian / "
                        "dx dy, uniform blur vs FFT; not part of all); rotation: the cost of per-pixel PSF "
                        "rotation, spreadlets with a constant and a per-pixel angle over without (512^2; "
                        "not part of all); layered: lens rays through the peeled layers of --scene (default "
                        "scenes/foreground.toml) for 4..256 rays and 1..L layers against Mitsuba, and spreadlets in "
                        "1/2/4 depth layers beside it at equal time; thick_layered: the same through a thick lens (--scene, "
                        "default scenes/thick_highlights.toml), point rays and cones, against the flat image, a thin "
                        "lens of equal paraxial CoC and the reference's noise floor (not part of all); layer_cost: layers 5-8 against 1-4 of the "
                        "layered pass on an 8-layer numpy scene, and time for 8..256 rays x 1..16 layers (LES10 "
                        "Table 1's axes) on a 16-layer one (neither part of all); splat_layers: "
                        "spreadlets and Splat with 1, 2, 4 depth layers, with and without the guard band, "
                        "times, cost of layers, SSIM/PSNR and the reference's noise floor (not part of all); "
                        "integrate: the Poisson integrators (exact, fft32, pyramid) at 1024^2 and 4096^2 and on "
                        "--scene's own spreadlet canvas (default the demo; --no-build skips it), errors "
                        "against the exact solve and time ratios (not part of all); "
                        "all: precompute and runtime")
    p.add_argument("--quick", action="store_true",
                   help="polygon: small sizes only (a smoke run in seconds); integrate: 1024^2 only")
    p.add_argument("--scene", type=Path, default=DEMO_SCENE, help="scene to benchmark (default: demo)")
    p.add_argument("--repeats", type=int, default=5, help="timed repetitions after warm-up (default 5)")
    p.add_argument("--models", metavar="NAME[,NAME...]",
                   help="precompute: only these registered models (default: all)")
    p.add_argument("--no-build", action="store_true",
                   help="precompute: measure rays/s only, skip the (minutes-long) database builds; "
                        "runtime: render no reference (times and ratios only, no SSIM); integrate: skip the "
                        "scene's own canvas (its Laplacian database)")
    p.add_argument("--passes", metavar="A,B", type=lambda s: s.split(","),
                   help="runtime: only these passes of the scene's plan (default all; the first is "
                        "the ratios' base)")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="precompute: local worker processes for the database builds (default 1)")
    p.add_argument("--set", dest="sets", action="append", metavar="KEY=VALUE",
                   help="runtime: an option for every pass of the plan that takes it (repeatable; VALUE is "
                        "a TOML value), e.g. --set spreadlet_rotation=bank (turned PSFs from an angle bank "
                        "built in each pass's set-up, its time in prepare_ms)")

    p = sub.add_parser("db", description=DESCRIPTIONS["db"], help="spreadlet database tools")
    dbsub = p.add_subparsers(dest="db_command", required=True, metavar="DB_COMMAND")
    q = dbsub.add_parser("info", description=DESCRIPTIONS["info"], help="summarise a database and verify its checksum")
    q.add_argument("file", type=Path)

    sub.add_parser("doctor", description=DESCRIPTIONS["doctor"], help="Dr.Jit backend and LLVM, PoCL device, what is missing and how to install it")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    from . import commands

    handler = getattr(commands, "cmd_" + args.command)
    try:
        return int(handler(args) or 0)
    except InputError as exc:
        print(f"splatlab {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] not in LAB_EXTRA:
            raise
        print(f"splatlab {args.command}: error: this command needs splatlab's lab extra (no module "
              f"{exc.name!r}); install it with `pip install 'splatlab[lab]'` (the base install has "
              "the runtime: `splatlab render` and `splatlab db info`)", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `splatlab db info X | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print(f"splatlab {args.command}: interrupted; finished shards and caches are kept, "
              "run the command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
