"""The layered lens-ray tracer (LES09/LES10): the kernel's hits against brute force, the pass's
images against thin-lens optics, and its bad input."""
import numpy as np
import pytest
from layered_reference import brute_force_hits, march_hits

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.layered.lens_samples import disc_samples
from runtime_cl.layered.nbuffer import minmax_nbuffer
from runtime_cl.layered.tracer import LayerStack, LayerTracer, layer_stack
from runtime_cl.passes import get_pass

# 50 mm f/1 focused at 1 m, 160 px wide: S = 5.85 px per dioptre; a plane at 5 m blurs to 4.7 px.
CAMERA = ThinLens(focal_length_mm=50.0, f_number=1.0, focus_distance_m=1.0)


def random_layers(rng, n_layers=3, h=24, w=32, empty=0.3):
    inv = rng.uniform(0.1, 2.0, (n_layers, h, w)).astype(np.float32)
    inv[rng.random(inv.shape) < empty] = -1.0
    inv[1 % n_layers, 5:15, 5:20] = -1.0        # a large empty region the N-buffer must skip
    inv[0, 0, 0] = 0.0                          # one pixel at infinity
    return LayerStack(inv, np.zeros(inv.shape + (4,), np.float32))


def random_rays(rng, n, h, w, spread=8.0):
    a = rng.uniform(-5, max(h, w) + 5, (n, 2))
    b = rng.normal(0.0, spread, (n, 2))
    b[:20, 0] = 0.0                             # axis-parallel rays and ...
    b[20:30] = 0.0                              # ... the pinhole ray (b = 0)
    return np.concatenate([a, b], axis=1)


@pytest.mark.parametrize("downsample, clamp_iters", [(4, 3), (1, 3), (2, 0), (8, 1)])
def test_kernel_hits_match_brute_force(downsample, clamp_iters):
    """Every ray's nearest surfel (layer, cell) is the one found by testing every cell of every
    layer in float64; the N-buffer clamping only skips what cannot be hit."""
    rng = np.random.default_rng(downsample * 10 + clamp_iters)
    stack = random_layers(rng)
    rays = random_rays(rng, 3000, 24, 32)
    thickness = 0.05
    got = LayerTracer((24, 32), 3, 4, downsample=downsample, clamp_iters=clamp_iters).trace(stack, rays, thickness)
    ref = brute_force_hits(stack.inv_depth, rays, thickness)
    same = (got[:, 1] == ref[:, 1]) & (got[:, 2] == ref[:, 2])
    assert 0.3 < (ref[:, 1] >= 0).mean() < 0.9            # a mix of hits and misses
    assert same.mean() >= 0.999, np.nonzero(~same)[0][:5]
    hit = same & (ref[:, 1] >= 0)
    np.testing.assert_allclose(got[hit, 0], ref[hit, 0], atol=1e-5)


def test_brute_force_agrees_with_a_ray_march():
    """The brute-force reference itself against a dense march along each ray (steps of 1e-4 in w)."""
    rng = np.random.default_rng(5)
    stack = random_layers(rng, n_layers=2, h=12, w=16)
    rays = random_rays(rng, 300, 12, 16, spread=4.0)
    exact = brute_force_hits(stack.inv_depth, rays, 0.05)
    marched = march_hits(stack.inv_depth, rays, 0.05)
    same = (exact[:, 1] == marched[:, 1]) & (exact[:, 2] == marched[:, 2])
    assert same.mean() >= 0.97
    hit = same & (exact[:, 1] >= 0)
    np.testing.assert_allclose(marched[hit, 0], exact[hit, 0], atol=2e-4)


def test_nbuffer_bounds_every_block_rectangle():
    rng = np.random.default_rng(2)
    inv = rng.uniform(0, 1, (1, 37, 50)).astype(np.float32)
    inv[rng.random(inv.shape) < 0.2] = -1.0
    nb = minmax_nbuffer(inv, 4)
    h4, w4 = nb.shape[2:4]
    for _ in range(200):
        y0, x0 = rng.integers(0, h4), rng.integers(0, w4)
        y1, x1 = rng.integers(y0, h4), rng.integers(x0, w4)
        block = inv[0, 4 * y0:4 * y1 + 4, 4 * x0:4 * x1 + 4]
        level = int(max(x1 - x0, y1 - y0) + 1).bit_length() - 1
        size, lv = 1 << level, nb[0, level]
        corners = [lv[y, x] for y in (y0, max(y1 - size + 1, 0)) for x in (x0, max(x1 - size + 1, 0))]
        lo, hi = min(c[0] for c in corners), max(c[1] for c in corners)
        valid = block[block >= 0]
        if valid.size:
            assert lo <= valid.min() and hi >= valid.max()
        if x1 - x0 == y1 - y0 and valid.size:                  # a square query is exact
            assert lo == valid.min() and hi == valid.max()


