"""Global depth layers for polygonal splatting against a brute-force numpy composite.

The reference splats every pixel's rasterised polygon densely in float64, layer by layer, blurs
the nearer layers' coverage the same way for the re-weighting and composites with "over"; the
runtime must agree to float32 precision. The behaviour tests pin what layering is for: an
in-focus foreground is not bled over, a hole behind it is filled, a transparent layer and a
single layer change nothing.
"""
import numpy as np
import pytest
from polygon_reference import footprint, shape

from runtime_cl.errors import InputError
from runtime_cl.layers.composite import LayerPart, PixelLayer, layer_edges, render_layers
from runtime_cl.masks import on_box
from runtime_cl.polygon.layers import PolygonLayerSplatter
from runtime_cl.polygon.splat import PolygonSplatter


@pytest.fixture(scope="module")
def hexagon():
    return PolygonSplatter(*shape("hexagon"))


def dense(image, radius, splatter):
    """float64 brute-force splat: each pixel spreads its value over its rasterised polygon."""
    h, w = radius.shape
    out = np.zeros(image.shape, np.float64)
    for y, x in zip(*np.nonzero(np.any(image != 0, axis=2))):
        dy, dx = footprint(splatter.polygon(float(np.float32(radius[y, x]))))
        ty, tx = dy + y, dx + x
        ok = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
        np.add.at(out, (ty[ok], tx[ok]), image[y, x].astype(np.float64) / dy.size)
    return out


def reference(layers, n, splatter):
    """The module docstring's composite, written plainly in float64."""
    live = [(x.alpha > 0) | np.any(x.rgb != 0, axis=2) for x in layers]
    cocs = np.concatenate([x.coc[m] for x, m in zip(layers, live)])
    edges = np.linspace(cocs.min(), cocs.max(), n + 1)
    bins = []
    for x, m in zip(layers, live):
        b = np.minimum(((x.coc - edges[0]) // (edges[1] - edges[0])).astype(int), n - 1) if n > 1 \
            else np.zeros(x.coc.shape, int)
        bins.append(np.where(m, b, -1))
    h, w, c = layers[0].rgb.shape
    out, behind = np.zeros((h, w, c)), False
    for i in reversed(range(n)):
        layer, sites, radii = np.zeros((h, w, c + 1)), np.zeros((h, w)), []
        for x, b in zip(layers, bins):
            m = b == i
            if m.any():
                img = np.concatenate([x.rgb, x.alpha[..., None]], axis=2) * m[..., None]
                layer += dense(img, np.abs(x.coc), splatter)
                sites += x.alpha * m
                radii += [(a, r) for a, r in zip(x.alpha[m], np.abs(x.coc[m]))]
        if not radii:
            continue
        a, r = np.array(radii).T
        rho = (a * r).sum() / a.sum() if a.sum() > 0 else r.mean()
        colour, alpha = layer[..., :c], layer[..., c]
        nearer = np.minimum(sum(x.alpha * ((b >= 0) & (b < i)) for x, b in zip(layers, bins)), 1)
        known = 1 - dense(nearer[..., None], np.full((h, w), rho), splatter)[..., 0]
        g = 1 / np.clip(np.maximum(known, alpha), 0.1, 1)
        opacity = np.minimum(alpha * g, 1)
        if behind:
            own = dense(np.minimum(sites, 1)[..., None], np.full((h, w), rho), splatter)[..., 0]
            opacity = np.maximum(opacity, np.minimum(own / np.clip(known, 0.1, 1), 1))
        out = colour * g[..., None] + (1 - opacity)[..., None] * out
        behind = True
    return out


def depth_scene(rng, h=26, w=34):
    """Opaque pixels at four depths: background (CoC +5..+7), a blurred patch in the middle
    (+2..+3) partly hidden by a defocused near bar (-4..-3), an in-focus block."""
    coc = rng.uniform(5.0, 7.0, (h, w))
    coc[18:, 20:] = rng.uniform(2.0, 3.0, (h - 18, w - 20))
    coc[8:18, 10:22] = rng.uniform(-0.4, 0.4, (10, 12))       # in focus: one-pixel polygons
    coc[:, 26:30] = rng.uniform(-4.0, -3.0, (h, 4))            # defocused foreground bar
    rgb = rng.random((h, w, 3)) * np.where(coc > 4, 3.0, 1.0)[..., None]   # bright background
    return PixelLayer(rgb.astype(np.float32), np.ones((h, w), np.float32), coc.astype(np.float32))


@pytest.mark.parametrize("n", [2, 3, 5])
def test_single_image_matches_brute_force(hexagon, n):
    rng = np.random.default_rng(n)
    img = depth_scene(rng)
    got, info = render_layers(PolygonLayerSplatter(hexagon), img, n)
    want = reference([img], n, hexagon)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * want.max())
    assert len(info["layers"]) <= n and info["device_ms"] > 0
    assert info["edges"][0] == pytest.approx(img.coc.min()) and info["edges"][-1] == pytest.approx(img.coc.max())


def test_layered_input_matches_brute_force(hexagon):
    """A foreground layer with partial alpha over a complete background, plus an empty layer."""
    rng = np.random.default_rng(7)
    bg = depth_scene(rng)
    h, w = bg.alpha.shape
    alpha = np.zeros((h, w), np.float32)
    alpha[5:20, 3:12] = 1.0
    alpha[5:20, 12] = 0.4                                          # a partially covered edge
    fg = PixelLayer((rng.random((h, w, 3)) * alpha[..., None]).astype(np.float32), alpha,
                    np.full((h, w), -5.5, np.float32))
    empty = PixelLayer(np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.float32),
                       np.full((h, w), 50.0, np.float32))
    got, _ = render_layers(PolygonLayerSplatter(hexagon), [fg, bg, empty], 4)
    want = reference([fg, bg, empty], 4, hexagon)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * want.max())


