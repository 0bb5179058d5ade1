"""``splatlab bench thick_layered``: lens rays of a thick lens through the peeled layers, one run.

On a thick-lens scene with ``[render] peel_layers`` (default ``scenes/thick_highlights.toml``), in
the style of LES10 Table 1: for N = 8, 32, 100, 256 lens rays per pixel, SSIM, PSNR and time per
frame of the layered pass through the peeled layers with point rays and with cones (LES09 4.4);
the same through a thin lens of the same paraxial CoC (what the real lens adds: spherical
aberration, cat-eyes, colour) and, at 100 rays, through the flat pinhole image (what the peeled
layers add); and the
Mitsuba thick-lens reference's noise floor (a second reference with an independent seed), the
SSIM no method can beat. Each time is the median of ``repeats`` timed calls after a warm-up,
with the spread; from 100 rays on (tens of seconds a frame at 400x300 on two cores) one call. PNGs of the reference and the renders at 100 rays, with 4x crops of the
off-axis highlights, go beside the JSON (look at them).
"""
from __future__ import annotations

import time

import numpy as np

from lab.bench import output
from lab.bench.layered import _spread, _timed

__all__ = ["bench_thick_layered", "RAYS", "paraxial_thin_lens"]

RAYS = (8, 32, 100, 256)
WARM_UP_BELOW = 100   # ray counts from which a frame is timed once, without a warm-up call


def paraxial_thin_lens(camera, width: int):
    """A thin lens with ``camera``'s focal length, focus and sensor whose CoC scale (px per dioptre
    at ``width``) is the thick lens's paraxial one: no spherical aberration, vignetting,
    distortion or colour."""
    from runtime_cl.camera.thin_lens import ThinLens

    probe = ThinLens(focal_length_mm=camera.focal_length_mm, f_number=2.0, focus_distance_m=camera.focus_distance_m,
                     sensor_width_mm=camera.sensor_width_mm)
    return ThinLens(focal_length_mm=camera.focal_length_mm,
                    f_number=2.0 * probe.coc_scale_px(width) / camera.coc_scale_px(width),
                    focus_distance_m=camera.focus_distance_m, sensor_width_mm=camera.sensor_width_mm)


def _crops(image, boxes, zoom: int = 4) -> np.ndarray:
    """The ``boxes`` (y0, x0, size) of ``image`` side by side, each ``zoom``x (nearest)."""
    tiles = [np.repeat(np.repeat(image[y:y + s, x:x + s], zoom, 0), zoom, 1) for y, x, s in boxes]
    return np.concatenate(tiles, axis=1)


def bench_thick_layered(scene_path, repeats: int, rays=RAYS) -> "Path":
    """The layered pass through a thick lens on ``scene_path``: quality and time per ray count."""
    from lab.errors import UserError
    from lab.pipeline import inputs_and_reference, load_scene_and_plan
    from lab.report.images import save_render
    from lab.report.metrics import psnr, ssim
    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import get_pass

    scene, plan = load_scene_and_plan(scene_path)
    if "layered" not in plan.runtime_passes:
        raise UserError(f"{scene_path}: its plan runs no layered pass; add [render] peel_layers (e.g. 6)")
    if scene.camera.model != "thick":   # before any render
        raise UserError(f"{scene_path}: camera model {scene.camera.model!r}; this bench compares a thick lens "
                        "with its paraxial thin lens (use bench layered for a thin-lens scene)")
    image, reference, info = inputs_and_reference(scene, plan, second=True)
    camera = runtime_camera(image)
    width = reference.shape[1]
    thin = paraxial_thin_lens(camera, width)
    peeled, flat = frame_of(image, layered_input=True), frame_of(image)
    pictures, extra = {}, {}

    def run(name, cam, frame, n, **options):
        p = get_pass("layered")(cam, rays=n, layered_input=frame is peeled, **options)
        prepared = p.prepare(frame)   # builds the kernels
        if n >= WARM_UP_BELOW:        # a frame of tens of seconds: no warm-up call
            start = time.perf_counter()
            img, times = p(prepared)
            walls = [(time.perf_counter() - start) * 1e3]
        else:
            (img, times), walls = _timed(lambda: p(prepared), repeats)
        if n == 100:
            pictures[name] = img
        if frame is peeled:
            extra["occupancy"] = times.counts["occupancy"]
        return {"rays": n, "ssim": ssim(img, reference), "psnr": psnr(img, reference), **_spread(walls),
                "device_ms": times.device_ms}

    methods = {}
    for n in rays:
        methods[f"peeled_{n}"] = run(f"peeled_{n}", camera, peeled, n)
        methods[f"peeled_cone_{n}"] = run(f"peeled_cone_{n}", camera, peeled, n, cone=True)
        methods[f"thin_paraxial_{n}"] = run(f"thin_paraxial_{n}", thin, peeled, n)
        if n == 100:
            methods[f"flat_{n}"] = run(f"flat_{n}", camera, flat, n)
    folder = output.BENCH_DIR
    h, w = reference.shape[:2]
    s = max(16, w // 8)
    boxes = [(0, 0, s), (0, w - s, s), (h - s, 0, s), (h - s, w - s, s)]     # the four corners
    strips = [_crops(reference, boxes)] + [_crops(pictures[k], boxes) for k in
                                           ("peeled_100", "peeled_cone_100", "flat_100", "thin_paraxial_100")]
    save_render(np.concatenate(strips, axis=0), folder / "thick_layered_corners.png")
    for name, img in (("reference", reference), *pictures.items()):
        save_render(img, folder / f"thick_layered_{name}.png")
    data = {"scene": str(scene_path), "resolution": list(scene.info.resolution), "repeats": repeats,
            "reference": {"spp_per_wavelength": scene.render.reference_spp, "seconds": info.get("reference_s")},
            "noise_floor": info.get("noise_floor"), "input_layers": len(image.layers()),
            "occupancy": extra["occupancy"],
            "pinhole_input": {"ssim": ssim(image.rgb, reference), "psnr": psnr(image.rgb, reference)},
            "thin_paraxial": {"f_number": thin.f_number, "coc_scale_px": float(thin.coc_scale_px(width))},
            "methods": methods, "timed_once_from_rays": WARM_UP_BELOW,
            "corners_png": "thick_layered_corners.png: rows reference, peeled 100, cones 100, flat 100, "
                           "paraxial thin 100; columns the corners top-left, top-right, bottom-left, bottom-right"}
    return output.write_bench("thick_layered", data)
