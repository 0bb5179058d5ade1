"""``splatlab bench layered``: lens rays through the peeled layers (LES10 Table 1 style), one run.

On a scene with ``[render] peel_layers`` (default ``scenes/foreground.toml``): for N = 8, 32,
100, 256 lens rays per pixel, SSIM and PSNR against the Mitsuba thin-lens reference and the time
per frame; the same through the flat pinhole image (what the peeled layers add); the time with
the nearest 1, 2, ... layers (the cost of later layers); and Mitsuba's own render through the
scene's lens at low sample counts with an independent seed (the reference's own seed would
reuse its samples and flatter Mitsuba), timed in the same run, for the time at equal SSIM
(:mod:`lab.bench.layered_plot`, which also draws LES10 Fig. 7 beside the JSON). Each time is the median
of ``repeats`` timed calls (after a warm-up), with the spread over them.
"""
from __future__ import annotations

import time

import numpy as np

from lab.bench import output
from lab.bench.layered_plot import equal_quality_speedup, plot_layered, ssim_at_time

__all__ = ["bench_layered", "RAYS"]

RAYS = (4, 8, 32, 100, 256)
SPLAT_LAYERS = (1, 2, 4)   # spreadlets' global depth layers, beside the layered pass at equal time
MITSUBA_SPP = (1, 4, 16, 64, 256, 1024, 4096)


def _timed(call, repeats: int) -> tuple:
    """``call()`` once to warm up, then ``repeats`` times: (first result, ms list)."""
    first = call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) * 1e3)
    return first, times


def _smooth_ssim(image, reference) -> float:
    """SSIM after a 1-px Gaussian on both: grain (the inputs' path-tracing noise) mostly gone, the
    blur and visibility left; a diagnostic beside the plain SSIM."""
    from scipy.ndimage import gaussian_filter

    from lab.report.metrics import ssim

    return ssim(gaussian_filter(image, (1, 1, 0)), gaussian_filter(reference, (1, 1, 0)))


def _spread(times) -> dict:
    return {"time_ms": float(np.median(times)), "min_ms": float(min(times)), "max_ms": float(max(times))}


def _spreadlet_layers(scene, plan, image, reference, repeats: int) -> dict:
    """Spreadlets (LSR18) in 1, 2, 4 global depth layers from the pinhole input, and from the
    peeled layers, timed by the runtime's contract and scored: splatting's answer to the hidden
    background, to set beside the layered pass at equal time."""
    from lab.pipeline import build_databases
    from lab.report.metrics import psnr, ssim
    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase

    result = build_databases(scene, plan, image)["simple_lens"]
    db = SpreadletDatabase.load(result.path, expect_model="simple_lens")
    camera = runtime_camera(image)
    out = {}
    for layered in (False, True):
        frame = frame_of(image, db=db, layered_input=layered)
        for n in SPLAT_LAYERS:
            rendered, timing = run_pass("spreadlets", frame, camera, db, runs=repeats, layers=n,
                                        layered_input=layered)
            rgb = rendered[..., :3]
            out[f"spreadlets_{n}{'_peeled' if layered else ''}"] = dict(
                timing.to_json(), ssim=ssim(rgb, reference), psnr=psnr(rgb, reference))
    return out


def bench_layered(scene_path, repeats: int, rays=RAYS, mitsuba_spp=MITSUBA_SPP) -> "Path":
    """The layered pass on ``scene_path``'s peeled input: quality and time per ray count and layer count."""
    from lab.errors import UserError
    from lab.pipeline import inputs_and_reference, load_scene_and_plan, reseeded
    from lab.reference.render import reference_job
    from lab.report.metrics import psnr, ssim
    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import get_pass

    scene, plan = load_scene_and_plan(scene_path)
    if "layered" not in plan.runtime_passes:
        raise UserError(f"{scene_path}: its plan runs no layered pass; add [render] peel_layers (e.g. 8)")
    image, reference, ref_info = inputs_and_reference(scene, plan)
    camera = runtime_camera(image)
    peeled, flat = frame_of(image, layered_input=True), frame_of(image)

    def run(frame, **options):
        p = get_pass("layered")(camera, **options)
        prepared = p.prepare(frame)
        (img, times), walls = _timed(lambda: p(prepared), repeats)
        return img, times, walls

    methods = {}
    for n in rays:
        for name, frame, layered in (("peeled", peeled, True), ("flat", flat, False)):
            if name == "flat" and n != 100:
                continue
            img, times, walls = run(frame, rays=n, layered_input=layered)
            methods[f"{name}_{n}"] = {"rays": n, "ssim": ssim(img, reference), "psnr": psnr(img, reference),
                                      "ssim_smoothed": _smooth_ssim(img, reference),
                                      **_spread(walls), "device_ms": times.device_ms, "counts": times.counts}
    pinhole = {"ssim": ssim(image.rgb, reference), "ssim_smoothed": _smooth_ssim(image.rgb, reference)}
    n_layers = len(image.layers())
    layers = {}
    for k in range(1, n_layers + 1):
        img, times, walls = run(peeled, rays=100, layered_input=True, max_layers=k)
        layers[k] = {"ssim": ssim(img, reference), **_spread(walls), "device_ms": times.device_ms}
    mitsuba = {}
    for spp in mitsuba_spp:
        start = time.perf_counter()
        img = reference_job(reseeded(scene, 2), spp=spp).run(progress=False)   # independent noise
        mitsuba[spp] = {"ssim": ssim(img, reference), "psnr": psnr(img, reference),
                        "ssim_smoothed": _smooth_ssim(img, reference),
                        "time_ms": (time.perf_counter() - start) * 1e3}
    splats = _spreadlet_layers(scene, plan, image, reference, repeats)
    curve = [(m["time_ms"], m["ssim"]) for k, m in methods.items() if k.startswith("peeled_")]
    for v in splats.values():
        v["layered_at_equal_time"] = ssim_at_time(v["time_ms"], curve)
    t4 = layers[min(4, n_layers)]["time_ms"]
    equal = {k: equal_quality_speedup(m["ssim"], m["time_ms"], mitsuba) for k, m in methods.items()
             if k.startswith("peeled_")}
    data = {"scene": str(scene_path), "resolution": list(scene.info.resolution), "repeats": repeats,
            "reference": {"spp": scene.render.reference_spp, "seconds": ref_info.get("reference_s")},
            "input_layers": n_layers, "occupancy": methods["peeled_100"]["counts"]["occupancy"],
            "pinhole_input": pinhole, "methods": methods, "layers": layers, "mitsuba_low_spp": mitsuba,
            "mitsuba_at_equal_ssim": equal, "equal_time": splats,
            "cost_layers_5_8_over_1_4": ((layers[min(8, n_layers)]["time_ms"] - t4) / t4
                                         if n_layers > 4 else None),
            "targets": {"peeled_100.ssim": ">= 0.98 (<= 7 layers, 800x600)",
                        "cost_layers_5_8_over_1_4": "<= 0.4 (LES10: 0.2-0.3)",
                        "time vs Mitsuba at equal SSIM": ">= 100x less"}}
    path = output.write_bench("layered", data)
    plot_layered(data, path.with_suffix(".png"))
    return path
