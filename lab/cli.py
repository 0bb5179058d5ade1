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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="splatlab", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Cinematic depth of field, fast and provably right: Dr.Jit light-traced PSFs, "
                    "sparse Laplacian spreadlets (LSR18), an OpenCL splatting runtime and Mitsuba 3 "
                    "references.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("plan", help="print the effects a scene calls for and what will run or be skipped")
    _add_scene(p)

    p = sub.add_parser("precompute", help="light-trace and sparsify the PSF databases a scene needs")
    _add_scene(p)
    p.add_argument("--out", type=Path, help="copy the database here too (it is always cached by content hash)")
    p.add_argument("--force", action="store_true", help="rebuild even when a database with this hash exists")

    p = sub.add_parser("reference", help="render the Mitsuba reference and the pinhole labelled-pixel input")
    _add_scene(p)
    p.add_argument("--out-dir", type=Path, help="write reference.exr and input.exr here "
                   "(default reports/<scene>/)")

    p = sub.add_parser("render", help="render a labelled-pixel EXR with a spreadlet database")
    p.add_argument("input", type=Path, help="labelled-pixel EXR: R,G,B,A,Z and the splatlab.camera header")
    p.add_argument("--db", type=Path, required=True, help="spreadlet database (splatlab precompute)")
    p.add_argument("--method", choices=("spreadlets", "splat", "filter"), default="spreadlets",
                   help="spreadlets: LSR18 Laplacian splatting; splat: dense PSF splatting; "
                        "filter: gathering with the PSF (default: spreadlets)")
    p.add_argument("--out", type=Path, required=True, help="output EXR (R, G, B)")
    p.add_argument("--camera", type=Path, help="camera TOML ([camera] table) overriding the EXR header")

    p = sub.add_parser("report", help="the whole job for a scene: precompute, references, methods, report")
    _add_scene(p)
    p.add_argument("--out-dir", type=Path, help="report directory (default reports/<scene name>/)")
    p.add_argument("--baseline", type=Path, help="report.json to check for regressions (exit 1 if any)")

    sub.add_parser("demo", help=f"`report` on the embedded scene {DEMO_SCENE.relative_to(ROOT)}")

    p = sub.add_parser("bench", help="benchmarks; JSON under reports/bench/")
    p.add_argument("what", choices=("runtime", "precompute", "all"),
                   help="runtime: spreadlets vs Splat vs Filter and kernel throughput at 1024^2 on the "
                        "demo scene; precompute: PSF tracing in M rays/s")
    p.add_argument("--scene", type=Path, default=DEMO_SCENE, help="scene to benchmark (default: demo)")
    p.add_argument("--repeats", type=int, default=5, help="timed repetitions after warm-up (default 5)")

    p = sub.add_parser("db", help="spreadlet database tools")
    dbsub = p.add_subparsers(dest="db_command", required=True, metavar="DB_COMMAND")
    q = dbsub.add_parser("info", help="summarise a database and verify its checksum")
    q.add_argument("file", type=Path)

    sub.add_parser("doctor", help="Dr.Jit backend and LLVM, PoCL device, what is missing and how to install it")
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
    except KeyboardInterrupt:
        print(f"splatlab {args.command}: interrupted; finished shards and caches are kept, "
              "run the command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
