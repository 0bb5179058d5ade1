"""Depth layers for the spreadlet passes against a plain numpy composite (LSR18 section 6.2).

The reference bins the pixels in signed CoC (soft layering: linear shares across each edge),
splats every layer's radiance and opacity with the database's dense PSFs by a float64 scatter
(``cl_reference.splat_image``; the synthetic disc database's spreadlets integrate exactly to
them), blurs the nearer coverage with the brute-force rasterised 16-gon and composites back to
front with the re-weighting of :mod:`runtime_cl.layers.composite`, written out plainly.
"""
import numpy as np
import pytest
from cl_reference import filter_image, splat_image
from polygon_reference import footprint

from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.coords.maps import psf_coords
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.layers.composite import LayerPart, PixelLayer, render_layers
from runtime_cl.masks import on_box
from runtime_cl.passes import get_pass
from runtime_cl.passes.polygon import builtin_splatter
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.spreadlets.layers import BLUR_SHAPE, SpreadletLayerSplatter
from runtime_cl.spreadlets.renderer import Renderer

R_MAX = 5.0


@pytest.fixture(scope="module")
def renderer():
    return Renderer(disc_database(R_MAX, samples=12))


def blur(image, radius):
    """float64 uniform blur by the rasterised 16-gon at ``radius`` (the runtime's blur shape)."""
    polygon = builtin_splatter(BLUR_SHAPE).polygon(float(np.float32(radius)))
    dy, dx = footprint(polygon)
    h, w = image.shape
    out = np.zeros((h, w))
    for y, x in zip(*np.nonzero(image)):
        ty, tx = dy + y, dx + x
        ok = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
        np.add.at(out, (ty[ok], tx[ok]), image[y, x] / dy.size)
    return out


def shares(coc, live, edges, soft):
    """(n, H, W) share of each pixel in each layer, as the composite's docstring defines them."""
    n = len(edges) - 1
    t = (coc - edges[0]) / (edges[1] - edges[0]) if n > 1 else np.zeros(coc.shape)
    out = np.zeros((n,) + coc.shape)
    for i in range(n):
        if soft == 0 or n == 1:
            b = np.minimum(np.floor(t), n - 1).astype(int)
            out[i] = b == i
        else:
            lo = 1.0 if i == 0 else np.clip((t - i) / soft + 0.5, 0, 1)
            hi = 0.0 if i == n - 1 else np.clip((t - i - 1) / soft + 0.5, 0, 1)
            out[i] = lo - hi
    return out * live


def hidden_within(layers, w8):
    """The shares after the nearer input pixels of the same layer hid them, pixel by pixel: front
    to back by signed CoC (ties: input order), each scaled by what the ones before let through."""
    out = [s.copy() for s in w8]
    n, h, w = w8[0].shape
    for i in range(n):
        for y in range(h):
            for x in range(w):
                through = 1.0
                for k in sorted(range(len(layers)), key=lambda k: (layers[k].coc[y, x], k)):
                    out[k][i, y, x] = w8[k][i, y, x] * through
                    through *= 1.0 - layers[k].alpha[y, x] * w8[k][i, y, x]
    return out


def reference(layers, n, spread, soft=0.0):
    """The composite of :mod:`runtime_cl.layers.composite`, float64; ``spread(image, source)``
    splats an (H, W, C) image of input layer ``source``."""
    live = [(x.alpha > 0) | np.any(x.rgb != 0, axis=2) for x in layers]
    cocs = np.concatenate([x.coc[m] for x, m in zip(layers, live)]).astype(np.float64)
    edges = np.linspace(cocs.min(), cocs.max(), n + 1)
    w8 = hidden_within(layers, [shares(x.coc.astype(np.float64), m, edges, soft) for x, m in zip(layers, live)])
    h, w, c = layers[0].rgb.shape
    out, behind = np.zeros((h, w, c)), False
    for i in reversed(range(n)):
        colour, alpha, sites, num, den = np.zeros((h, w, c)), np.zeros((h, w)), np.zeros((h, w)), 0.0, 0.0
        if not any(s[i].any() for s in w8):
            continue
        for k, (x, s) in enumerate(zip(layers, w8)):
            if s[i].any():
                colour += spread(x.rgb * s[i][..., None], k)
                alpha += spread((x.alpha * s[i])[..., None], k)[..., 0]
                sites += x.alpha * s[i]
                num, den = num + (x.alpha * s[i] * np.abs(x.coc)).sum(), den + (x.alpha * s[i]).sum()
        rho = num / den
        nearer = np.minimum(sum(x.alpha * s[:i].sum(axis=0) for x, s in zip(layers, w8)), 1)
        known = 1 - blur(nearer, rho)
        g = 1 / np.clip(np.maximum(known, alpha), 0.1, 1)
        opacity = np.minimum(alpha * g, 1)
        if behind:
            own = blur(np.minimum(sites, 1), rho)
            opacity = np.maximum(opacity, np.minimum(own / np.clip(known, 0.1, 1), 1))
        out = colour * g[..., None] + (1 - opacity)[..., None] * out
        behind = True
    return out


