"""Hard cases of the layered pass (issue 14): empty layers and fully transparent pixels. The
reference is the same render without the empty or transparent layer: a layer that holds nothing
must change no ray's hit, so the images agree bit for bit."""
import numpy as np

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.frame import Frame

CAMERA = ThinLens(focal_length_mm=50.0, f_number=1.0, focus_distance_m=1.0)
H, W = 24, 40


def _scene():
    rng = np.random.default_rng(5)
    rgb = rng.random((H, W, 3)).astype(np.float32)
    depth = np.where(np.arange(W)[None, :] < 20, 0.6, 3.0) * np.ones((H, 1))   # CoC -5.6 / +4.4 px
    return rgb, depth


def _render(rgb, depth, layers):
    return runtime_cl.render(rgb, depth, CAMERA, method="layered", rays=16, layered_input=True,
                             input_layers=layers)


def test_an_empty_layer_changes_nothing():
    """A layer with alpha 0 everywhere (colour 0, finite depth: not the sky), behind or in front
    of the opaque one: the image is the one-layer image, bit for bit."""
    rgb, depth = _scene()
    solid = Frame(rgb, depth)
    empty = Frame(np.zeros_like(rgb), np.full((H, W), 0.8), alpha=np.zeros((H, W), np.float32))
    one, t1 = _render(rgb, depth, (solid,))
    for layers in ((solid, empty), (empty, solid)):
        got, t = _render(rgb, depth, layers)
        np.testing.assert_array_equal(got, one)
        assert t.counts["rays_hit"] == t1.counts["rays_hit"] and t.counts["rays_missed"] == t1.counts["rays_missed"]


def test_fully_transparent_pixels_let_every_ray_through_to_the_layer_behind():
    """A front layer whose left half is opaque and right half fully transparent (alpha 0): the
    right half of the image, beyond the front layer's reach (its CoC, 6 px), is the back layer's
    own render, bit for bit."""
    rgb, depth = _scene()
    back = Frame(rgb, depth)
    front_alpha = (np.arange(W)[None, :] < 10) * np.ones((H, 1), np.float32)
    front = Frame(np.full((H, W, 3), 0.5, np.float32) * front_alpha[..., None], np.full((H, W), 0.5),
                  alpha=front_alpha.astype(np.float32))
    alone, _ = _render(rgb, depth, (back,))
    got, _ = _render(rgb, depth, (front, back))
    reach = 10 + 8                                     # the front layer's edge plus its CoC (< 8 px)
    np.testing.assert_array_equal(got[:, reach:], alone[:, reach:])
    assert np.abs(got[:, :5] - 0.5).max() < 1e-6      # the opaque front part covers its own pixels
