"""Mitsuba scene dicts, seeded render passes, the labelled input and the CoC range helper."""
import math
from dataclasses import replace

import numpy as np
import pytest

from lab.exr_io import read_labelled, write_labelled
from lab.paths import SCENES
from lab.reference.coc import CocRange, coc_range, depth_range
from lab.reference.labelled import planar_depth, render_labelled
from lab.reference.mitsuba_scene import scene_dict
from lab.reference.passes import FIXED_BLOCK_LANES, RenderPass
from lab.reference.render import pass_seeds, reference_job, render_pinhole, render_reference, split_spp
from lab.scene import load_scene


@pytest.fixture(scope="module")
def tiny():
    return load_scene(SCENES / "tiny.toml")


def small(scene, w, h):
    return replace(scene, info=replace(scene.info, resolution=(w, h)))


def test_scene_dict_sensors(tiny):
    lens = tiny.camera.thin_lens()
    thin = scene_dict(tiny, "scene", spp=8)["sensor"]
    assert thin["type"] == "thinlens" and thin["fov_axis"] == "x"
    assert thin["aperture_radius"] == pytest.approx(lens.aperture_radius_m)
    assert thin["focus_distance"] == 2.0
    assert thin["fov"] == pytest.approx(lens.fov_x_deg())
    assert thin["film"]["rfilter"] == {"type": "box"} and thin["sampler"]["sample_count"] == 8
    pin = scene_dict(tiny, "pinhole")["sensor"]
    assert pin["type"] == "perspective" and "aperture_radius" not in pin
    assert pin["fov"] == thin["fov"]
    np.testing.assert_array_equal(np.array(pin["to_world"].matrix), np.array(thin["to_world"].matrix))
    d = scene_dict(tiny)
    assert sum(k.startswith("shape_") for k in d) == len(tiny.shapes)
    assert d["shape_5"]["emitter"]["sampling_weight"] == pytest.approx(0.02)
    assert d["shape_0"]["bsdf"] == {"type": "ref", "id": "material_1"}  # floor, sorted names
    assert d["material_1"]["reflectance"]["type"] == "checkerboard"


def test_split_spp_and_seeds():
    assert split_spp(512, 1024, 1024) == [16] * 32
    assert split_spp(100, 1024, 1024) == [16] * 6 + [4]
    assert split_spp(4103, 1024, 1024) == [16] * 256 + [4, 2, 1]   # the rest in powers of two
    assert split_spp(1000, 640, 480) == [32] * 31 + [4, 4]          # 2^24 // 307200 = 54 -> 32; 8 x 307200 < 2^22
    assert split_spp(64, 256, 256) == [64]                          # 2^22 samples: fixed Dr.Jit blocks
    assert split_spp(64, 64, 64) == [4] * 16                        # 2^18: blocks sized by threads
    assert split_spp(10, 8, 8, pass_spp=4) == [4, 4, 2]
    for spp, w, h in [(4096, 1024, 1024), (77, 333, 211), (5, 1, 1), (3000, 17, 5)]:
        chunks = split_spp(spp, w, h)
        assert sum(chunks) == spp and all(c & (c - 1) == 0 for c in chunks)
        assert all(c <= 4 or w * h * c >= FIXED_BLOCK_LANES for c in chunks)
    with pytest.raises(ValueError):
        split_spp(0, 8, 8)
    with pytest.raises(ValueError, match="power of two"):
        split_spp(10, 8, 8, pass_spp=3)
    with pytest.raises(ValueError, match="pass 2: spp = 3 must be a power of two"):
        RenderPass(2, 3, 1, (3.0,) * 3)
    seeds = pass_seeds(7, "reference", 32)
    assert len(set(seeds)) == 32 and set(seeds).isdisjoint(pass_seeds(7, "input", 32))
    assert seeds == pass_seeds(7, "reference", 32) and seeds != pass_seeds(8, "reference", 32)


def test_reference_is_seeded_and_passes_average(tiny):
    scene = small(tiny, 24, 24)
    a = render_reference(scene, spp=8, pass_spp=4, progress=False)
    b = render_reference(scene, spp=8, pass_spp=4, progress=False)
    assert a.shape == (24, 24, 3) and a.dtype == np.float32
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)  # same seed, same image
    c = render_reference(replace(scene, render=replace(scene.render, seed=8)), spp=8, pass_spp=4,
                         progress=False)
    assert np.abs(a - c).mean() > 1e-3  # another seed, another noise
    # One pass of 32 and the job's passes (8 x 4 at this size) estimate the same image: without
    # the small lights (rare, bright hits) the image means agree to ~1%.
    lit = replace(scene, shapes=scene.shapes[:5])
    job = reference_job(lit, spp=32)
    assert [p.spp for p in job.passes()] == [4] * 8
    one = job.render(RenderPass(0, 32, 12345, (32.0,) * 3))
    split = job.run(progress=False)
    assert split.mean() == pytest.approx(one.mean(), rel=0.03)