def test_single_layer_is_todays_polygon_render(hexagon):
    img = depth_scene(np.random.default_rng(3))
    got, info = render_layers(PolygonLayerSplatter(hexagon), img, 1)
    today, _ = hexagon.render(img.rgb, np.abs(img.coc))
    np.testing.assert_allclose(got, today, rtol=1e-6, atol=1e-7)
    assert [x["coverage_gain"] for x in info["layers"]] == [1.0]


@pytest.mark.parametrize("where", ["corner", "middle", "empty"])
def test_a_layer_is_splatted_on_its_window_as_on_the_frame(hexagon, where):
    """A layer's canvas is the box of its pixels widened by its largest polygon's reach: the same
    values, to the last bit, as the whole frame's canvas (exact integer sums), and nothing
    outside it."""
    rng = np.random.default_rng(11)
    h, w = 70, 90
    rgba = np.zeros((h, w, 4), np.float32)
    coc = np.zeros((h, w), np.float32)
    box = {"corner": (slice(0, 9), slice(78, 90)), "middle": (slice(30, 38), slice(40, 52)), "empty": None}[where]
    part_box = box or (slice(10, 20), slice(5, 9))
    if box is not None:
        rgba[box] = rng.random(rgba[box].shape)
        coc[box] = rng.uniform(-9.0, 9.0, coc[box].shape)
    part = LayerPart(part_box, rgba[part_box], coc[part_box], 0)
    crop, window, _ = PolygonLayerSplatter(hexagon).splat_layer([part], (h, w))
    got = on_box(crop, window, (slice(0, h), slice(0, w)))
    want, _ = hexagon.render(rgba, np.abs(coc))
    assert np.array_equal(got, want)
    if box is not None:
        assert window != (slice(0, h), slice(0, w)) and np.abs(want).max() > 0


def test_in_focus_foreground_is_not_bled_over(hexagon):
    """Bright bokeh behind an in-focus block: one layer bleeds over it, layers leave it exact."""
    img = depth_scene(np.random.default_rng(5))
    block = (slice(8, 18), slice(10, 22))
    one, _ = render_layers(PolygonLayerSplatter(hexagon), img, 1)
    assert np.abs(one[block] - img.rgb[block]).max() > 0.1          # today's result: bleeding
    for n in (2, 4, 8):
        layered, _ = render_layers(PolygonLayerSplatter(hexagon), img, n)
        np.testing.assert_allclose(layered[block], img.rgb[block], rtol=1e-6, atol=1e-6)


def test_polygon_steps_do_not_let_the_background_through(hexagon):
    """Radii across MHU21's polygon steps (1 px, 5-px triangle, 17-px hexagon): the splats of the
    near surface do not sum to 1 everywhere, but its inside hides the background completely."""
    rng = np.random.default_rng(4)
    h, w = 30, 30
    coc = np.full((h, w), 8.0, np.float32)
    coc[6:24, 6:24] = rng.uniform(-1.6, 1.6, (18, 18))
    near = rng.random((h, w, 3)).astype(np.float32)
    inside = (slice(9, 21), slice(9, 21))
    results = []
    for glow in (0.0, 100.0):
        rgb = np.where((coc > 4)[..., None], np.float32(glow), near)
        out, _ = render_layers(PolygonLayerSplatter(hexagon), PixelLayer(rgb, np.ones((h, w), np.float32), coc), 3)
        results.append(out[inside])
    np.testing.assert_allclose(results[1], results[0], atol=1e-4)


