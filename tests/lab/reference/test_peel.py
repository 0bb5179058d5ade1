"""LES10's umbra depth peeling: the offset's geometry, and what each peeled layer holds.

Scene: a card at 0.5 m in front of a wall at 2 m, and a second card 5 cm behind the first (inside
the first card's umbra, x(0.5) = 10.6 cm for S = 2.85 px per dioptre), seen through a 50 mm f/0.5
lens focused at 2 m, 40 px wide. Layer 0 is the pinhole view; layer 1 holds the wall behind the
first card (not the second card: no lens ray can reach it); the wall's umbra (4.7 m) reaches past
everything, so there is no layer 2.
"""
import numpy as np
import pytest

from lab.reference.labelled import planar_depth
from lab.reference.peel import peel_layers, umbra_offset
from lab.reference.render import render_pinhole
from lab.scene import parse_scene

W, H = 40, 32


def test_umbra_offset_is_where_every_lens_ray_crosses_the_extended_pixel():
    """Brute force: a point on the centre ray of a surfel (2e pixels wide at depth d) is hidden from
    every point of the lens disc up to d + x, and seen from some just beyond."""
    rng = np.random.default_rng(0)
    a, f_px, e, d = 0.02, 1000.0, 1.0, 1.5         # lens radius m, image distance px, half-size px, depth m
    scale = a * f_px                                # S = 20 px per dioptre
    x = umbra_offset(d, scale, e)
    assert x == pytest.approx(e * d * d / (scale - e * d))
    half = e * d / f_px                             # the surfel's half-size in metres at depth d
    r, phi = a * np.sqrt(rng.random(20000)), 2 * np.pi * rng.random(20000)
    lens = np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)
    centre = np.array([0.3, -0.1]) * d              # an off-axis surfel: its centre ray passes (0.3, -0.1) at z = 1

    def blocked(z):                                 # every lens-to-point segment crosses the surfel at depth d
        p = centre / d * z
        at_d = lens + (p - lens) * d / z
        return np.all(np.abs(at_d - centre) <= half)

    assert blocked(d + 0.999 * x) and not blocked(d + 1.01 * x)
    assert umbra_offset(scale / e, scale, e) == np.inf and umbra_offset(30.0, scale, e) == np.inf
    np.testing.assert_allclose(umbra_offset(np.array([0.5, 1.5]), scale, e), [0.5 ** 2 / 19.5, x])


@pytest.fixture(scope="module")
def peeled():
    scene = parse_scene({
        "scene": {"name": "peel", "resolution": [W, H]},
        "camera": {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50,
                   "f_number": 0.5, "focus_distance_m": 2},
        "render": {"input_spp": 16, "max_depth": 2, "seed": 5, "peel_layers": 4},
        "materials": {"red": {"reflectance": [0.8, 0.1, 0.1]}, "green": {"reflectance": [0.1, 0.6, 0.2]},
                      "blue": {"reflectance": [0.1, 0.1, 0.8]}},
        "shapes": [{"type": "rectangle", "material": "red", "center": [0.0, 0.0, 0.5], "scale": [0.05, 0.05, 1],
                    "rotate": [0, 180, 0]},
                   {"type": "rectangle", "material": "blue", "center": [0.0, 0.0, 0.55], "scale": [0.05, 0.05, 1],
                    "rotate": [0, 180, 0]},
                   {"type": "rectangle", "material": "green", "center": [0, 0, 2], "scale": [5, 5, 1],
                    "rotate": [0, 180, 0]}],
        "emitters": [{"type": "constant", "radiance": [0.5, 0.5, 0.5]}],
    }, "peel.toml")
    channels, stats = peel_layers(scene, progress=False)
    return scene, channels, stats


def layer(channels, k):
    rgb = np.stack([channels[f"layer{k}.{c}"] for c in "RGB"], axis=-1)
    return rgb, channels[f"layer{k}.A"], channels[f"layer{k}.Z"]


