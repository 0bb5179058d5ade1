"""The layered labelled input from Mitsuba: what each layer holds, and that it adds up.

A red ball (layer 0) in front of a green wall (the untagged last layer) under a constant sky and
a sun: layer 0 covers exactly the ball with its planar depth; the wall layer continues behind the
ball (green there, not red), with full coverage; composited "over" without blur, the layers give
the flat pinhole input back (both are 256-spp estimates of the same pixels).
"""
import numpy as np
import pytest

from lab.reference.labelled import render_labelled
from lab.scene import parse_scene

W, H = 40, 32


@pytest.fixture(scope="module")
def layered():
    scene = parse_scene({
        "scene": {"name": "layers", "resolution": [W, H]},
        "camera": {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50,
                   "f_number": 2, "focus_distance_m": 2, "aperture": {"blades": 6}},
        "render": {"input_spp": 256, "max_depth": 3, "seed": 3},
        "materials": {"red": {"reflectance": [0.8, 0.1, 0.1]}, "green": {"reflectance": [0.1, 0.6, 0.2]}},
        "shapes": [{"type": "sphere", "material": "red", "center": [0.1, 0.0, 2.0], "radius": 0.2, "layer": 0},
                   {"type": "rectangle", "material": "green", "center": [0, 0, 4], "scale": [5, 5, 1],
                    "rotate": [0, 180, 0]}],
        "emitters": [{"type": "constant", "radiance": [0.5, 0.5, 0.5]},
                     {"type": "directional", "direction": [0.2, -0.3, 1.0], "irradiance": [2, 2, 2]}],
    }, "layers.toml")
    return scene, render_labelled(scene, progress=False)


def test_layers_hold_their_objects(layered):
    _, im = layered
    ball, wall = im.layers()
    inside, outside = im.depth < 3, im.depth > 3          # pixel centres on the ball / the wall
    assert ball.alpha[inside].min() > 0.4 and ball.alpha[outside].max() < 0.6   # edge pixels: partial
    assert ball.alpha.sum() == pytest.approx(inside.sum(), rel=0.05)   # coverage = the ball's area
    assert np.isinf(ball.depth[ball.alpha == 0]).all()
    assert ball.depth[inside].min() >= 1.8 - 1e-3 and ball.depth[inside].max() <= 2.0 + 1e-3
    np.testing.assert_array_equal(wall.alpha, 1.0)
    np.testing.assert_allclose(wall.depth, 4.0, rtol=1e-5)
    behind = wall.rgb[inside]                                # the wall continues behind the ball
    assert (behind[:, 1] > behind[:, 0]).all()
    assert (ball.rgb[inside][:, 0] > ball.rgb[inside][:, 1]).all()


def test_layers_composite_to_the_flat_input(layered):
    _, im = layered
    ball, wall = im.layers()
    over = ball.rgb + (1 - ball.alpha[..., None]) * wall.rgb
    np.testing.assert_allclose(over.mean(axis=(0, 1)), im.rgb.mean(axis=(0, 1)), rtol=0.02)
    assert np.median(np.abs(over - im.rgb) / (im.rgb + 1e-3)) < 0.05