def test_hole_behind_an_in_focus_object_is_filled():
    """A uniform background blurred behind a sharp square: no dark rim around the square."""
    sp = PolygonSplatter(*shape("octagon"))
    h, w = 40, 40
    coc = np.full((h, w), 6.0, np.float32)
    rgb = np.broadcast_to(np.float32([0.8, 0.5, 0.2]), (h, w, 3)).copy()
    coc[15:25, 15:25] = 0.0
    rgb[15:25, 15:25] = 0.1
    img = PixelLayer(rgb, np.ones((h, w), np.float32), coc)
    one, _ = render_layers(PolygonLayerSplatter(sp), img, 1)
    rim = np.zeros((h, w), bool)
    rim[10:30, 10:30] = True
    rim[15:25, 15:25] = False
    assert one[rim].min() < 0.8 * 0.8                                # today: darkened (and tinted)
    two, info = render_layers(PolygonLayerSplatter(sp), img, 2)
    np.testing.assert_allclose(two[rim], np.broadcast_to(rgb[0, 0], (rim.sum(), 3)), atol=1e-5)
    np.testing.assert_allclose(two[15:25, 15:25], rgb[15:25, 15:25], atol=1e-6)
    assert info["layers"][1]["coverage_gain"] > 1.01


def test_defocused_foreground_reveals_layered_background(hexagon):
    """A blurred opaque foreground over a background that is there: C_f + (1 - A_f) C_b exactly."""
    h, w = 30, 30
    alpha = np.zeros((h, w), np.float32)
    alpha[:, :12] = 1.0
    fg = PixelLayer(np.float32([0.0, 0.0, 1.0]) * alpha[..., None], alpha, np.full((h, w), -6.0, np.float32))
    bg = PixelLayer(np.full((h, w, 3), [1.0, 0.0, 0.0], np.float32), np.ones((h, w), np.float32),
                    np.full((h, w), 0.0, np.float32))
    got, _ = render_layers(PolygonLayerSplatter(hexagon), [fg, bg], 2)
    cover, _ = hexagon.render(alpha, 6.0)
    np.testing.assert_allclose(got[..., 2], cover, atol=1e-6)
    np.testing.assert_allclose(got[..., 0], 1.0 - cover, atol=1e-6)   # red shows where blue thins out
    assert 0.2 < got[15, 12, 0] < 0.8


def test_transparent_layer_changes_nothing(hexagon):
    img = depth_scene(np.random.default_rng(9))
    h, w = img.alpha.shape
    ghost = PixelLayer(np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.float32),
                       np.full((h, w), -80.0, np.float32))
    a, info_a = render_layers(PolygonLayerSplatter(hexagon), [img], 3)
    b, info_b = render_layers(PolygonLayerSplatter(hexagon), [ghost, img], 3)
    np.testing.assert_array_equal(a, b)
    assert info_a["edges"] == info_b["edges"]


def test_empty_layers_are_skipped(hexagon):
    h, w = 10, 12
    coc = np.zeros((h, w), np.float32)
    coc[:, 6:] = 9.0                                                  # two depths, many bins
    img = PixelLayer(np.ones((h, w, 3), np.float32), np.ones((h, w), np.float32), coc)
    _, info = render_layers(PolygonLayerSplatter(hexagon), img, 16)
    assert [x["index"] for x in info["layers"]] == [0, 15]
    assert layer_edges(img, 16).shape == (17,)


@pytest.mark.parametrize("layers,n,match", [
    ("ok", 0, r"n_layers = 0: .* >= 1"),
    ("ok", 2.5, r"n_layers = 2.5"),
    ([], 2, r"non-empty list"),
    ("shape", 2, r"layers\[1\].*same for every layer"),
    ("alpha", 2, r"layers\[0\].alpha: .*\[0, 1\]"),
    ("nan", 2, r"layers\[0\].coc: 4 non-finite"),
])
def test_bad_input_names_the_argument(hexagon, layers, n, match):
    ok = PixelLayer(np.zeros((4, 5, 3), np.float32), np.ones((4, 5), np.float32), np.zeros((4, 5), np.float32))
    cases = {"ok": [ok], "shape": [ok, PixelLayer(ok.rgb[:3], ok.alpha[:3], ok.coc[:3])],
             "alpha": [PixelLayer(ok.rgb, ok.alpha * 2, ok.coc)],
             "nan": [PixelLayer(ok.rgb, ok.alpha, np.where(np.arange(5) == 2, np.nan, ok.coc).astype(np.float32))]}
    with pytest.raises(InputError, match=match):
        render_layers(PolygonLayerSplatter(hexagon), cases.get(layers, layers) if isinstance(layers, str) else layers, n)


def test_soft_layers_of_one_coc_everywhere_are_the_hard_layers():
    """Every pixel at one CoC (an in-focus flat scene): there is no bin edge to soften, so soft
    layering gives the hard weights, not 0/0 (NaN) from the zero-width bin range."""
    from runtime_cl.layers.composite import _live, _weights, layer_edges

    layer = PixelLayer(np.ones((4, 5, 3), np.float32), np.ones((4, 5), np.float32), np.full((4, 5), 2.5))
    live, edges = _live(layer), layer_edges([layer], 3)
    soft = _weights(layer, edges, 0.5, live)
    assert np.all(np.isfinite(soft)) and np.array_equal(soft, _weights(layer, edges, 0.0, live))
