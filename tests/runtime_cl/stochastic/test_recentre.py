"""Re-centring a stochastic image: one CoC from a defocused point, not a CoC convolved with itself."""
from __future__ import annotations

import numpy as np
import pytest

from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.passes import run_pass
from runtime_cl.psf.disc import disc_psf
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.stochastic import channel_depths, concentric_disc, inverse_concentric, lens_time_samples, recentre

SIZE = 64
CAMERA = ThinLens(85.0, 0.5, 2.0)          # 13.4 px of CoC per dioptre at 64 px (scenes/tiny.toml)


def _depth_for(coc_px: float) -> float:
    """The depth behind the focus plane whose CoC radius is ``coc_px``."""
    return 1.0 / (1.0 / CAMERA.focus_distance_m - coc_px / CAMERA.coc_scale_px(SIZE))


def test_concentric_round_trip():
    rng = np.random.default_rng(1)
    u, v = rng.random(10000), rng.random(10000)
    dx, dy = concentric_disc(u, v)
    assert np.all(np.hypot(dx, dy) <= 1.0 + 1e-12)
    u2, v2 = inverse_concentric(dx, dy)
    np.testing.assert_allclose(np.c_[u2, v2], np.c_[u, v], atol=1e-9)   # float64 trig round-off


def _point_image(coc_px: float, rng):
    """The stochastic image of one bright point at the centre pixel (LSR18 Fig. 7 a): every pixel
    inside its CoC saw it, with the lens sample that sends it there; energy 1 in total."""
    z = _depth_for(coc_px)
    ys, xs = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    c = SIZE // 2 + 0.5
    dx, dy = (xs - c) / coc_px, (ys - c) / coc_px
    hit = np.hypot(dx, dy) < 1.0
    u, v = rng.random((SIZE, SIZE)), rng.random((SIZE, SIZE))   # the black pixels' own samples
    iu, iv = inverse_concentric(dx[hit], dy[hit])
    u[hit], v[hit] = iu, iv
    rgb = np.zeros((SIZE, SIZE, 3), np.float32)
    rgb[hit] = 1.0 / hit.sum()
    samples = np.stack([u, v, rng.random((SIZE, SIZE))], axis=-1).astype(np.float32)
    return Frame(rgb, np.full((SIZE, SIZE), z, np.float32), samples=samples), hit