def test_layer0_is_the_pinhole_view(peeled):
    scene, channels, stats = peeled
    rgb, alpha, z = layer(channels, 0)
    np.testing.assert_allclose(z, planar_depth(scene), rtol=1e-6)     # the same pixel-centre rays
    np.testing.assert_array_equal(alpha, 1.0)
    flat = render_pinhole(scene, 64, progress=False)                  # an independent pinhole estimate
    np.testing.assert_allclose(rgb.mean(axis=(0, 1)), flat.mean(axis=(0, 1)), rtol=0.03)
    card = z < 1.0
    assert (rgb[card][:, 0] > rgb[card][:, 2]).all()                   # the red card, not the blue one


def test_later_layers_lie_past_the_umbra_of_the_earlier(peeled):
    scene, channels, stats = peeled
    assert stats["layers"] == 2 and stats["truncated_pixels"] == 0
    (_, _, z0), (rgb1, a1, z1) = layer(channels, 0), layer(channels, 1)
    scale = scene.camera.thin_lens().coc_scale_px(W)
    both = np.isfinite(z1)
    assert both.any() and np.all(z1[both] >= z0[both] + umbra_offset(z0[both], scale))
    inner = (z0 < 1.0) & (np.abs(np.arange(W) - W / 2 + 0.5) < 5)[None, :] & \
            (np.abs(np.arange(H) - H / 2 + 0.5) < 5)[:, None]
    assert inner.sum() > 50
    np.testing.assert_allclose(z1[inner], 2.0, rtol=1e-4)             # the wall, not the blue card
    np.testing.assert_array_equal(a1[inner], 1.0)
    assert (rgb1[inner][:, 1] > rgb1[inner][:, 2]).all()
    assert np.all(a1[z0 > 1.0] == 0)                                   # nothing peeled behind the wall
    assert stats["occupancy"][0] == 1.0 and stats["occupancy"][1] == pytest.approx(np.mean(a1 > 0))


def test_coc_layers_are_spaced_uniformly_in_coc():
    """LES09 eq. 4: each layer spans delta pixels of CoC (plus 10 % overlap); the last reaches infinity."""
    from lab.reference.coc_layers import coc_bounds

    bounds = coc_bounds(0.5, 20.0, 2.0, 6)
    far, near = bounds[:, 0], bounds[:, 1]
    np.testing.assert_allclose(near[0], 2.0)
    np.testing.assert_allclose(20.0 * (near[:-1] - far[:-1]), 2.2)         # delta + 10 % overlap
    np.testing.assert_allclose(20.0 * (near[:-1] - near[1:]), 2.0)          # CoC step delta
    assert far[-1] == 0.0


def test_coc_layers_hold_the_first_surface_of_their_interval(peeled):
    from lab.reference.coc_layers import coc_bounds, coc_layers

    scene, _, _ = peeled
    scale = scene.camera.thin_lens().coc_scale_px(W)
    channels = coc_layers(scene, 4, 1.0, 0.45, spp=4)      # S = 2.85: 0.35 /m per layer from 2.22 /m
    bounds = coc_bounds(0.45, scale, 1.0, 4)
    z = [channels[f"layer{k}.Z"] for k in range(4)]
    for k, (far, near) in enumerate(bounds):                 # every depth within its layer's interval
        finite = np.isfinite(z[k])
        assert np.all(1 / z[k][finite] <= near + 1e-6) and np.all(1 / z[k][finite] >= far - 1e-6)
    card = np.isclose(z[0], 0.5, rtol=1e-4)
    assert card.sum() > 50                                   # layer 0 (2.22 .. 1.84 /m): the red card
    blue = np.isclose(z[1], 0.55, rtol=1e-4)                 # layer 1 (1.87 .. 1.49 /m): the blue card behind it
    assert blue.sum() > 40 and np.all(card[blue]) and np.all(np.isinf(z[1][~blue]))
    assert np.isinf(z[2]).all()                              # layer 2 (1.52 .. 1.14 /m): nothing
    assert np.all(np.isclose(z[3], 2.0, rtol=1e-4))          # the wall, in the last layer everywhere