@pytest.mark.parametrize("shape, ds", [((3, 37, 50), 4), ((2, 64, 64), 4), ((1, 9, 131), 2), ((2, 5, 3), 8)])
def test_device_nbuffer_is_the_numpy_nbuffer(shape, ds):
    """The N-buffer built on the device (kernels/layered/nbuffer.cl) equals the numpy one bit for
    bit (min/max of the same floats), empty blocks and a wholly empty layer included, and the
    per-layer range is its top square."""
    rng = np.random.default_rng(sum(shape) + ds)
    inv = rng.uniform(0, 2, shape).astype(np.float32)
    inv[rng.random(shape) < 0.3] = -1.0
    inv[-1, : shape[1] // 2] = -1.0
    if shape[0] > 1:
        inv[1] = -1.0                                          # an empty layer
    tracer = LayerTracer(shape[1:], shape[0], 2, downsample=ds)
    tracer._upload(LayerStack(inv, np.zeros(shape + (4,), np.float32)))
    ref = minmax_nbuffer(inv, ds)
    got = np.empty_like(ref)
    rng_got = np.empty((shape[0], 2), np.float32)
    import pyopencl as cl

    cl.enqueue_copy(tracer.device.queue, got, tracer.buf["nbuf"], wait_for=tracer.nbuffer_events)
    cl.enqueue_copy(tracer.device.queue, rng_got, tracer.buf["range"], wait_for=tracer.nbuffer_events)
    np.testing.assert_array_equal(got, ref)
    np.testing.assert_array_equal(rng_got, ref[:, -1, 0, 0, :])


def test_lens_samples_cover_the_unit_disc_evenly():
    s = disc_samples(512)
    r = np.hypot(s[:, 0], s[:, 1])
    assert r.max() <= 1.0 + 1e-6
    assert abs(r.mean() - 2 / 3) < 0.01 and np.abs(s.mean(axis=0)).max() < 0.01
    assert abs(np.mean(r < np.sqrt(0.5)) - 0.5) < 0.01        # half the area inside radius 1/sqrt(2)


@pytest.mark.parametrize("cone", [False, True])
def test_in_focus_layer_renders_unchanged(cone):
    rng = np.random.default_rng(0)
    rgb = rng.random((30, 40, 3)).astype(np.float32)
    depth = np.full((30, 40), CAMERA.focus_distance_m)
    image, timing = runtime_cl.render(rgb, depth, CAMERA, method="layered", rays=16, cone=cone)
    np.testing.assert_allclose(image, rgb, rtol=1e-6)
    assert timing.counts["rays_hit"] == 30 * 40 * 16


@pytest.mark.parametrize("cone", [False, True])
def test_defocused_point_spreads_into_the_coc_disc(cone):
    """256 rays, or 64 cones (LES09 4.4: each cone reads the mipmap over the window between rays)."""
    h, w = 90, 160
    depth = np.full((h, w), 5.0)
    rgb = np.zeros((h, w, 3), np.float32)
    rgb[45, 80] = 100.0
    image, _ = runtime_cl.render(rgb, depth, CAMERA, method="layered", rays=64 if cone else 256, cone=cone)
    radius = abs(CAMERA.coc_radius_px(5.0, w))
    assert 4.5 < radius < 5.0
    ys, xs = np.nonzero(image[..., 0] > 0)
    dist = np.hypot(xs - 80, ys - 45)
    assert radius - 0.5 < dist.max() <= radius + np.sqrt(0.5) + 1e-3   # a cell reaches half a diagonal
    assert abs(image[..., 0].sum() / 100.0 - 1.0) < 0.03                # energy kept (3 %: jitter)
    inner = dist < radius - 1.5
    assert np.all(image[ys[inner], xs[inner], 0] > 0.3 * 100.0 / (np.pi * radius ** 2))  # a filled disc


def occluder_scene(h=40, w=160):
    """A near bar (0.4 m, 8 px wide) in front of a blue wall (10 m) that is red where the bar hides it.

    Focus at 1 m: the bar blurs over |C(0.4 m)| = 8.8 px, the wall over 5.3 px.
    """
    bar = np.zeros((h, w), bool)
    bar[:, 76:84] = True
    wall = np.zeros((h, w, 3), np.float32)
    wall[..., 2] = 1.0
    wall[bar] = (1.0, 0.0, 0.0)
    flat_rgb = np.where(bar[..., None], np.float32(0.2), wall)
    flat_z = np.where(bar, 0.4, 10.0)
    layer1 = Frame(np.where(bar[..., None], wall, 0.0), np.where(bar, 10.0, np.inf), alpha=bar.astype(np.float32))
    return flat_rgb, flat_z, (Frame(flat_rgb, flat_z), layer1)


def test_foreground_occluder_reveals_what_the_pinhole_hides():
    rgb, z, layers = occluder_scene()
    flat, _ = runtime_cl.render(rgb, z, CAMERA, method="layered", rays=64)
    peeled, t = runtime_cl.render(rgb, z, CAMERA, method="layered", rays=64, layered_input=True,
                                  input_layers=layers)
    # Behind the bar's centre, the rays with |xi_x| > (4 + 1) / 8.8 (one pixel of slab) pass beside
    # the bar, a third of the lens, and reach the wall 3..5 px from the centre: hidden, red.
    red_flat, red = flat[..., 0] - flat[..., 1], peeled[..., 0] - peeled[..., 1]   # grey bar: R = G
    assert np.abs(red_flat).max() < 1e-6                   # the flat image has no red at all
    assert 0.2 < red[:, 78:82].mean() < 0.4
    assert np.abs(red[:, :60]).max() < 1e-6 and np.abs(red[:, 100:]).max() < 1e-6   # only behind the bar
    assert t.counts["input_layers"] == 2 and t.counts["rays_missed"] == 0


def test_bad_input_is_refused_in_one_line():
    rgb, z, layers = occluder_scene()
    with pytest.raises(InputError, match="rays = 0"):
        runtime_cl.render(rgb, z, CAMERA, method="layered", rays=0)
    small = Frame(rgb[:30], z[:30])
    with pytest.raises(InputError, match="sizes"):
        runtime_cl.render(rgb, z, CAMERA, method="layered", layered_input=True, input_layers=(layers[0], small))
    with pytest.raises(InputError, match="sizes"):
        layer_stack([(rgb, np.ones(z.shape), z), (rgb[:30], np.ones((30, 160)), z[:30])])
    with pytest.raises(InputError, match="no layerN"):
        runtime_cl.render(rgb, z, CAMERA, method="layered", layered_input=True)
    assert get_pass("layered").layered and get_pass("layered").database_models == ()


def test_clamping_changes_no_hit():
    """LES10's min/max clamping (per pixel over the CoC, then per ray) only skips what no ray can
    hit: the image equals the unclamped walk's bit for bit (cell entries are computed from the cell
    edges, so a walk's start does not round them differently)."""
    rng = np.random.default_rng(4)
    h, w = 48, 64
    depth = np.where(rng.random((h, w)) < 0.5, 0.3, 1.0) * rng.uniform(1.0, 3.0, (h, w))
    layers = [Frame(rng.random((h, w, 3)), depth),
              Frame(rng.random((h, w, 3)), depth * 3.0, alpha=(rng.random((h, w)) < 0.6).astype(np.float32))]
    images = [runtime_cl.render(layers[0].rgb, depth, CAMERA, method="layered", rays=16, layered_input=True,
                                input_layers=layers, pixel_iters=p, clamp_iters=c)[0]
              for p, c in ((0, 0), (3, 0), (3, 3), (1, 2))]
    for image in images[1:]:
        np.testing.assert_array_equal(image, images[0])


def test_false_position_finds_the_exact_hits_on_a_smooth_layer():
    """LES09's false-position search (3 steps, then halvings) on a smooth height field: the same
    rays hit, within a pixel of the exact walk's cell (it interpolates between the samples)."""
    rng = np.random.default_rng(0)
    h, w = 48, 64
    yy, xx = np.mgrid[0:h, 0:w]
    inv = (0.5 + 0.01 * xx + 0.2 * np.sin(xx / 9.0) * np.cos(yy / 7.0)).astype(np.float32)[None]
    stack = LayerStack(inv, np.zeros(inv.shape + (4,), np.float32))
    pixel = rng.uniform(8, 40, (4000, 2)) * [56 / 40, 1]
    b = rng.normal(0, 0.5, (4000, 2)) * 20.0                  # S = 20 px per dioptre, focus 1 m
    rays = np.concatenate([pixel - b, b], axis=1)
    exact = LayerTracer((h, w), 1, 1).trace(stack, rays, 1 / 20.0)
    fp = LayerTracer((h, w), 1, 1, false_position=3).trace(stack, rays, 1 / 20.0)
    np.testing.assert_array_equal(fp[:, 1] >= 0, exact[:, 1] >= 0)
    hit = exact[:, 1] >= 0
    assert hit.mean() > 0.99
    dx = np.abs(exact[hit, 2] % w - fp[hit, 2] % w)
    dy = np.abs(exact[hit, 2] // w - fp[hit, 2] // w)
    assert np.mean(np.maximum(dx, dy) <= 1) > 0.99
