"""The variance-guided reference (lab/reference/adaptive.py): the pass-spread variance, the
allocation, no bias against a brute-force render, and a lower error than uniform sampling at the
same number of samples."""
from dataclasses import replace

import numpy as np
import pytest

from lab.reference.adaptive import AdaptiveJob, allocate, tile_grid, tonemapped_error
from lab.reference.execute import run_job
from lab.reference.passes import Accumulator, RenderPass
from lab.reference.render import reference_job
from lab.report.metrics import ssim, tonemap
from lab.scene import AdaptiveSettings, parse_scene

# A grey wall under a uniform sky, out of focus, and one tiny bright light in front of it whose
# bokeh disc (~13 px across at 48 px) is the speckle: a lens sample rarely sees the light.
SCENE = {
    "scene": {"name": "speckle", "resolution": [48, 48]},
    "camera": {"model": "thin", "position": [0.0, 0.0, 0.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 1.0, 0.0],
               "focal_length_mm": 85.0, "f_number": 0.5, "focus_distance_m": 1.0, "sensor_width_mm": 36.0},
    "render": {"reference_spp": 64, "input_spp": 4, "seed": 3, "max_depth": 3},
    "materials": {"wall": {"reflectance": [0.5, 0.5, 0.5]}},
    "shapes": [{"type": "rectangle", "material": "wall", "center": [0.0, 0.0, 3.0], "scale": [3.0, 3.0, 1.0],
                "rotate": [0.0, 180.0, 0.0]},
               {"type": "sphere", "center": [0.05, 0.04, 2.5], "radius": 0.01,
                "emitter": {"radiance": [200.0, 160.0, 120.0], "sampling_weight": 0.02}}],
    "emitters": [{"type": "constant", "radiance": [0.3, 0.3, 0.3]}],
}
# 64 spp everywhere (a pilot of 8 spp, not in the image) and 64 spp more per pixel of the frame on at
# most 9 of the 9 16-px tiles: measured on seeds 5 and 6, SSIM +0.021 / +0.025 over uniform 136 spp,
# the worst 8-px tile's error 3.5x / 6.6x lower
SETTINGS = AdaptiveSettings(extra_spp=64, tiles=9, tile_px=16, pilot_spp=8)


@pytest.fixture(scope="module")
def speckle():
    return parse_scene(SCENE, "speckle")


@pytest.fixture(scope="module")
def brute(speckle):
    """An 8192-spp uniform render from its own seed: (mean, variance of the mean). Four passes of
    2048 spp: each 2^22 samples, thread-count independent (passes.py), and 3 degrees of freedom per
    pixel for its variance, summed over hundreds of pixels where it is used."""
    acc = run_job(reference_job(replace(speckle, render=replace(speckle.render, seed=991)), spp=8192, pass_spp=2048),
                  progress=False, stats=True)
    return acc.mean().astype(np.float64), acc.variance()


def adaptive(scene, settings=SETTINGS):
    """The adaptive render, its info and the accumulators of its rounds (by name)."""
    rounds = {}

    def run(job, name, stats):
        rounds[name] = (job.crop, run_job(job, progress=False, stats=True))
        return rounds[name][1]

    image, info = AdaptiveJob(reference_job(scene), settings).run(run)
    return image, info, rounds


def test_accumulator_variance_is_the_spread_of_unequal_passes():
    rng = np.random.default_rng(0)
    sigma, trials = 2.0, 4000
    counts = [4, 4, 2, 1, 8]   # samples per pass (its weight)
    estimates, means = [], []
    for _ in range(trials):
        acc = Accumulator()
        for i, n in enumerate(counts):
            samples = rng.normal(1.0, sigma, (n, 1, 1, 3))
            acc.add(RenderPass(i, n, i, (float(n),) * 3), samples.mean(axis=0))
        estimates.append(acc.variance()[0, 0, 0])
        means.append(acc.mean()[0, 0, 0])
    true = sigma ** 2 / sum(counts)
    # unbiased: the mean of 4000 estimates (chi-square, 4 dof: sd = true * sqrt(2 / 4)) within 4 standard errors
    assert abs(np.mean(estimates) - true) < 4 * true * np.sqrt(0.5 / trials)
    # and it is the variance the mean really has (sample variance of 4000 means: rel. sd sqrt(2 / 4000))
    assert np.var(means, ddof=1) == pytest.approx(true, rel=4 * np.sqrt(2 / trials))


def test_allocation_is_neyman_water_filled_within_budget():
    error = np.zeros((32, 48))
    grid = tile_grid(48, 32, 16)
    assert len(grid) == 6 and grid[2] == (32, 0, 16, 16)
    for value, (x, y, w, h) in zip([4.0, 1.0, 0.0, 9.0, 0.25, 1e-6], grid):
        error[y:y + h, x:x + w] = value
    budget = 100.0 * 32 * 48
    chosen = allocate(error, 16.0, budget, 3, 16)
    assert [i for i, *_ in chosen] == [3, 0, 1]          # the 3 largest errors, at most 3 tiles
    spent = sum(n * w * h for _, (_, _, w, h), n in chosen)
    assert budget - 3 * 256 <= spent <= budget            # rounding down costs < 1 spp per tile
    totals = np.array([16 + n for *_, n in chosen], float)
    np.testing.assert_allclose(totals / totals[0], [1.0, 2 / 3, 1 / 3], rtol=0.02)   # n_t ~ sqrt(e_t)
    assert allocate(np.zeros((32, 48)), 16.0, budget, 3, 16) == []      # nothing to refine
    # a tile too quiet for the water level gets nothing: a small budget goes to the noisiest tile only
    assert [i for i, *_ in allocate(error, 16.0, 4.0 * 256, 6, 16)] == [3]


