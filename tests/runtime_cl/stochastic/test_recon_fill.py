"""The normalised reconstruction's push-pull fill and the bilinear sample footprint."""
from __future__ import annotations

import numpy as np
import pytest

from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.passes import run_pass
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.stochastic import concentric_disc, recentre
from runtime_cl.stochastic.fill import _down, _up, normalise

CAMERA = ThinLens(85.0, 0.5, 2.0)


def _depth_for(coc_px: float, size: int) -> float:
    return 1.0 / (1.0 / CAMERA.focus_distance_m - coc_px / CAMERA.coc_scale_px(size))


def test_fill_keeps_a_flat_colour_flat_through_holes():
    """Samples of one colour at random density with holes of every size (up to 16 x 16): the
    filled ratio is that colour everywhere, the plain clamp darkens every hole."""
    rng = np.random.default_rng(0)
    d = rng.random((64, 48, 1)) * (rng.random((64, 48, 1)) > 0.3)
    d[10:26, 5:21] = 0.0
    c = 0.7 * d * np.array([1.0, 0.5, 0.25])
    out = normalise(c, d, 0.5)
    np.testing.assert_allclose(out, np.broadcast_to([0.7, 0.35, 0.175], out.shape), rtol=1e-6)   # float32 output
    assert (c / np.maximum(d, 0.5))[15, 10, 0] == 0.0


def test_fill_leaves_dense_pixels_alone_and_interpolates_holes():
    """Where the density reaches m the output is exactly C / D; a one-pixel hole in a linear ramp
    is filled with a value between its neighbours (bilinear pull of 2 x 2 means)."""
    ys, xs = np.mgrid[0:32, 0:32].astype(np.float64)
    ramp = (xs / 31.0)[..., None]
    d = np.ones((32, 32, 1))
    d[16, 16] = 0.0
    out = normalise(ramp * d, d, 1.0)
    mask = d[..., 0] > 0
    np.testing.assert_array_equal(out[mask], ramp[mask].astype(np.float32))
    assert ramp[16, 15, 0] - 0.05 < out[16, 16, 0] < ramp[16, 17, 0] + 0.05   # 2 x 2 means are +-1.5 px of ramp


def test_down_up_shapes_and_constants():
    a = np.ones((7, 5, 2))
    assert _down(a).shape == (4, 3, 2) and _down(a)[0, 0, 0] == 4.0
    np.testing.assert_allclose(_up(np.full((4, 3), 2.5), (7, 5)), 2.5)   # partition of unity


@pytest.mark.parametrize("footprint", ["nearest", "bilinear"])
@pytest.mark.parametrize("normalize", [False, True])
def test_in_focus_textured_plane_reconstructs_exactly(footprint, normalize):
    """A plane in the focus plane seen at 1 spp with converged shading: every sample returns to
    its own pixel (y' = y), so the reconstruction is the input, whatever the lens samples."""
    size = 48
    rng = np.random.default_rng(1)
    texture = rng.random((size, size, 3)).astype(np.float32)
    frame = Frame(texture, np.full((size, size), CAMERA.focus_distance_m, np.float32),
                  samples=rng.random((size, size, 3)).astype(np.float32))
    out, _ = run_pass("stochastic_splat", frame, CAMERA, disc_database(r_max=6.0, samples=64),
                      normalize=normalize, footprint=footprint)
    np.testing.assert_allclose(out, texture, atol=1e-5)    # float32 splat sums of one delta per pixel


def test_bilinear_footprint_keeps_sub_pixel_positions_and_energy():
    """One sample re-centred to (15.25, 17.75) in pixel coordinates (centres at i + 0.5): its
    light goes to the four pixels around it by the tent weights, all of it."""
    size = 32
    coc = 3.0
    z = _depth_for(coc, size)
    depth = np.full((size, size), z, np.float32)
    rgb = np.zeros((size, size, 1), np.float32)
    rgb[16, 16] = 1.0
    # pick the lens sample whose re-centring y' = y - c d lands at the wanted point
    want = np.array([15.25, 17.75])
    d = (np.array([16.5, 16.5]) - want) / coc
    from runtime_cl.stochastic import inverse_concentric

    u, v = inverse_concentric(np.array([d[0]]), np.array([d[1]]))
    samples = np.full((size, size, 3), 0.5, np.float32)
    samples[16, 16] = [u[0], v[0], 0.5]
    dx, dy = concentric_disc(samples[16, 16, 0], samples[16, 16, 1])
    got = np.array([16.5 - coc * dx, 16.5 - coc * dy])
    np.testing.assert_allclose(got, want, atol=1e-5)        # float32 lens sample round-off
    rec = recentre(Frame(rgb, depth, samples=samples), samples, CAMERA, footprint="bilinear")
    total = sum(f.rgb[..., 0] for f in rec.frames)
    assert total.sum() == pytest.approx(1.0, abs=1e-6)
    fx, fy = got - 0.5                                      # continuous pixel index
    x0, y0 = int(np.floor(fx)), int(np.floor(fy))
    wx, wy = fx - x0, fy - y0
    expected = {(y0, x0): (1 - wx) * (1 - wy), (y0, x0 + 1): wx * (1 - wy),
                (y0 + 1, x0): (1 - wx) * wy, (y0 + 1, x0 + 1): wx * wy}
    for (y, x), wgt in expected.items():
        assert total[y, x] == pytest.approx(wgt, abs=1e-5)
    with pytest.raises(InputError, match="footprint = 'box'"):
        recentre(Frame(rgb, depth, samples=samples), samples, CAMERA, footprint="box")


