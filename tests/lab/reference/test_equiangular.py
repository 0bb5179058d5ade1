"""The equi-angular fog reference (lab/reference/equiangular.py) computes what Mitsuba's volpath
computes: the same image in expectation, path depth for path depth, with far less noise."""
from dataclasses import replace

import numpy as np
import pytest

from lab.paths import SCENES
from lab.pipeline import reseeded
from lab.reference.equiangular import EquiAngularJob, applies, hg_cos_sample, hg_phase
from lab.reference.render import reference_job
from lab.scene import load_scene
from lab.scene_objects import Material


@pytest.mark.parametrize("g", [-0.95, 0.0, 0.6, 0.999])
def test_hg_sampling_draws_the_phase_function(g):
    """Histogram of sampled cosines against the phase function's integral over each bin (4 sigma of
    the bin counts), in numpy and in Dr.Jit."""
    from lab.reference.backend import mitsuba

    mi = mitsuba()
    u = np.random.default_rng(3).random(400_000)
    cos = hg_cos_sample(u, g)
    np.testing.assert_allclose(np.asarray(hg_cos_sample(mi.Float(u.astype(np.float32)), g)), cos, atol=2e-4)
    edges = np.linspace(-1, 1, 41)
    if g == 0:
        cdf = (1 + edges) / 2
    else:   # the phase function's integral over [-1, cos], in closed form
        cdf = (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * edges) - 1 / (1 + g))
    expected = np.diff(cdf) * u.size
    counts = np.histogram(cos, edges)[0]
    if abs(g) < 0.99:   # and hg_phase is that integral's derivative (trapezoids)
        fine = np.linspace(-1, 1, 200_001)
        np.testing.assert_allclose(np.trapezoid(2 * np.pi * hg_phase(fine, g), fine), 1, rtol=1e-4)
    assert np.all(np.abs(counts - expected) <= 4 * np.sqrt(expected) + 2), np.abs(counts - expected).max()


def _scene(max_depth, metal):
    scene = load_scene(SCENES / "tiny_fog.toml")
    materials = dict(scene.materials)
    if metal:   # a mirror: light reaches the camera through it only by the path's own bounce
        materials["subject"] = Material(type="conductor", metal="Au")
    return replace(scene, materials=materials, info=replace(scene.info, resolution=(24, 24)),
                   render=replace(scene.render, max_depth=max_depth))


def _blocks(img):
    return img.reshape(6, 4, 6, 4, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("max_depth,metal", [(2, False), (6, True)])
def test_it_agrees_with_volpath(max_depth, metal):
    """4x4-pixel block means of tiny_fog (24^2; a gold subject in the second case) from 256 spp
    against two volpath renders of 4096 spp: the squared difference from their mean is no larger
    than twice their own noise plus ours (measured: 0.8-1.2x), and so are the image means; the same
    check tells a path depth from the next."""
    scene = _scene(max_depth, metal)
    ea = [_blocks(EquiAngularJob(s, 256, medium=True).run(False)) for s in (scene, reseeded(scene, 1))]
    vp = [_blocks(reference_job(s, 4096).run(False)) for s in (scene, reseeded(scene, 1))]
    noise = np.mean((vp[0] - vp[1]) ** 2) / 4 + np.mean((ea[0] - ea[1]) ** 2) / 2
    err = np.mean((ea[0] - 0.5 * (vp[0] + vp[1])) ** 2)
    assert err < 2 * noise, (err, noise)
    z = (ea[0].mean(axis=(0, 1)) - np.mean(vp, axis=(0, 1, 2))) / np.sqrt(noise / ea[0][..., 0].size)
    assert np.all(np.abs(z) < 4), z   # the image means, per channel
    deeper = _blocks(EquiAngularJob(_scene(max_depth + 1, metal), 256, medium=True).run(False))
    assert np.mean((deeper - 0.5 * (vp[0] + vp[1])) ** 2) > 4 * noise


def test_it_is_far_less_noisy_than_volpath():
    """At the same spp, two seeds of the equi-angular estimator differ by far less than two of volpath
    (tiny_fog at 24^2, 64 spp: measured MSE ratio ~40)."""
    scene = _scene(6, False)
    mse = lambda make: float(np.mean((make(scene) - make(reseeded(scene, 1))) ** 2))   # noqa: E731
    assert 10 * mse(lambda s: EquiAngularJob(s, 64, medium=True).run(False)) < mse(lambda s: reference_job(s, 64).run(False))


def test_it_applies_to_a_scene_filling_medium_only():
    assert applies(load_scene(SCENES / "tiny_fog.toml"))
    assert not applies(load_scene(SCENES / "tiny_fogbox.toml")) and not applies(load_scene(SCENES / "tiny.toml"))
