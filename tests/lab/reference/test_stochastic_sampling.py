"""Where the stochastic input's samples come from: an Owen-scrambled Sobol sequence in shuffled
Morton order over the pixels, and a thick lens's box samples drawn until its ray passes."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import kstest

from lab.paths import SCENES
from lab.reference.sampling import sample_points
from lab.reference.stochastic import passing_lens, render_stochastic
from lab.scene import load_scene
from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.stochastic.thick import backward_rays


@pytest.mark.parametrize("shape", [(256, 256), (48, 64), (3, 5)])
def test_every_pixel_gets_one_uniform_point(shape):
    h, w = shape
    jitter, lens, shutter = sample_points(np.random.default_rng(1), h, w)
    assert jitter.shape == lens.shape == (h * w, 2) and shutter.shape == (h * w,)
    for x in (jitter, lens, shutter):
        assert x.min() >= 0.0 and x.max() < 1.0
    if h * w >= 1024:
        for x in (jitter[:, 0], jitter[:, 1], lens[:, 0], lens[:, 1], shutter):
            assert kstest(x, "uniform").pvalue > 1e-3


@pytest.mark.parametrize("side", [2, 16])
def test_neighbouring_pixels_share_out_the_lens_and_the_shutter(side):
    """Each 2x2 (16x16) block of pixels holds exactly as many lens samples in every quarter of the
    lens square and shutter times in each half of the shutter as its area says (a net); independent
    samples scatter by about 8 around 128 in a 16x16 block (a test of the test: they fail it)."""
    h = w = 256
    jitter, lens, shutter = sample_points(np.random.default_rng(7), h, w)
    per_row = w // side
    block = (np.arange(h * w) // w // side) * per_row + (np.arange(h * w) % w) // side
    quarters = (lens[:, 0] < 0.5) * 2 + (lens[:, 1] < 0.5)
    for k in range(4):
        assert np.all(np.bincount(block[quarters == k], minlength=per_row ** 2) == side * side // 4)
    assert np.all(np.bincount(block[shutter < 0.5], minlength=per_row ** 2) == side * side // 2)
    iid = np.random.default_rng(7).random(h * w)
    assert np.ptp(np.bincount(block[iid < 0.5], minlength=per_row ** 2)) > (20 if side == 16 else 3)


def test_the_pattern_does_not_repeat_or_streak():
    """Neighbouring pixels' lens and time samples are anti-correlated (-0.16 at one pixel) and
    uncorrelated beyond, along rows and columns alike: no stripes for a denoiser to take for
    texture. A Sobol net over the pixel positions themselves gave +0.38 at one pixel along the rows
    and -0.29 at four (streaks), a plain Morton order a lens half repeating every other pixel."""
    h = w = 256
    jitter, lens, shutter = sample_points(np.random.default_rng(5), h, w)
    for x in (lens[:, 0], lens[:, 1], shutter, jitter[:, 0]):
        v = x.astype(np.float64).reshape(h, w) - 0.5
        for axis in (0, 1):
            lag = [float(np.mean(v * np.roll(v, k, axis)) / np.mean(v * v)) for k in (1, 2, 4, 8)]
            assert -0.25 < lag[0] < -0.05 and max(abs(c) for c in lag[1:]) < 0.03, (axis, lag)


def test_a_thick_lens_sample_is_uniform_over_the_rays_that_pass():
    """At a vignetted corner and at the centre of tiny_rain's film: every redrawn sample passes,
    a first draw that passes is kept (the net's stratification stays), and the samples' mean is
    the quadrature of the passing region over a fine grid of the box (what the reference's
    ``box area / A(r)`` averages)."""
    scene = load_scene(SCENES / "tiny_rain.toml")
    camera = scene.camera.runtime_camera()
    shape = (scene.height, scene.width)
    boxes = PupilBoxes.for_camera(camera, shape)
    rng = np.random.default_rng(3)
    g = (np.arange(200) + 0.5) / 200
    grid = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    for point in ((0.5, 0.5), (32.0, 24.0)):
        n = 20000
        film = np.tile(point, (n, 1))
        first = rng.random((n, 2)).astype(np.float32)
        drawn = passing_lens(camera, shape, film, first, rng)
        passed = backward_rays(camera, boxes, shape, film, first, 1)[2]
        assert backward_rays(camera, boxes, shape, film, drawn, 1)[2].all()
        assert np.array_equal(drawn[passed], first[passed]) and 0.0 < passed.mean() < 0.9
        inside = backward_rays(camera, boxes, shape, np.tile(point, (len(grid), 1)), grid, 1)[2]
        exact = grid[inside].mean(axis=0)
        sigma = drawn.std(axis=0) / np.sqrt(n)
        assert np.all(np.abs(drawn.mean(axis=0) - exact) < 4 * sigma + 1e-3), (drawn.mean(axis=0), exact)


def test_a_thick_lens_input_is_as_bright_as_its_reference():
    """tiny_rain's stochastic input averages to the thick-lens reference's brightness (1.02 over
    four images, 2026-12-05): a ray is drawn until the lens passes it, as the reference's weight
    averages over the passing rays. With the blocked box samples left black it was 0.74."""
    from lab.pipeline import inputs_and_reference
    from lab.plan import make_plan

    scene = load_scene(SCENES / "tiny_rain.toml")
    scene = replace(scene, render=replace(scene.render, reference_spp=128))
    _, reference, _ = inputs_and_reference(scene, make_plan(scene), False)
    images = [render_stochastic(scene, i, shading_spp=16).rgb for i in range(4)]
    assert 0.9 < np.mean(images) / reference.mean() < 1.1