@pytest.mark.parametrize("footprint", ["nearest", "bilinear"])
def test_normalised_defocused_plane_with_holes_is_flat(footprint):
    """A constant plane at a 0.7-px CoC: its PSFs are about one pixel, so with nearest-pixel
    deposits some pixels receive no sample and dividing by a clamped density leaves them dark;
    the push-pull fill (and the bilinear footprint) keep the plane flat."""
    size = 64
    rng = np.random.default_rng(4)
    samples = rng.random((size, size, 3)).astype(np.float32)
    frame = Frame(np.full((size, size, 3), 0.5, np.float32), np.full((size, size), _depth_for(0.7, size), np.float32),
                  samples=samples)
    db = disc_database(r_max=6.0, samples=64)
    inner = (slice(6, -6), slice(6, -6))
    filled, _ = run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, footprint=footprint)
    np.testing.assert_allclose(filled[inner], 0.5, rtol=1e-3)    # float32 splat sums and the Laplacian round-off
    clamped, _ = run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, footprint=footprint, fill=False)
    if footprint == "nearest":
        assert clamped[inner].min() < 0.4       # a hole: density below min_density = 0.25
    with pytest.raises(InputError, match="fill = 1"):
        run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, fill=1)


def test_composite_of_one_layer_is_the_normalised_reconstruction():
    from runtime_cl.stochastic.composite import composite

    rng = np.random.default_rng(6)
    c, d = rng.random((20, 20, 3)), rng.random((20, 20, 1)) * 2
    np.testing.assert_array_equal(composite([c], [d], 0.25), normalise(c, d, 0.25))
    np.testing.assert_allclose(composite([c], [d], 0.25, fill=False), c / np.maximum(d, 0.25), rtol=1e-6)


def _occluder_scene(size, coc_bg, rng):
    """A numpy stochastic image: an in-focus grey square (x < size/2 in every view: an in-focus
    surface projects to y' = y through any lens point) in front of a bright defocused plane whose
    pinhole image is a vertical stripe pattern; every pixel traces its own lens sample."""
    samples = rng.random((size, size, 3)).astype(np.float32)
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    dx, dy = concentric_disc(samples[..., 0], samples[..., 1])
    front = xs < size / 2
    bg_x = xs - coc_bg * dx                       # where on the background's pinhole image the ray lands
    stripes = 4.0 + 3.0 * (np.floor(bg_x / 4) % 2)
    rgb = np.where(front, 0.2, stripes)[..., None].repeat(3, axis=2).astype(np.float32)
    depth = np.where(front, CAMERA.focus_distance_m, _depth_for(coc_bg, size)).astype(np.float32)
    return Frame(rgb, depth, samples=samples)


def test_depth_layers_keep_the_background_blur_off_an_in_focus_occluder():
    """Background samples seen past the occluder's edge re-centre behind it; splatted with their
    full disc they spill over it. In one layer the normalised reconstruction blends that spill
    in; in depth layers the occluder's own density (1: it is in focus) hides it, so the occluder
    is its colour exactly, as every lens ray from its pixels meets it."""
    size, coc = 64, 6.0
    frame = _occluder_scene(size, coc, np.random.default_rng(7))
    db = disc_database(r_max=8.0, samples=64)
    band = (slice(8, -8), slice(size // 2 - 6, size // 2 - 2))    # the occluder within 6 px of its edge
    flat, _ = run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, footprint="bilinear")
    layered, _ = run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, footprint="bilinear",
                          depth_layers=2)
    assert flat[band].max() > 0.5                 # the bright background (4-7) bleeds over grey 0.2
    np.testing.assert_allclose(layered[band], 0.2, rtol=1e-4)   # float32 splat sums
    inner = (slice(8, -8), slice(size // 2 + 10, -10))           # background away from the edge and the border
    assert abs(layered[inner].mean() - 5.5) < 0.3     # the stripes' mean, blurred by a 6-px disc (+-0.15 residual)
    with pytest.raises(InputError, match="depth_layers = 2: .*normalize = True"):
        run_pass("stochastic_splat", frame, CAMERA, db, depth_layers=2)
    with pytest.raises(InputError, match="depth_layers = 0"):
        run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, depth_layers=0)
