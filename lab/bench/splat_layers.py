"""``splatlab bench splat_layers``: depth layers of the spreadlet passes on a scene (LSR18 6.2).

On the scene's input (default the demo) and its reference, spreadlets and LSR18's Splat render
with 1, 2 and 4 global depth layers (and spreadlets from the input's own ``layerN.*`` layers
when it has them, e.g. ``scenes/foreground.toml``'s peeled ones), without and with the guard band (the input rendered with a
margin and cropped, :mod:`lab.reference.guard_band`), each timed by the runtime's contract
(:mod:`runtime_cl.timing`) and scored (SSIM, PSNR) against the reference; the reference's own
noise floor (a second reference with an independent seed) is stated beside them. Figures: the
cost of n layers over n times one layer (LSR18: "layering merely shifts around the work"), the
Splat / spreadlets time ratio at each layer count, all measured in the same run.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from lab.bench import output

__all__ = ["bench_splat_layers"]

LAYERS = (1, 2, 4)
SOFT = 0.5   # the soft-layering width also measured (spreadlets, more than one layer)
METHODS = ("spreadlets", "splat")


def bench_splat_layers(scene_path, repeats: int, layers=LAYERS, methods=METHODS, soft: float = 0.0,
                       soft_variant: float = SOFT) -> Path:
    """See the module docstring; returns the JSON file written."""
    from lab.paths import cache_root
    from lab.pipeline import build_databases, inputs_and_reference, load_scene_and_plan
    from lab.report.metrics import psnr, ssim
    from lab.report.images import save_render
    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase

    scene, plan = load_scene_and_plan(scene_path)
    pictures = cache_root() / "bench" / f"splat_layers-{scene.name}"   # to look at, not committed
    pictures.mkdir(parents=True, exist_ok=True)
    out = {}
    floor = None
    for guard in (False, True):
        s = replace(scene, render=replace(scene.render, guard_band=guard))
        image, reference, info = inputs_and_reference(s, plan, second=not guard)
        floor = info.get("noise_floor", floor)
        databases = build_databases(s, plan, image)
        (name, result), = [(n, r) for n, r in databases.items() if n == "simple_lens"] or databases.items()
        db = SpreadletDatabase.load(result.path, expect_model=name)
        camera = runtime_camera(image)
        frame = frame_of(image, db=db)
        runs = {}
        for n in layers:
            for method in methods:
                rendered, timing = run_pass(method, frame, camera, db, runs=repeats, layers=n, soft_layers=soft)
                rgb = rendered[..., :3]
                runs[f"{method}_{n}"] = dict(timing.to_json(), ssim=ssim(rgb, reference),
                                             psnr=psnr(rgb, reference))
                save_render(rgb, pictures / f"{method}_{n}_{'guard' if guard else 'frame'}.png")
            if n > 1 and soft_variant:
                rendered, timing = run_pass(methods[0], frame, camera, db, runs=repeats, layers=n,
                                            soft_layers=soft_variant)
                runs[f"{methods[0]}_{n}_soft{soft_variant:g}"] = dict(
                    timing.to_json(), ssim=ssim(rendered[..., :3], reference), psnr=psnr(rendered[..., :3], reference))
        save_render(reference, pictures / "reference.png")
        if image.layers():   # a layered input (peeled or [[shapes]] layer keys): spreadlets from its layers
            frame = frame_of(image, db=db, layered_input=True)
            for n in layers:
                rendered, timing = run_pass(methods[0], frame, camera, db, runs=repeats, layers=n,
                                            soft_layers=soft, layered_input=True)
                rgb = rendered[..., :3]
                runs[f"{methods[0]}_{n}_layered_input"] = dict(timing.to_json(), ssim=ssim(rgb, reference),
                                                               psnr=psnr(rgb, reference))
                save_render(rgb, pictures / f"{methods[0]}_{n}_layered_input_{'guard' if guard else 'frame'}.png")
        ratios = {}
        for n in layers:
            for method in methods:
                t1, tn = runs[f"{method}_1"]["time_ms"], runs[f"{method}_{n}"]["time_ms"]
                ratios[f"{method}_{n}_over_{n}x1"] = tn / (n * t1)
            if "splat" in methods and "spreadlets" in methods:
                ratios[f"splat_over_spreadlets_{n}"] = (runs[f"splat_{n}"]["time_ms"]
                                                        / runs[f"spreadlets_{n}"]["time_ms"])
        out["guard" if guard else "frame"] = {"guard_px": image.guard_px, "runs": runs, "ratios": ratios}
    data = {"scene": str(scene_path), "resolution": list(scene.info.resolution), "repeats": repeats,
            "soft_layers": soft, "soft_variant": soft_variant, "reference_spp": scene.render.reference_spp, "noise_floor": floor,
            **out,
            "targets": {"spreadlets_n_over_nx1": "< 1 (LSR18: layering shifts the work around)",
                        "splat_over_spreadlets_n": ">= 10", "spreadlets time_ms": "<= 400 at 1024^2",
                        "spreadlets ssim (2 layers)": ">= 0.97 against a reference with floor >= 0.98"}}
    return output.write_bench("splat_layers", data)