def random_layers(rng, h=22, w=26, fg_coc=(-4.0, -1.0)):
    """A background (CoC +2..+5, bright) and a foreground layer with random coverage patches
    (CoC ``fg_coc``), colours premultiplied; opaque everywhere together."""
    coc_bg = rng.uniform(2.0, 5.0, (h, w)).astype(np.float32)
    bg = PixelLayer((rng.random((h, w, 3)) * 3).astype(np.float32), np.ones((h, w), np.float32), coc_bg)
    alpha = np.zeros((h, w), np.float32)
    alpha[4:14, 5:15] = rng.uniform(0.3, 1.0, (10, 10))
    alpha[16:20, 2:22] = 1.0
    coc_fg = np.where(alpha > 0, rng.uniform(*fg_coc, (h, w)), 0.0).astype(np.float32)
    fg = PixelLayer((rng.random((h, w, 3)) * alpha[..., None]).astype(np.float32), alpha, coc_fg)
    return [fg, bg]


def coords_of(layers):
    return [(np.abs(x.coc)[..., None].astype(np.float32), None) for x in layers]


@pytest.mark.parametrize("method, n, soft, fg_coc", [
    ("spreadlets", 2, 0.0, (-4.0, -1.0)), ("spreadlets", 4, 0.5, (-4.0, -1.0)), ("splat", 3, 1.0, (-4.0, -1.0)),
    ("filter", 3, 0.0, (-4.0, -1.0)),
    ("spreadlets", 2, 0.0, (1.0, 4.0)), ("splat", 1, 0.0, (1.0, 4.0)), ("spreadlets", 3, 0.5, (1.0, 4.0))])
def test_layered_input_matches_numpy(renderer, method, n, soft, fg_coc):
    # fg_coc (1, 4): the foreground shares layers with the background (and is sometimes behind it)
    layers = random_layers(np.random.default_rng(n), fg_coc=fg_coc)
    db = renderer.db
    one = {"spreadlets": splat_image, "splat": splat_image, "filter": filter_image}[method]

    def spread(image, source):
        coords = np.abs(layers[source].coc)[..., None]
        out = one(db, image.astype(np.float32), coords)
        return out if out.shape[2] == image.shape[2] else out[..., :1]

    cropping = Renderer(db, crop_integration=True)            # as the passes render layers
    got, info = render_layers(SpreadletLayerSplatter(cropping, method, coords_of(layers)), layers, n, soft=soft)
    want = reference(layers, n, spread, soft)
    # float32 splats and integration (spreadlets: an FFT Poisson solve) against float64
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * want.max())
    assert len(info["layers"]) >= min(n, 2) and info["device_ms"] > 0


def test_an_opaque_input_pixel_hides_the_one_behind_it_in_its_layer(renderer):
    # LES10's peeled layers: layer 1 holds what lies behind layer 0. In one depth layer the
    # pinhole view shows only the nearer, so the pair must render as the near image alone.
    rng = np.random.default_rng(5)
    h, w = 20, 24
    near = PixelLayer((rng.random((h, w, 3)) + 0.5).astype(np.float32), np.ones((h, w), np.float32),
                      rng.uniform(2.0, 3.0, (h, w)).astype(np.float32))
    far = PixelLayer((rng.random((h, w, 3)) * 4).astype(np.float32), np.ones((h, w), np.float32),
                     near.coc + 0.5)
    splatter = SpreadletLayerSplatter(Renderer(renderer.db, crop_integration=True), "splat",
                                      coords_of([near, far]))
    both, _ = render_layers(splatter, [near, far], 1)
    alone, _ = render_layers(SpreadletLayerSplatter(Renderer(renderer.db, crop_integration=True), "splat",
                                                    coords_of([near])), [near], 1)
    np.testing.assert_array_equal(both, alone)   # the far pixels' shares are exactly 0


