"""The ``splatlab`` command line: plan, precompute, reference, render, report, bench, db, doctor, demo."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from runtime_cl.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
DEMO_SCENE = ROOT / "scenes" / "demo.toml"

EPILOG = """\
typical use:
  splatlab demo                                  the main job on the embedded scene (make demo)
  splatlab plan scenes/demo.toml                 what a scene calls for, what runs, what is skipped
  splatlab report scenes/demo.toml               precompute + reference + runtime + SSIM/timing report
  splatlab render in.exr --db simple_lens.spdb --method spreadlets --out out.exr
  splatlab bench runtime                         method timings and kernel throughput -> reports/bench/
  splatlab doctor                                what is installed, what is missing and how to fix it

Bad input (a typo in a scene, an EXR without Z, a foreign database) exits with status 2 and
one line naming the file, the value and the fix.
"""


def _add_scene(p):
    p.add_argument("scene", type=Path, help="scene file (TOML), e.g. scenes/demo.toml")


DESCRIPTIONS = {
    "plan": "Read a scene file and print the effects it calls for (depth of field, motion, medium, "
            "chromatic aberration, aperture), the PSF models that will be precomputed, the references "
            "and runtime passes that will run, and what is skipped with the reason. Nothing is computed.",
    "precompute": "Light-trace (Dr.Jit LLVM) and sparsify (LSR18 5.5) every PSF database the scene's plan "
                  "needs. Each PSF is written as its own shard, so an interrupted job resumes; the result "
                  "is cached under .cache/db/ by a hash of the model, its configuration and the code.",
    "reference": "Render the Mitsuba 3 path-traced reference (through the scene's thin lens) and the "
                 "pinhole labelled-pixel input EXR (R, G, B, A, Z and the splatlab.camera header).",
    "render": "Render a labelled-pixel EXR (from `splatlab reference` or any renderer that writes R, G, B, "
              "A, Z and a splatlab.camera header) with a spreadlet database on the OpenCL device.",
    "report": "The whole job for one scene: plan, labelled-pixel input and Mitsuba reference, PSF "
              "databases, every runtime method, then SSIM/PSNR against the reference and timings in "
              "reports/<scene>/index.html and report.json. Every stage is cached by content hash.",
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

    p = sub.add_parser("precompute", description=DESCRIPTIONS["precompute"], help="light-trace and sparsify the PSF databases a scene needs")
    _add_scene(p)
    p.add_argument("--out", type=Path, help="copy the database here too (it is always cached by content hash)")
    p.add_argument("--force", action="store_true", help="rebuild even when a database with this hash exists")

    p = sub.add_parser("reference", description=DESCRIPTIONS["reference"], help="render the Mitsuba reference and the pinhole labelled-pixel input")
    _add_scene(p)
    p.add_argument("--out-dir", type=Path, help="write reference.exr and input.exr here "
                   "(default reports/<scene>/)")

    p = sub.add_parser("render", description=DESCRIPTIONS["render"], help="render a labelled-pixel EXR with a spreadlet database")
    p.add_argument("input", type=Path, help="labelled-pixel EXR: R,G,B,A,Z and the splatlab.camera header")
    p.add_argument("--db", type=Path, required=True, help="spreadlet database (splatlab precompute)")
    p.add_argument("--method", choices=("spreadlets", "splat", "filter"), default="spreadlets",
                   help="spreadlets: LSR18 Laplacian splatting; splat: dense PSF splatting; "
                        "filter: gathering with the PSF (default: spreadlets)")
    p.add_argument("--out", type=Path, required=True, help="output EXR (R, G, B)")
    p.add_argument("--camera", type=Path, help="camera TOML ([camera] table) overriding the EXR header")

    p = sub.add_parser("report", description=DESCRIPTIONS["report"], help="the whole job for a scene: precompute, references, methods, report")
    _add_scene(p)
    p.add_argument("--out-dir", type=Path, help="report directory (default reports/<scene name>/)")
    p.add_argument("--baseline", type=Path, help="report.json to check for regressions (exit 1 if any)")

    sub.add_parser("demo", description=DESCRIPTIONS["demo"], help=f"`report` on the embedded scene {DEMO_SCENE.relative_to(ROOT)}")

    p = sub.add_parser("bench", description=DESCRIPTIONS["bench"], help="benchmarks; JSON under reports/bench/")
    p.add_argument("what", choices=("runtime", "precompute", "all"),
                   help="runtime: spreadlets vs Splat vs Filter and kernel throughput at 1024^2 on the "
                        "demo scene; precompute: PSF tracing in M rays/s")
    p.add_argument("--scene", type=Path, default=DEMO_SCENE, help="scene to benchmark (default: demo)")
    p.add_argument("--repeats", type=int, default=5, help="timed repetitions after warm-up (default 5)")

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
    except BrokenPipeError:  # e.g. `splatlab db info X | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print(f"splatlab {args.command}: interrupted; finished shards and caches are kept, "
              "run the command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