@pytest.mark.parametrize("method", ["stochastic_splat", "stochastic_spreadlets"])
def test_defocused_point_reconstructs_one_coc(method):
    coc = 6.0
    frame, hit = _point_image(coc, np.random.default_rng(2))
    db = disc_database(r_max=10.0, samples=64)
    image, _ = run_pass(method, frame, CAMERA, db)
    out = image[..., 0]
    expected = np.zeros((SIZE, SIZE))
    disc = disc_psf(coc)
    r = disc.shape[0] // 2
    expected[SIZE // 2 - r:SIZE // 2 + r + 1, SIZE // 2 - r:SIZE // 2 + r + 1] = disc / disc.sum()
    # energy: every sample's light, once (float32 splat sums)
    assert out.sum() == pytest.approx(1.0, rel=1e-4)
    ys, xs = np.mgrid[0:SIZE, 0:SIZE] - SIZE // 2
    second = float((out * (xs ** 2 + ys ** 2)).sum())
    # a disc of radius c has E[r^2] = c^2 / 2; a disc convolved with itself has c^2
    assert second == pytest.approx(coc ** 2 / 2, rel=0.08)   # the database's cells step the radius by ~2 %
    # and it is the disc pixel by pixel: the database's nearest cell radius differs by < 0.2 px
    assert np.abs(out - expected).sum() < 0.1
    # the plain pass on the same pixels draws the CoC twice: twice the second moment
    plain, _ = run_pass(method.split("_", 1)[1], Frame(frame.rgb, frame.depth), CAMERA, db)
    twice = float((plain[..., 0] * (xs ** 2 + ys ** 2)).sum())
    assert twice == pytest.approx(coc ** 2, rel=0.1)


def test_motion_recentring_returns_each_time_to_mid_shutter():
    """A point moving 10 px right over the shutter, seen at times t: y' is its mid-shutter place."""
    rng = np.random.default_rng(3)
    t = rng.random((SIZE, SIZE))
    xs = np.mgrid[0:SIZE, 0:SIZE][1] + 0.5
    motion = np.zeros((SIZE, SIZE, 2), np.float32)
    motion[..., 0] = 10.0
    samples = np.stack([np.full_like(t, 0.5), np.full_like(t, 0.5), t], axis=-1).astype(np.float32)
    frame = Frame(np.ones((SIZE, SIZE, 1), np.float32), np.full((SIZE, SIZE), 2.0, np.float32),
                  motion=motion, samples=samples)
    rec = recentre(frame, samples, CAMERA)
    total = sum(f.rgb[..., 0] for f in rec.frames)
    assert total.sum() + rec.dropped == SIZE * SIZE
    assert rec.max_shift_px <= 5.0 + 1e-6
    np.testing.assert_allclose(rec.max_shift_px, np.abs(10.0 * (t - 0.5)).max(), atol=1e-5)
    del xs


def test_bad_channels_name_the_channel_value_and_fix():
    good = {"lens.U": np.full((4, 4), 0.5), "lens.V": np.full((4, 4), 0.5), "time": np.zeros((4, 4))}
    assert lens_time_samples(good, "in.exr", (4, 4)).shape == (4, 4, 3)
    bad = dict(good, **{"lens.V": np.full((4, 4), 1.0)})
    with pytest.raises(InputError, match=r"in\.exr: channel lens\.V = 1\.0 .*outside \[0, 1\)"):
        lens_time_samples(bad, "in.exr", (4, 4))
    with pytest.raises(InputError, match=r"in\.exr: channel\(s\) \['time'\] missing"):
        lens_time_samples({k: good[k] for k in ("lens.U", "lens.V")}, "in.exr", (4, 4))
    sub = dict(good, **{"subpixel.X": np.full((4, 4), 0.25), "subpixel.Y": np.full((4, 4), 0.75)})
    assert lens_time_samples(sub, "in.exr", (4, 4)).shape == (4, 4, 5)
    with pytest.raises(InputError, match=r"in\.exr: channel subpixel\.Y missing beside subpixel\.X; write both"):
        lens_time_samples(dict(good, **{"subpixel.X": np.full((4, 4), 0.25)}), "in.exr", (4, 4))
    with pytest.raises(InputError, match=r"samples: shape \(4, 4, 4\), need \(H, W, 3\)"):
        Frame(np.ones((4, 4, 3)), np.ones((4, 4)), samples=np.zeros((4, 4, 4)))
    with pytest.raises(InputError, match="stochastic_splat.*needs the channels"):
        run_pass("stochastic_splat", Frame(np.ones((4, 4, 3)), np.ones((4, 4))), CAMERA, disc_database(4.0))


def test_channel_depths_default_to_z_and_refuse_bad_values():
    z = np.full((4, 4), 3.0, np.float32)
    assert channel_depths({}, "in.exr", z) is None
    got = channel_depths({"Z.R": np.full((4, 4), np.inf)}, "in.exr", z)   # inf: the ray hit nothing
    assert got.shape == (4, 4, 3) and np.isinf(got[..., 0]).all() and (got[..., 1:] == 3.0).all()
    with pytest.raises(InputError, match=r"in\.exr: channel Z\.B = 0\.0 at pixel \(x=0, y=0\) \(16 pixel"):
        channel_depths({"Z.B": np.zeros((4, 4))}, "in.exr", z)
    with pytest.raises(InputError, match=r"in\.exr: channel Z\.R is \(2, 2\), the image is \(4, 4\)"):
        channel_depths({"Z.R": np.ones((2, 2))}, "in.exr", z)
    with pytest.raises(InputError, match=r"channel_depth: shape \(4, 4, 1\), need one depth per colour"):
        Frame(np.ones((4, 4, 3)), z, channel_depth=np.ones((4, 4, 1)))


def test_normalised_reconstruction_of_a_flat_plane_is_flat():
    """A constant plane at a 4-px CoC: the plain sum carries the random sample density (about
    1 / sqrt(pi 4^2) = 14 % per pixel), the density-normalised one is the constant."""
    rng = np.random.default_rng(4)
    samples = rng.random((SIZE, SIZE, 3)).astype(np.float32)
    frame = Frame(np.full((SIZE, SIZE, 3), 0.5, np.float32), np.full((SIZE, SIZE), _depth_for(4.0), np.float32),
                  samples=samples)
    db = disc_database(r_max=10.0, samples=64)
    inner = (slice(12, -12), slice(12, -12))       # away from the border, where samples leave the frame
    plain, _ = run_pass("stochastic_splat", frame, CAMERA, db)
    normal, _ = run_pass("stochastic_splat", frame, CAMERA, db, normalize=True)
    assert plain[inner].mean() == pytest.approx(0.5, rel=0.02)      # unbiased: the mean density is 1
    assert plain[inner].std() > 0.02
    np.testing.assert_allclose(normal[inner], 0.5, rtol=1e-4)        # float32 splat sums
    with pytest.raises(InputError, match="min_density = 0"):
        run_pass("stochastic_splat", frame, CAMERA, db, normalize=True, min_density=0)


def test_reconstruction_is_unbiased_on_a_textured_plane():
    """A textured plane at a 3-px CoC, seen through random lens samples (numpy: pixel j shows the
    texture at j - c d): the mean of many reconstructions is the Splat of the pinhole texture."""
    size, coc, runs = 40, 3.0, 48
    z = 1.0 / (1.0 / CAMERA.focus_distance_m - coc / CAMERA.coc_scale_px(size))
    rng = np.random.default_rng(5)
    texture = rng.random((size // 4, size // 4)).repeat(4, 0).repeat(4, 1)     # 4-px blocks
    db = disc_database(r_max=6.0, samples=64)
    depth = np.full((size, size), z, np.float32)
    expected, _ = run_pass("splat", Frame(texture[..., None].astype(np.float32), depth), CAMERA, db)
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    total = np.zeros((size, size))
    for _ in range(runs):
        u, v, t = rng.random((3, size, size))
        dx, dy = concentric_disc(u, v)
        px, py = np.floor(xs - coc * dx).astype(int), np.floor(ys - coc * dy).astype(int)
        seen = np.where((px >= 0) & (px < size) & (py >= 0) & (py < size),
                        texture[py.clip(0, size - 1), px.clip(0, size - 1)], 0.0)
        frame = Frame(seen[..., None].astype(np.float32), depth,
                      samples=np.stack([u, v, t], axis=-1).astype(np.float32))
        total += run_pass("stochastic_splat", frame, CAMERA, db)[0][..., 0]
    inner = (slice(8, -8), slice(8, -8))            # the border loses samples that leave the frame
    diff = total[inner] / runs - expected[inner][..., 0]
    # one reconstruction's pixel noise is ~0.1 here (a 3-px CoC holds ~28 samples of a [0, 1)
    # texture); the mean of 48 leaves ~0.015: 4 sigma per pixel, and no bias in the mean
    assert np.abs(diff).max() < 0.07
    assert abs(diff.mean()) < 0.005


def test_samples_of_different_motion_keep_their_own_entries():
    """A moving light and the static wall behind it, at nearly one depth, landing on one pixel:
    each keeps its motion (averaged, the light's streak would take the wall's zero motion in)."""
    depth = np.full((1, 3), 2.0, np.float32)
    motion = np.array([[[0.0, 0.0], [0.0, 0.0], [22.0, 0.0]]], np.float32)
    samples = np.array([[[0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5 + 2.0 / 22.0]]], np.float32)
    frame = Frame(np.ones((1, 3, 1), np.float32), depth, motion=motion, samples=samples)
    rec = recentre(frame, samples, CAMERA)        # pixel 2's sample moves back 2 px onto pixel 0
    assert len(rec.frames) == 2
    got = sorted(float(f.motion[0, 0, 0]) for f in rec.frames)
    assert got == pytest.approx([0.0, 22.0])
    assert sum(float(n[0, 0, 0]) for n in rec.counts) == 2.0


@pytest.mark.parametrize("name", ["stochastic_spreadlets", "stochastic_splat"])
def test_stochastic_passes_refuse_global_depth_layers(name):
    """Re-centred slots are flat frames: global depth layers would meet frames without layers
    (the passes' own ``depth_layers`` bin the slots). A far field completes a medium's database,
    whose sample counts are never splatted (tests/runtime_cl/stochastic/test_medium.py)."""
    from runtime_cl.passes import get_pass

    cls = get_pass(name)
    assert not cls.layered and cls.far_field
    with pytest.raises(InputError, match="renders one layer"):
        cls(ThinLens(50.0, 2.0, 1.0), layers=2)


@pytest.mark.parametrize("method", ["stochastic_splat", "stochastic_spreadlets"])
def test_a_point_outside_the_frame_blurs_back_in(method):
    """A lamp 3 px left of the frame, CoC -10 px (in front of the focus): the frame's left edge saw
    it through the lens.
    Its samples re-centre outside the image; kept in the margin, their PSFs draw the part of its
    disc that lies inside the frame (as a path tracer does); dropped, the frame loses its light."""
    coc, rng = -10.0, np.random.default_rng(5)
    z = _depth_for(coc)
    ys, xs = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    cx, cy = -3.0, SIZE / 2 + 0.5          # the lamp's pinhole position, outside the image
    dx, dy = (xs - cx) / coc, (ys - cy) / coc
    hit = np.hypot(dx, dy) < 1.0
    u, v = rng.random((SIZE, SIZE)), rng.random((SIZE, SIZE))
    u[hit], v[hit] = inverse_concentric(dx[hit], dy[hit])
    disc = disc_psf(-coc) / disc_psf(-coc).sum()
    rgb = np.zeros((SIZE, SIZE, 3), np.float32)
    rgb[hit] = disc.max()                   # each pixel of the blurred lamp: one unit-energy disc's value
    samples = np.stack([u, v, rng.random((SIZE, SIZE))], axis=-1).astype(np.float32)
    frame = Frame(rgb, np.full((SIZE, SIZE), z, np.float32), samples=samples)
    db = disc_database(r_max=12.0, samples=64)
    # the disc centred on the lamp, the part inside the image
    r = disc.shape[0] // 2
    big = np.zeros((SIZE + 2 * 16, SIZE + 2 * 16))
    px, py = int(np.floor(cx)) + 16, int(np.floor(cy)) + 16
    big[py - r:py + r + 1, px - r:px + r + 1] = disc
    expected = big[16:-16, 16:-16]
    kept, t = run_pass(method, frame, CAMERA, db)
    assert t.counts["margin_px"] == 11 and t.counts["dropped_samples"] == 0
    # the plain sum spreads the samples it has: those of the pixels inside the frame, the in-frame
    # part of the disc; so it keeps that part of them (a guard band on the input would add the rest)
    inside = float(expected.sum())
    assert kept[..., 0].sum() == pytest.approx(hit.sum() * disc.max() * inside, rel=0.02)
    assert np.abs(kept[..., 0] / kept[..., 0].sum() - expected / inside).sum() < 0.1
    lost, t = run_pass(method, frame, CAMERA, db, keep_outside=False)
    assert t.counts["margin_px"] == 0 and t.counts["dropped_samples"] >= hit.sum()
    assert lost[..., 0].sum() < 1e-6
    # normalised by the sample density, the frame's left edge inside the disc takes the lamp's
    # radiance averaged with the black samples that land there too (0.46 of it); dropped, none
    edge = (slice(int(cy) - 3, int(cy) + 3), slice(0, 3))
    kept, _ = run_pass(method, frame, CAMERA, db, normalize=True)
    lost, _ = run_pass(method, frame, CAMERA, db, normalize=True, keep_outside=False)
    assert kept[edge][..., 0].mean() > 0.4 * disc.max() and lost[edge][..., 0].max() == 0.0


def test_a_widened_camera_keeps_the_pixel_pitch():
    """The margin's frames are splatted with the camera widened at the image's pixel pitch: a thin
    lens's CoCs and a pinhole's pixel directions (a medium's light distances) stay the image's."""
    from runtime_cl.camera.pinhole import Pinhole
    from runtime_cl.stochastic.recentre import widened

    pin, thin = Pinhole(fov_deg=40.0), ThinLens(50.0, 2.0, 1.0)
    assert widened(pin, 24, 3).focal_px(30) == pytest.approx(pin.focal_px(24), rel=1e-12)
    assert widened(thin, 24, 3).coc_radius_px(3.0, 30) == pytest.approx(thin.coc_radius_px(3.0, 24), rel=1e-12)
    assert widened(pin, 24, 0) is pin


def test_a_sample_in_focus_stays_home_nearest_and_lies_at_its_film_point_bilinear():
    """``subpixel.X, subpixel.Y`` = (0.9, 0.1) in focus: the nearest footprint keeps each sample
    whole on its own pixel (its box, moved by nothing); the bilinear one lays it at its film point,
    0.4 px right of and 0.4 px above its pixel's centre."""
    h = w = 8
    samples = np.zeros((h, w, 5), np.float32)
    samples[..., :3] = 0.5
    samples[..., 3], samples[..., 4] = 0.9, 0.1
    rgb = np.zeros((h, w, 1), np.float32)
    rgb[3, 3] = 1.0
    frame = Frame(rgb, np.full((h, w), CAMERA.focus_distance_m, np.float32), samples=samples)
    (near,) = recentre(frame, samples, CAMERA).frames
    assert near.rgb[3, 3, 0] == 1.0 and near.rgb.sum() == 1.0
    (tent,) = recentre(frame, samples, CAMERA, footprint="bilinear").frames
    want = np.zeros((h, w))
    want[3, 3], want[3, 4], want[2, 3], want[2, 4] = 0.36, 0.24, 0.24, 0.16
    np.testing.assert_allclose(tent.rgb[..., 0], want, atol=1e-6)
