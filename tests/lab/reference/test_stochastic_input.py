"""The 1-spp stochastic input: its lens samples and depths put every pixel back where the pinhole sees it."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lab.errors import UserError
from lab.paths import SCENES
from lab.reference.motion import project
from lab.reference.stochastic import render_stochastic, trace_samples
from lab.scene import load_scene
from runtime_cl.camera import from_header
from runtime_cl.stochastic import concentric_disc, lens_time_samples
from runtime_cl.stochastic.recentre import pinhole_positions


def _tiny(name="tiny.toml", size=32, aperture=None):
    scene = load_scene(SCENES / name)
    if aperture is not None:
        scene = replace(scene, camera=replace(scene.camera, aperture=aperture))
    return replace(scene, info=replace(scene.info, resolution=(size, size)))


def test_concentric_map_is_mitsubas():
    from lab.reference.backend import mitsuba

    mi = mitsuba()
    rng = np.random.default_rng(0)
    u, v = rng.random(4096).astype(np.float32), rng.random(4096).astype(np.float32)
    d = mi.warp.square_to_uniform_disk_concentric(mi.Point2f(mi.Float(u), mi.Float(v)))
    ours = np.stack(concentric_disc(u, v), axis=-1)
    np.testing.assert_allclose(ours, np.c_[np.asarray(d[0]), np.asarray(d[1])], atol=1e-6)  # float32


@pytest.mark.parametrize("aperture", [None, {"shape": "heart"}, {"blades": 5, "rotation_deg": 20.0}],
                         ids=["round", "heart", "iris"])
def test_recentred_positions_are_the_pinhole_projections(aperture):
    """Independent check of the whole contract: Mitsuba's thin-lens rays hit points whose pinhole
    projection is the runtime's y' (from the sample's own film point: ``subpixel.X, subpixel.Y``).
    A shaped aperture and an odd iris (neither symmetric under a half turn nor a mirror in
    x) are traced by the reference's own Python sensor: a lens point mirrored or turned would
    miss by up to the CoC."""
    scene = _tiny(aperture=aperture)
    tr = trace_samples(scene)
    image = render_stochastic(scene)
    h, w = image.depth.shape
    samples = lens_time_samples(image.extra, "input", (h, w))
    camera = from_header(image.camera, "header")
    assert samples.shape == (h, w, 5)
    y_prime = pinhole_positions(image.depth, samples, camera).reshape(-1, 2)
    hit = np.isfinite(tr["depth"])
    assert hit.mean() > 0.9
    err = np.abs(y_prime[hit] - project(scene, tr["points"][hit], 0.5))
    assert err.max() < 2e-3          # float32 depths and lens samples: ~1e-4 px measured
    # and the blur is real: samples move by pixels (round 3.5, heart and iris ~2.7 at most), three
    # orders of magnitude more than the error above
    assert np.abs(y_prime[hit] - (np.argwhere(np.ones((h, w)))[:, ::-1] + tr["jitter"])[hit]).max() > 2.0


def test_motion_input_has_times_and_motion():
    scene = _tiny("tiny_motion.toml", 24)
    image = render_stochastic(scene, max_motion_px=4.0)
    t = image.extra["time"]
    assert set(np.unique(t).round(3)) == {0.125, 0.375, 0.625, 0.875}   # 4 sub-frames of a 4 px motion
    assert "motion.X" in image.extra and np.isfinite(image.extra["motion.X"]).all()


def test_thick_lens_samples_return_to_the_pinhole_projections():
    """The thick lens's contract, checked against Mitsuba's own intersections: each pixel's middle
    wavelength ray, re-traced by the runtime from the input's channels alone (its film point
    ``subpixel.X, subpixel.Y`` and box sample ``lens.U, lens.V``:
    :func:`runtime_cl.stochastic.thick.thick_positions`), is the line whose point at the depth the
    ray hit is the pinhole projection of that hit point. A ray turned or mirrored would miss by up
    to the lens's blur, one re-traced from the pixel centre by up to the lens's magnification of
    half a pixel."""
    from runtime_cl.stochastic.thick import thick_positions

    scene = load_scene(SCENES / "tiny_rain.toml")
    tr = trace_samples(scene)
    image = render_stochastic(scene)
    h, w = image.depth.shape
    samples = lens_time_samples(image.extra, "input", (h, w))
    got = thick_positions(image.depth, samples, from_header(image.camera, "header"), 1).reshape(-1, 2)
    hit = np.isfinite(tr["depth"])
    assert hit.mean() > 0.5 and not np.isnan(got[hit]).any()   # the ray the input traced passes
    err = np.hypot(*(got[hit] - project(scene, tr["points"][hit], 0.5)).T)
    assert err.max() < 1e-3, err.max()   # float32 Mitsuba rays, depths and channels: 9e-5 px measured


def test_each_channel_of_a_thick_lens_sample_returns_to_its_own_hit():
    """Dispersed by the lens, a pixel's red and blue rays can pass a drop its middle ray hits, or
    hit one it passes. Each channel's depth (``channel_depth``, written as ``Z.R, Z.B``) is its own
    ray's hit, checked against Mitsuba's intersection of that ray, so the channel's line at that
    depth is the pinhole projection of its own hit point; at the middle ray's depth such samples
    land pixels away (the coloured specks a reconstruction then draws)."""
    from lab.reference.render import load
    from lab.reference.stochastic import thick_rays
    from runtime_cl.camera.exit_pupil import PupilBoxes
    from runtime_cl.stochastic.thick import ray_lines

    scene = load_scene(SCENES / "tiny_rain.toml")
    tr = trace_samples(scene)
    h, w = scene.height, scene.width
    camera = scene.camera.runtime_camera()
    film = np.stack([np.arange(h * w) % w, np.arange(h * w) // w], axis=1) + tr["jitter"]
    mi_scene = load(scene, "scene")
    t_mid = 0.5 * sum(scene.camera.shutter)
    for c in (0, 2):
        ray, ok = thick_rays(camera, mi_scene.sensors()[0], (h, w), film, tr["lens"], c, t_mid)
        si = mi_scene.ray_intersect(ray)
        hit = np.asarray(si.is_valid(), bool) & ok & ~tr["blocked"]
        p = np.stack([np.asarray(si.p[i], np.float64) for i in range(3)], axis=-1)[hit]
        own = tr["channel_depth"][hit, c]
        np.testing.assert_allclose(own, (p - scene.camera.position_at(t_mid)) @ scene.camera.forward(), rtol=1e-6)
        a, b, _ = ray_lines(camera, PupilBoxes.for_camera(camera, (h, w)), (h, w), film, tr["lens"], c)
        target = project(scene, p, 0.5)
        err = np.hypot(*(a[hit] + b[hit] / own[:, None] - target).T)
        assert err.max() < 1e-3, err.max()
        middle = np.hypot(*(a[hit] + b[hit] / tr["depth"][hit, None] - target).T)
        apart = ~np.isclose(own, tr["depth"][hit], rtol=0.05)
        assert 0.003 < apart.mean() < 0.2 and middle[apart].max() > 1.0, (apart.mean(), middle[apart].max())


def test_thick_lens_recentres_each_channel_through_its_wavelength():
    """A thick camera's re-centring traces every channel at its own indices: one sample's three
    channels return to places up to a pixel apart (the singlet's lateral colour, undone), each
    channel's frames hold that channel alone with its own sample counts, and blocked rays are no
    samples: the input draws its box samples until the middle ray passes, so these are the few
    re-traced from the pixel centre (the input's ray left from its sub-pixel point) or dispersed
    past the stop."""
    from runtime_cl.frame import Frame
    from runtime_cl.stochastic.recentre import recentre
    from runtime_cl.stochastic.thick import thick_positions

    scene = load_scene(SCENES / "tiny_rain.toml")
    image = render_stochastic(scene)
    h, w = image.depth.shape
    samples = lens_time_samples(image.extra, "input", (h, w))
    camera = from_header(image.camera, "header")
    red, blue = (thick_positions(image.depth, samples, camera, c) for c in (0, 2))
    apart = np.hypot(*(red - blue).reshape(-1, 2).T)
    assert 0.5 < np.nanmax(apart) < 3.0 and 0.0 < np.isnan(apart).mean() < 0.05   # 1.2 px; 0.7 % blocked
    rec = recentre(Frame(image.rgb, image.depth, alpha=image.alpha), samples, camera)
    for frame, n in zip(rec.frames, rec.counts):
        assert n.shape == (h, w, 3) and np.count_nonzero(n.max(axis=(0, 1))) == 1   # one channel per frame
        c = int(np.argmax(n.max(axis=(0, 1))))
        assert not np.delete(np.asarray(frame.rgb), c, axis=2).any()
    total = sum(rec.counts).sum(axis=(0, 1))
    assert np.all((0.9 * h * w < total) & (total < h * w))   # the blocked rays are left out


def test_a_thick_lens_that_blocks_every_ray_reconstructs_black():
    """Box samples in a corner of every pixel's exit-pupil box, outside the round pupil: the lens
    blocks every ray, so there is no sample; the stochastic pass renders black, not an error."""
    from runtime_cl.frame import Frame
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.synthetic import disc_database
    from runtime_cl.stochastic.recentre import recentre

    scene = load_scene(SCENES / "tiny_rain.toml")
    camera = scene.camera.runtime_camera()
    h, w = scene.height, scene.width
    samples = np.zeros((h, w, 3), np.float32)
    frame = Frame(np.ones((h, w, 3), np.float32), np.full((h, w), 2.0, np.float32), samples=samples)
    rec = recentre(frame, samples, camera)
    assert len(rec.frames) == 3 and rec.dropped == h * w and not any(np.any(f.rgb) for f in rec.frames)
    image, _ = run_pass("stochastic_splat", frame, camera, disc_database(4.0, samples=4), normalize=True)
    assert image.shape == (h, w, 3) and not np.any(image)


def test_shading_spp_keeps_the_visibility_sample_and_lowers_the_noise():
    scene = _tiny(size=24)
    one, many = trace_samples(scene, shading_spp=1), trace_samples(scene, shading_spp=16)
    for key in ("lens", "t_frac", "jitter", "depth"):
        np.testing.assert_array_equal(one[key], many[key])       # the same camera ray per pixel
    ref = trace_samples(scene, shading_spp=256)["rgb"]   # the same camera rays, converged shading
    assert np.mean((many["rgb"] - ref) ** 2) < 0.25 * np.mean((one["rgb"] - ref) ** 2)
    with pytest.raises(UserError, match=r"shading_spp = 0: give an integer in \[1, 4096\]"):
        trace_samples(scene, shading_spp=0)


def test_motion_recentring_reaches_the_mid_shutter_projection():
    """Moving shapes: each sample's y' (lens and motion undone) is where its surface point is seen
    by the pinhole at mid-shutter. Exact for translations; turning shapes move along an arc, not
    the chord the motion vectors hold, so those pixels are held to the chord's sagitta."""
    scene = _tiny("tiny_motion.toml", 32)
    image = render_stochastic(scene, max_motion_px=8.0)
    tr = trace_samples(scene, max_motion_px=8.0)
    h, w = image.depth.shape
    samples = lens_time_samples(image.extra, "input", (h, w))
    motion = np.stack([image.extra["motion.X"], image.extra["motion.Y"]], axis=-1)
    y_prime = pinhole_positions(image.depth, samples, from_header(image.camera, "header"), motion)
    y_prime = y_prime.reshape(-1, 2)
    o, c = scene.camera.shutter
    mid = 0.5 * (o + c)
    truth = tr["points"].copy()
    translating = np.zeros(h * w, bool)
    for i, shape in enumerate(scene.shapes):
        if shape.velocity is None and shape.angular_velocity_deg is None:
            continue
        for t in np.unique(tr["t_frac"]):
            on = (tr["shape_idx"] == i) & (tr["t_frac"] == t)
            m = shape.to_world_at(mid) @ np.linalg.inv(shape.to_world_at(o + t * (c - o)))
            truth[on] = tr["points"][on] @ m[:3, :3].T + m[:3, 3]
        translating |= (tr["shape_idx"] == i) & (shape.angular_velocity_deg is None)
    hit = np.isfinite(tr["depth"])
    err = np.hypot(*(y_prime - project(scene, truth, mid)).T)
    moved = hit & (np.hypot(*motion.reshape(-1, 2).T) > 1.0)
    assert moved.sum() > 20 and translating[moved].sum() > 5
    assert err[hit & translating].max() < 5e-3   # float32 moved vertices and channels: <= 2.2e-3 px measured
    assert np.median(err[moved]) < 0.1                   # arcs of <= 45 degrees over the shutter


@pytest.mark.parametrize("aperture", [{"shape": "heart"}, {"blades": 5, "rotation_deg": 20.0}, {"blades": 4}])
def test_lens_channels_hold_the_shape_point_in_film_axes(aperture):
    """lens.U, lens.V of a shaped lens lie in [0, 1) -- corners on the unit circle included, where
    rounding can put the point just outside the disc -- and map back to the shape's point (x, y),
    mirrored to the film's y down."""
    from drjit.llvm import Array2f, Float

    from lab.optics.aperture import make_aperture
    from lab.reference.stochastic import lens_channels

    scene = _tiny(aperture=aperture)
    rng = np.random.default_rng(3)
    top = np.nextafter(np.float32(1), np.float32(0))
    corners = [[0, 0], [0, top], [top, 0], [top, top], [0.5, 0.5]]
    lens = np.concatenate([rng.random((4000, 2)), corners]).astype(np.float32)
    u, v = lens_channels(scene, lens)
    assert u.dtype == v.dtype == np.float32 and (u >= 0).all() and (u < 1).all() and (v >= 0).all() and (v < 1).all()
    shaped, iris = scene.camera.shaped(), scene.camera.iris()
    shape = shaped.aperture() if shaped is not None else make_aperture(
        "polygon", blades=iris.blades, rotation_deg=iris.rotation_deg, rounding=iris.rounding)
    p = shape.sample(Array2f(Float(lens[:, 0]), Float(lens[:, 1])))
    dx, dy = concentric_disc(u, v)
    np.testing.assert_allclose(np.c_[dx, dy], np.c_[np.asarray(p.x), -np.asarray(p.y)], atol=1e-5)


def test_a_medium_is_left_to_the_runtime():
    """tiny_fog's stochastic input (converged shading) is the labelled input's fog-free surfaces,
    which the volume PSFs then fog; not the volpath view, which would fog it twice. Measured
    (tonemapped MSE against the fog-free pinhole / the volpath view): 0.008 / 0.036; the same
    samples traced through the medium (``medium=True``, BM3D's input in Table 3) 0.032 / 0.014."""
    from lab.reference.render import render_pinhole, render_reference
    from lab.report.metrics import tonemap

    scene = _tiny("tiny_fog.toml", size=24)
    image = render_stochastic(scene, shading_spp=64)
    surfaces, fogged = render_pinhole(scene, spp=64, progress=False), render_reference(scene, spp=64, progress=False)
    assert image.camera["medium"] == {"sigma_t": 0.25, "albedo": [0.9, 0.9, 0.85], "g": 0.6}
    mse = lambda a, b: float(np.mean((tonemap(a) - tonemap(b)) ** 2))   # noqa: E731  (lights clip)
    assert mse(image.rgb, surfaces) < 0.5 * mse(image.rgb, fogged), (mse(image.rgb, surfaces), mse(image.rgb, fogged))
    shown = render_stochastic(scene, shading_spp=64, medium=True)
    assert mse(shown.rgb, fogged) < 0.5 * mse(shown.rgb, surfaces), (mse(shown.rgb, fogged), mse(shown.rgb, surfaces))
    np.testing.assert_array_equal(shown.extra["lens.U"], image.extra["lens.U"])   # the same samples
