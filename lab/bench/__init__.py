"""``splatlab bench``: benchmarks written as JSON under ``reports/bench/`` (:mod:`.output`).

Methods are compared as ratios measured in the same run (the machine is shared and noisy).
One module per benchmark:

- :mod:`.runtime` - every runtime pass of a scene's plan (``bench runtime``);
- :mod:`.precompute` - light tracing and database builds per PSF model (``bench precompute``);
- :mod:`.polygon` - MHU21's exact polygonal bokeh (``bench polygon``);
- :mod:`.spreadlet_throughput` - kernel rates on synthetic discs, and the cost of per-pixel
  rotation (``bench rotation``);
- :mod:`.integrate` - the Poisson integrators: errors against the exact solve and times at
  1024^2 and 4096^2, and on the scene's own spreadlet canvas (``bench integrate``);
- :mod:`.layered` - lens rays through peeled layers: quality and time per ray and layer count
  (``bench layered``, default scene ``scenes/foreground.toml``);
- :mod:`.thick_layered` - lens rays of a thick lens through peeled layers, point rays and cones,
  against the flat image and the paraxial thin lens (``bench thick_layered``, default scene
  ``scenes/thick_highlights.toml``);
- :mod:`.layer_cost` - layers 5-8 against 1-4 of the layered pass on a numpy fence scene
  (``bench layer_cost``);
- :mod:`.tracing` - Dr.Jit PSF tracing rays/s of one model;
- :mod:`.sparsify` - the sparsifier on analytic PSFs (``python -m lab.bench.sparsify``).
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["BENCHES", "run_bench"]


def _runtime(args) -> list:
    from .runtime import bench_runtime

    return [bench_runtime(args["scene"], args["repeats"], reference=args["build"], passes=args["passes"],
                          sets=args["sets"])]


def _precompute(args) -> list:
    from .precompute import bench_precompute

    return [bench_precompute(args["repeats"], args["models"], args["build"], args["workers"])]


def _rotation(args) -> list:
    from .spreadlet_throughput import bench_rotation

    return [bench_rotation(args["repeats"])]


def _polygon(args) -> list:
    from .polygon import bench_polygon

    return [bench_polygon(args["repeats"], quick=args["quick"])]


def _integrate(args) -> list:
    from .integrate import bench_integrate

    return [bench_integrate(args["repeats"], sizes=(1024,) if args["quick"] else (1024, 4096),
                            scene=args["scene"] if args["build"] else None)]


def _layered(args) -> list:
    from lab.paths import DEMO_SCENE, SCENES

    from .layered import bench_layered

    scene = SCENES / "foreground.toml" if Path(args["scene"]) == DEMO_SCENE else args["scene"]
    return [bench_layered(scene, args["repeats"])]


def _thick_layered(args) -> list:
    from lab.paths import DEMO_SCENE, SCENES

    from .thick_layered import bench_thick_layered

    scene = SCENES / "thick_highlights.toml" if Path(args["scene"]) == DEMO_SCENE else args["scene"]
    return [bench_thick_layered(scene, args["repeats"])]


def _layer_cost(args) -> list:
    from .layer_cost import bench_layer_cost

    return [bench_layer_cost(args["repeats"])]


def _splat_layers(args) -> list:
    from .splat_layers import bench_splat_layers

    return [bench_splat_layers(args["scene"], args["repeats"])]


# ``splatlab bench WHAT``: the benchmarks each name runs, in order.
BENCHES = {"runtime": (_runtime,), "precompute": (_precompute,), "polygon": (_polygon,),
           "rotation": (_rotation,), "integrate": (_integrate,), "layered": (_layered,),
           "thick_layered": (_thick_layered,), "layer_cost": (_layer_cost,), "splat_layers": (_splat_layers,),
           "all": (_precompute, _runtime)}


def run_bench(what: str, scene_path, repeats: int, models=None, build: bool = True,
              workers: int = 1, quick: bool = False, passes=None, sets=None) -> list[Path]:
    """Run the benchmarks ``what`` names (:data:`BENCHES`); the JSON files written."""
    from lab.errors import UserError

    if not (isinstance(repeats, int) and repeats >= 1):
        raise UserError(f"--repeats {repeats}: must be an integer >= 1")
    if what not in BENCHES:
        raise UserError(f"bench {what!r}: unknown; choose one of {list(BENCHES)}")
    if sets and what != "runtime":
        raise UserError(f"--set {sets[0]}: pass options are for `bench runtime`, not `bench {what}`")
    from lab.pipeline import load_scene_and_plan

    plan = load_scene_and_plan(scene_path)[1]
    if not plan.scored:   # every bench scores its methods against the scene's reference
        raise UserError(f"--scene {scene_path}: the benches score against a reference, and this scene has none "
                        f"({plan.references[0].detail}); bench another scene")
    args = {"scene": scene_path, "repeats": repeats, "models": models, "build": build,
            "workers": workers, "quick": quick, "passes": passes, "sets": sets}
    return [path for bench in BENCHES[what] for path in bench(args)]