def test_labelled_input_round_trip_and_coc_range(tiny, tmp_path):
    scene = small(tiny, 32, 32)
    im = render_labelled(scene, spp=4, progress=False)
    assert im.rgb.shape == (32, 32, 3) and np.all(im.alpha == 1) and np.all(np.isfinite(im.depth))
    assert im.camera == scene.camera.camera_json()
    write_labelled(tmp_path / "input.exr", im)
    back = read_labelled(tmp_path / "input.exr")
    np.testing.assert_array_equal(back.depth, im.depth)
    lens = scene.camera.thin_lens()
    r = coc_range(back)
    z0, z1 = depth_range(back)
    assert (r.z_min_m, r.z_max_m) == (z0, z1) == (float(im.depth.min()), float(im.depth.max()))
    assert r.coc_min_px == pytest.approx(float(lens.coc_radius_px(z0, 32)))
    assert r.coc_max_px == pytest.approx(float(lens.coc_radius_px(z1, 32)))
    assert r.coc_min_px < 0 < r.coc_max_px and r.max_abs_px == max(-r.coc_min_px, r.coc_max_px)
    # Pinhole colour and the input colour come from the same seed stream and view.
    np.testing.assert_allclose(render_pinhole(scene, spp=4, progress=False), im.rgb, rtol=1e-5, atol=1e-6)


def test_coc_range_pinhole_and_infinity():
    from lab.exr_io import LabelledImage

    z = np.array([[1.0, np.inf]], np.float32)
    rgb = np.zeros((1, 2, 3), np.float32)
    pin = LabelledImage(rgb, np.ones((1, 2), np.float32), z, {"lens": "pinhole", "fov_x_deg": 40.0})
    assert coc_range(pin) == CocRange(1.0, math.inf, 0.0, 0.0)
    thin = replace(pin, camera={"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0,
                                "focus_distance_m": 2.0})
    r = coc_range(thin)
    scale = 0.0125 * (0.05 * 2 / 1.95) * 2 / 0.036  # a v W / sensor width, W = 2 px
    assert r.coc_max_px == pytest.approx(scale * 0.5) and r.coc_min_px == pytest.approx(-scale * 0.5)


def test_demo_view_is_closed_and_its_coc_range_is_as_designed():
    """Every demo pixel hits geometry; big background bokeh, some foreground blur, max |CoC| <= 100.

    85 mm f/1.2 focused at 1 m: r(z) = 93.6 (1 - 1/z) px. Most of the frame is background at
    70..90 px (the wall at 10 m is +84); the table at the bottom of the frame (0.65 m) is -50.
    """
    demo = load_scene(SCENES / "demo.toml")
    z = planar_depth(demo)
    assert z.shape == (1024, 1024) and np.all(np.isfinite(z))
    lens = demo.camera.thin_lens()
    assert lens.coc_scale_px(1024) == pytest.approx(93.58, abs=0.01)
    r = lens.coc_radius_px(z, 1024)
    assert 80 < r.max() < 88 and -56 < r.min() < -44
    assert np.abs(r).max() <= 100
    assert np.mean((r >= 70) & (r <= 90)) > 0.5  # mostly big background bokeh
    assert 0.05 < np.mean(r < -20) < 0.3  # some foreground blur
    assert np.mean(np.abs(r) < 3) > 0.05  # a sharp subject (ball, cube, the table under them)


def test_a_scene_loads_the_same_every_time():
    """rain's 97 emitters (lamps, drops, streaks: emitting boxes that share a BSDF) come out of
    every load in one order, each shape its own: Mitsuba's default optimisation merged the boxes in
    an order that changed from load to load, and with it the light a random number picked (the
    same seeds rendered 0.4 % of rain's pixels differently at 1 spp)."""
    from lab.reference.backend import load_scene_dict

    scene = load_scene(SCENES / "rain.toml")
    data = scene_dict(small(scene, 32, 32), "pinhole")

    def order():
        loaded = load_scene_dict(data)
        return [e.get_shape().id() if e.get_shape() is not None else type(e).__name__ for e in loaded.emitters()], \
            len(loaded.shapes())

    first = order()
    assert first[1] == len(scene.shapes) and len(first[0]) > 90
    assert all(order() == first for _ in range(3))
    image = render_labelled(small(scene, 32, 32), spp=1, progress=False)
    again = render_labelled(small(scene, 32, 32), spp=1, progress=False)
    np.testing.assert_array_equal(image.rgb, again.rgb)
