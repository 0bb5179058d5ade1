"""``splatlab bench layer_cost``: what layers 5-8 cost the layered pass beside layers 1-4 (LES10),
and LES10 Table 1's grid of time per frame over lens rays and 1 ... 16 layers.

A scene that peels into 8 layers, built in numpy so it needs no Mitsuba: a fence of 60 vertical
posts at 0.5-3 m in front of a wall at 6 m, seen through the foreground scene's lens (50 mm f/1.4,
focus 4 m, 800x600). Each pixel's surfaces along the centre ray are peeled as LES10 does (the next
one only past the umbra offset of the last, :func:`lab.reference.peel.umbra_offset`), so later
layers are ever sparser. The pass then traces the nearest 4 and all 8 layers, the two runs
interleaved so the machine's load drifts over both alike; the figure is the ratio of the extra
time of layers 5-8 to the time of layers 1-4 (LES10: 20-30 %). The grid then times N = 8 ... 256
rays through the nearest 1, 2, 4, 8 and 16 layers of the same scene with 300 posts (16 layers
deep); it has no reference, so it says what layers cost, not what they buy (``bench layered``).
"""
from __future__ import annotations

import time

import numpy as np

from lab.bench import output

__all__ = ["bench_layer_cost", "fence_layers"]


GRID_RAYS = (8, 32, 100, 256)
GRID_LAYERS = (1, 2, 4, 8, 16)


def fence_layers(camera, width: int = 800, height: int = 600, posts: int = 60, seed: int = 0,
                 n_layers: int = 8) -> list:
    """The peeled layers of the fence scene: a list of (rgb, alpha, depth), nearest first."""
    from lab.reference.peel import umbra_offset

    rng = np.random.default_rng(seed)
    scale = camera.coc_scale_px(width)
    surfaces = [(6.0, np.ones(width, bool), rng.random(3))]                 # the wall
    for _ in range(posts):
        depth = rng.uniform(0.5, 3.0)
        centre, half = rng.uniform(0, width), rng.uniform(0.015, 0.04) / depth * camera.focal_px(width)
        cover = np.abs(np.arange(width) + 0.5 - centre) < half
        surfaces.append((depth, cover, rng.random(3)))
    surfaces.sort(key=lambda s: s[0])
    layers = [[np.zeros((height, width, 3), np.float32), np.zeros((height, width), np.float32),
               np.full((height, width), np.inf, np.float32)] for _ in range(n_layers)]
    for x in range(width):                       # the posts are vertical: one column is every row
        k, reach = 0, 0.0
        for depth, cover, colour in surfaces:
            if k == n_layers or not cover[x] or depth < reach:
                continue
            rgb, alpha, z = layers[k]
            rgb[:, x], alpha[:, x], z[:, x] = colour, 1.0, depth
            reach, k = depth + umbra_offset(depth, scale), k + 1
    return [tuple(x) for x in layers]


def bench_layer_cost(repeats: int, rays: int = 100) -> "Path":
    """Layers 5-8 against 1-4 of the fence scene (see the module docstring)."""
    from runtime_cl.camera.thin_lens import ThinLens
    from runtime_cl.frame import Frame
    from runtime_cl.passes import get_pass

    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=4.0)
    layers = fence_layers(camera)
    frames = [Frame(rgb, z, alpha=a) for rgb, a, z in layers]
    frame = Frame(layers[0][0], layers[0][2], layers=frames)
    passes = {}
    for n in (4, 8):
        p = get_pass("layered")(camera, rays=rays, layered_input=True, max_layers=n)
        prepared = p.prepare(frame)
        p(prepared)                                                         # warm-up
        passes[n] = (p, prepared)
    times = {4: [], 8: []}
    for _ in range(repeats):
        for n in (4, 8):
            p, prepared = passes[n]
            start = time.perf_counter()
            p(prepared)
            times[n].append((time.perf_counter() - start) * 1e3)
    t4, t8 = float(np.median(times[4])), float(np.median(times[8]))
    ratios = [(b - a) / a for a, b in zip(times[4], times[8])]
    data = {"scene": "fence (numpy, 800x600, 60 posts, wall at 6 m)", "rays": rays, "repeats": repeats,
            "occupancy": [float(np.mean(a > 0)) for _, a, _ in layers],
            "time_ms_layers_1_4": t4, "time_ms_layers_1_8": t8, "times_ms": times,
            "cost_layers_5_8_over_1_4": (t8 - t4) / t4,
            "cost_ratio_per_pair": {"min": min(ratios), "max": max(ratios)},
            "targets": {"cost_layers_5_8_over_1_4": "<= 0.4 (LES10: 0.2-0.3)"}}
    data["grid"] = _grid(camera, repeats)
    return output.write_bench("layer_cost", data)


def _grid(camera, repeats: int) -> dict:
    """Median ms per frame for GRID_RAYS x GRID_LAYERS on the 16-layer fence (LES10 Table 1's axes)."""
    from runtime_cl.frame import Frame
    from runtime_cl.passes import get_pass

    layers = fence_layers(camera, posts=300, n_layers=max(GRID_LAYERS))
    frames = [Frame(rgb, z, alpha=a) for rgb, a, z in layers]
    frame = Frame(layers[0][0], layers[0][2], layers=frames)
    table = {}
    for rays in GRID_RAYS:
        for n in GRID_LAYERS:
            p = get_pass("layered")(camera, rays=rays, layered_input=True, max_layers=n)
            prepared = p.prepare(frame)
            p(prepared)                                                     # warm-up
            times = []
            for _ in range(repeats):
                start = time.perf_counter()
                p(prepared)
                times.append((time.perf_counter() - start) * 1e3)
            table[f"{rays}_rays_{n}_layers"] = {"rays": rays, "layers": n, "time_ms": float(np.median(times)),
                                                "min_ms": min(times), "max_ms": max(times)}
    return {"scene": "fence (numpy, 800x600, 300 posts, wall at 6 m)",
            "occupancy": [float(np.mean(a > 0)) for _, a, _ in layers], "times": table}