def test_one_layer_is_todays_render_bit_for_bit(renderer):
    """layers = 1: the pass's plain render, and render_layers through the splatter, both equal
    the Renderer's image exactly."""
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=1.0)
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.8, 1.3, (24, 30)).astype(np.float32)
    frame = Frame(rng.random((24, 30, 3)).astype(np.float32), depth)
    coords = psf_coords(camera, depth, renderer.db)
    assert coords.coords.max() <= R_MAX
    for method in ("spreadlets", "splat", "filter"):
        today, _ = renderer.render(frame.rgb, coords.coords, method)
        p = get_pass(method)(camera, renderer.db, layers=1)
        got, times = p(p.prepare(frame))
        assert np.array_equal(got, today) and "depth_layers" not in times.counts
        coc = camera.coc_radius_px(depth, 30).astype(np.float32)
        layered, _ = render_layers(SpreadletLayerSplatter(renderer, method, [(coords.coords, None)]),
                                   PixelLayer(frame.rgb, frame.coverage(), coc), 1)
        assert np.array_equal(layered, today)


def test_pass_layers_hide_the_background_behind_a_sharp_foreground(renderer):
    """A sharp dark block in front of a blurred bright background: one layer bleeds the
    background over it, layers leave it as it is (the single-view input, re-weighted)."""
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=1.0, sensor_width_mm=3.6)
    h, w = 30, 30
    depth = np.full((h, w), 2.0, np.float32)
    assert 3.5 < camera.coc_radius_px(depth, w).min() < R_MAX   # wider than the block's margin
    depth[10:20, 10:20] = 1.0                                  # in focus
    rgb = np.full((h, w, 3), 5.0, np.float32)
    rgb[10:20, 10:20] = 0.2
    frame = Frame(rgb, depth)
    block = (slice(12, 18), slice(12, 18))
    p1 = get_pass("spreadlets")(camera, renderer.db)
    one, _ = p1(p1.prepare(frame))
    assert one[block].max() > 0.5                               # bleeding today
    p2 = get_pass("spreadlets")(camera, renderer.db, layers=2, soft_layers=0.25)
    two, t = p2(p2.prepare(frame))
    np.testing.assert_allclose(two[block], 0.2, atol=1e-4)
    assert t.counts["used_layers"] == 2 and t.counts["spreadlets"] > 0


def test_bad_layer_options(renderer):
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=1.0)
    with pytest.raises(InputError, match=r"soft = 2.*\[0, 1\]"):
        get_pass("spreadlets")(camera, renderer.db, layers=2, soft_layers=2)
    with pytest.raises(InputError, match="layers = 0"):
        get_pass("splat")(camera, renderer.db, layers=0)
    depth = np.ones((8, 9), np.float32)
    small = Frame(np.zeros((8, 8, 3), np.float32), np.ones((8, 8), np.float32))
    frame = Frame(np.zeros((8, 9, 3), np.float32), depth, layers=[small])
    p = get_pass("filter")(camera, renderer.db, layers=2, layered_input=True)
    with pytest.raises(InputError, match=r"layer0: 8x8 pixels, the image is 8x9"):
        p.prepare(frame)