def test_tonemapped_error_ignores_noise_above_white():
    mean = np.full((8, 8, 3), 50.0)
    assert tonemapped_error(mean, np.full((8, 8, 3), 1.0)).max() == 0.0   # clipped either way
    dark = tonemapped_error(np.full((8, 8, 3), 0.1), np.full((8, 8, 3), 1e-4))
    slope = (tonemap(np.array(0.1 + 1e-3)) - tonemap(np.array(0.1 - 1e-3))) / 2e-3
    np.testing.assert_allclose(dark, slope ** 2 * 1e-4, rtol=0.01)        # the delta method where T is smooth


def test_adaptive_render_is_unbiased(speckle, brute):
    """Per refined tile and channel, and over the rest of the frame, the adaptive image minus the
    brute-force one, summed, in units of its standard deviation (pixels are independent; each
    pixel's variance from its own passes' spread)."""
    image, info, rounds = adaptive(speckle)
    assert 1 <= info["tiles_refined"] <= SETTINGS.tiles and "pilot" in rounds
    ref, ref_var = brute
    base = rounds["base"][1]
    weights = np.broadcast_to(base.weights, image.shape).copy()
    refined = np.zeros(image.shape[:2], bool)
    for name, (crop, acc) in rounds.items():
        if name.startswith("tile"):
            x, y, w, h = crop
            weights[y:y + h, x:x + w] += acc.weights
            refined[y:y + h, x:x + w] = True
    # a pixel's samples all have the brute-force render's per-sample variance (8192 x its mean's)
    var = ref_var * 8192 / weights + ref_var
    diff = image.astype(np.float64) - ref
    regions = [refined, ~refined]
    z = [diff[r][:, c].sum() / np.sqrt(var[r][:, c].sum()) for r in regions for c in range(3)]
    # 6 tests of a sum over >= 384 independent pixels (near normal): |z| < 4.5 fails once in 10^4 runs
    assert np.all(np.abs(z) < 4.5), z
    # what the test can see: the refined region 25 % too dark is far outside the noise
    biased = [(0.75 * image[refined][:, c] - ref[refined][:, c]).sum() / np.sqrt(var[refined][:, c].sum())
              for c in range(3)]
    assert np.all(np.abs(biased) > 4.5), biased


def test_adaptive_beats_uniform_at_equal_samples(speckle, brute):
    ref, _ = brute
    image, info, _ = adaptive(replace(speckle, render=replace(speckle.render, seed=5)))
    total = round(info["total_spp"])           # pilot + base + extra, per pixel of the frame
    uniform = run_job(reference_job(replace(speckle, render=replace(speckle.render, seed=5)), spp=total),
                      progress=False)

    def worst_tile(img):
        e = ((tonemap(img) - tonemap(ref)) ** 2).mean(axis=2)
        return max(e[y:y + h, x:x + w].mean() for x, y, w, h in tile_grid(48, 48, 8))

    # margins: half the gains measured on two seeds (see SETTINGS)
    assert worst_tile(image) < 0.5 * worst_tile(uniform)
    assert ssim(image, ref) > ssim(uniform, ref) + 0.01


def test_the_setting_changes_the_render_key_and_round_trips(speckle):
    from lab.pipeline import render_key
    from lab.scene import parse_scene

    asked = parse_scene({**SCENE, "render": {**SCENE["render"], "reference_adaptive": {"extra_spp": 64}}}, "a")
    other = replace(asked, render=replace(asked.render, reference_adaptive=replace(
        asked.render.reference_adaptive, tiles=4)))
    keys = {render_key(s) for s in (speckle, asked, other)}
    assert len(keys) == 3
    assert parse_scene(asked.to_dict(), "again") == asked
    assert asked.render.reference_adaptive == AdaptiveSettings(extra_spp=64)


def test_crop_passes_do_not_depend_on_the_thread_count(speckle):
    """A tile's passes are large (no 4-spp split) and render on one thread: the same image on 1 or
    2 Dr.Jit threads, bit for bit."""
    import drjit as dr

    job = replace(reference_job(speckle, spp=96), crop=(8, 8, 16, 16))
    assert [p.spp for p in job.passes()] == [64, 32] and all(job.one_thread(p) for p in job.passes())
    threads, images = dr.thread_count(), []
    try:
        for n in (1, 2):
            dr.set_thread_count(n)
            images.append(np.stack([job.render(p) for p in job.passes()]))
    finally:
        dr.set_thread_count(threads)
    assert images[0].shape == (2, 16, 16, 3) and np.array_equal(images[0], images[1])
    assert dr.thread_count() == threads
