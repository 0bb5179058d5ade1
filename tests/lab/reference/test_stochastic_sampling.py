"""Where the stochastic input's samples come from: one point of an Owen-scrambled Sobol net per pixel,
and a thick lens's box samples drawn until its ray passes."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import kstest

from lab.paths import SCENES
from lab.reference.stochastic import passing_lens, render_stochastic, sample_points
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


def test_neighbouring_pixels_share_out_the_lens_and_the_shutter():
    """Each 16x16 block of pixels holds exactly as many lens samples in every quarter of the lens
    square and shutter times in each half of the shutter as its area says (a net); independent
    samples scatter by about 8 around 128 (a test of the test: they fail it)."""
    h = w = 256
    jitter, lens, shutter = sample_points(np.random.default_rng(7), h, w)
    block = (np.arange(h * w) // w // 16) * 16 + (np.arange(h * w) % w) // 16
    quarters = (lens[:, 0] < 0.5) * 2 + (lens[:, 1] < 0.5)
    for k in range(4):
        assert np.all(np.bincount(block[quarters == k], minlength=256) == 64)
    assert np.all(np.bincount(block[shutter < 0.5], minlength=256) == 128)
    iid = np.random.default_rng(7).random(h * w)
    assert np.ptp(np.bincount(block[iid < 0.5], minlength=256)) > 20


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