@pytest.mark.parametrize("db_channels", [1, 3])
@pytest.mark.parametrize("rotate", [False, True])
def test_four_channels_are_radiance_and_opacity(db_channels, rotate):
    """A 4-channel image is its RGB as rendered alone plus its 4th channel drawn with the PSF of
    a 1-channel database or the green one of a 3-channel database, for every method (the kernels'
    float4 lane 3; rotated PSFs included)."""
    from cl_reference import random_database

    r = Renderer(random_database(np.random.default_rng(db_channels), channels=db_channels, fast=0.3))
    rng = np.random.default_rng(5)
    rgba = rng.random((14, 17, 4)).astype(np.float32)
    rgba[3:6, 4:9] = 0.0                                       # empty pixels splat nothing
    coords = (rng.random((14, 17, 1)) * 6).astype(np.float32)
    angle = rng.uniform(-np.pi, np.pi, (14, 17)).astype(np.float32) if rotate else None
    for method in ("spreadlets", "splat", "filter"):
        got, _ = r.render(rgba, coords, method, angle=angle)
        rgb, _ = r.render(np.ascontiguousarray(rgba[..., :3]), coords, method, angle=angle)
        alpha, _ = r.render(np.ascontiguousarray(rgba[..., 3:]), coords, method, angle=angle)
        assert got.shape == (14, 17, 4)
        # same terms per lane; float32 sums in another grouping (vector widths) differ by rounding
        np.testing.assert_allclose(got[..., :3], rgb, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(got[..., 3], alpha[..., 1 if db_channels == 3 else 0], rtol=1e-5, atol=1e-6)


def test_guard_band_is_rendered_and_cropped(renderer):
    """run_pass renders the whole guarded frame and returns the frame: the crop of the same render."""
    from runtime_cl.passes import run_pass

    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=1.0, sensor_width_mm=3.6)
    rng = np.random.default_rng(8)
    rgb, depth = rng.random((20, 26, 3)).astype(np.float32), rng.uniform(1.0, 2.0, (20, 26)).astype(np.float32)
    whole, _ = run_pass("spreadlets", Frame(rgb, depth), camera, renderer.db, layers=2)
    framed, _ = run_pass("spreadlets", Frame(rgb, depth, guard_px=4), camera, renderer.db, layers=2)
    assert framed.shape == (12, 18, 3)
    np.testing.assert_array_equal(framed, whole[4:16, 4:22])
    for bad in (-1, 10, True, 2.0):
        with pytest.raises(InputError, match="guard_px"):
            Frame(rgb, depth, guard_px=bad)


def test_integration_on_the_splats_support_is_the_full_solve():
    """A Laplacian canvas whose image lives in a corner: solved on its support rectangle, the same
    image as the full canvas's solve to float32 rounding; a frame-filling one keeps its canvas."""
    from runtime_cl.integrate import get_integrator
    from runtime_cl.integrate.crop import integrate_support
    from runtime_cl.integrate.poisson import laplacian5

    exact = get_integrator("exact")(None)
    rng = np.random.default_rng(4)
    image = np.zeros((90, 120, 4))
    image[10:30, 60:95] = rng.random((20, 35, 4))               # zero on a ring around it
    lap = laplacian5(image).astype(np.float32)
    full, _ = exact(lap)
    cropped, _ = integrate_support(exact, lap)
    np.testing.assert_allclose(cropped, image, rtol=0, atol=1e-5)   # float32 Laplacian, float64 solve
    np.testing.assert_allclose(cropped, full, rtol=0, atol=1e-5)
    image[2:88, 2:118] = rng.random((86, 116, 4))
    lap = laplacian5(image).astype(np.float32)
    assert np.array_equal(integrate_support(exact, lap)[0], exact(lap)[0])


@pytest.mark.parametrize("method", ["spreadlets", "splat", "filter"])
@pytest.mark.parametrize("where", ["corner", "middle", "empty"])
def test_a_layer_renders_on_its_window_as_on_the_frame(method, where):
    """The layer splatter renders a layer on the box of its pixels widened by the PSFs' reach
    (turned PSFs included), not the whole frame: the same image as the renderer's full-frame
    render of it, up to float32 rounding (tiles grouped otherwise), and nothing for an empty layer."""
    from cl_reference import random_database

    rng = np.random.default_rng(9)
    r = Renderer(random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40)))
    h, w = 60, 70
    rgba = np.zeros((h, w, 4), np.float32)
    box = {"corner": (slice(0, 9), slice(60, 70)), "middle": (slice(25, 33), slice(30, 41)), "empty": None}[where]
    if box is not None:
        rgba[box] = rng.random(rgba[box].shape)
    coords = (rng.random((h, w, 1)) * 6).astype(np.float32)
    angle = rng.uniform(-np.pi, np.pi, (h, w)).astype(np.float32)
    splatter = SpreadletLayerSplatter(r, method, [(coords, angle)])
    part_box = box or (slice(10, 20), slice(5, 9))   # empty: a part whose pixels are all zero
    crop, drawn, _ = splatter.splat_layer([LayerPart(part_box, rgba[part_box], np.zeros(rgba[part_box].shape[:2],
                                                                                         np.float32), 0)], (h, w))
    got = on_box(crop, drawn, (slice(0, h), slice(0, w)))
    want, _ = r.render(rgba, coords, method, angle=angle)
    assert got.shape == want.shape == (h, w, 4)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-6 * max(float(np.abs(want).max()), 1.0))
    if box is not None:
        assert np.abs(want[0, :50]).max() == 0 if where == "corner" else np.abs(want).max() > 0
