"""The camera contract against Mitsuba itself: planar Z, pixel layout, and thin-lens CoC discs.

The CoC test is the strongest single check of the whole camera contract: a tiny emitter off the
focus plane, rendered with Mitsuba's ``thinlens`` sensor configured from our ``ThinLens`` (fov
from ``fov_x_deg()``, aperture f/2N, focus F), must spread into a disc centred on its pinhole
projection whose radius is ``ThinLens.coc_radius_px``.
"""
import math

import numpy as np
import pytest

from lab.reference.labelled import planar_depth, render_labelled
from lab.reference.render import render_reference
from lab.scene import parse_scene

W = 64


def make_scene(camera, shapes, materials=None, emitters=(), res=(W, W), max_depth=1):
    return parse_scene({"scene": {"name": "geo", "resolution": list(res)}, "camera": camera,
                        "render": {"max_depth": max_depth}, "materials": materials or {},
                        "shapes": list(shapes), "emitters": list(emitters)}, "geo.toml")


def test_planar_depth_of_a_fronto_parallel_plane():
    """Z is the planar depth d everywhere (the radial distance would be up to 30% more here)."""
    pos = np.array([0.3, 1.2, -0.5])
    fwd = np.array([0.4, -0.3, 1.0]) / np.linalg.norm([0.4, -0.3, 1.0])
    d = 2.5
    # A big rectangle whose +z normal faces the camera: rotate (0, 0, -1) onto -fwd.
    yaw = math.degrees(math.atan2(-fwd[0], -fwd[2]))
    pitch = math.degrees(math.asin(fwd[1]))
    cam = {"model": "pinhole", "position": pos.tolist(), "look_at": (pos + fwd).tolist(), "fov_deg": 70.0}
    wall = {"type": "rectangle", "material": "m", "center": (pos + d * fwd).tolist(), "scale": 20.0,
            "rotate": [pitch, yaw, 0.0]}
    scene = make_scene(cam, [wall], {"m": {"reflectance": [0.5, 0.5, 0.5]}}, res=(32, 24))
    normal = scene.shapes[0].to_world_matrix()[:3, 2]
    np.testing.assert_allclose(normal / np.linalg.norm(normal), -fwd, atol=1e-9)
    z = planar_depth(scene)
    assert z.shape == (24, 32)
    np.testing.assert_allclose(z, d, rtol=2e-5)


def test_misses_are_inf_with_zero_coverage_and_pixels_match_the_render():
    """A sphere up and to the camera's left of the axis (+x, +y: Mitsuba's image left is +x):
    its Z mask and its rendered colour occupy the same pixels, in the top-left quadrant."""
    cam = {"model": "pinhole", "position": [0, 0, 0], "look_at": [0, 0, 1], "fov_deg": 50.0}
    ball = {"type": "sphere", "center": [0.5, 0.4, 3.0], "radius": 0.35,
            "emitter": {"radiance": [1.0, 1.0, 1.0]}}
    scene = make_scene(cam, [ball], res=(48, 40))
    scene = parse_scene({**scene.to_dict(), "render": {"input_spp": 64, "max_depth": 1}}, "geo.toml")
    im = render_labelled(scene, progress=False)
    hit = np.isfinite(im.depth)
    assert 0 < hit.sum() < hit.size / 4
    np.testing.assert_array_equal(im.alpha, hit.astype(np.float32))
    lit = im.rgb[..., 0] > 0.5  # the box filter makes edge pixels partial; centres decide Z
    assert (hit & lit).sum() / (hit | lit).sum() > 0.9
    ys, xs = np.nonzero(hit)
    assert xs.mean() < 24 and ys.mean() < 20
    # Z of a sphere: at least the centre depth minus the radius, all finite depths positive.
    assert im.depth[hit].min() >= 3.0 - 0.35 - 1e-4
    # The projected centre: pixels per unit tangent = W / (2 tan(fov/2)).
    k = 48 / (2 * math.tan(math.radians(25.0)))
    w = im.rgb[..., 0]
    cx, cy = (w * (np.arange(48) + 0.5)).sum() / w.sum(), (w.T * (np.arange(40) + 0.5)).sum() / w.sum()
    assert cx == pytest.approx(24 - k * 0.5 / 3.0, abs=0.3)
    assert cy == pytest.approx(20 - k * 0.4 / 3.0, abs=0.3)


def disc_stats(img, mask, xs, ys):
    w = np.where(mask, img, 0.0)
    total = w.sum()
    cx, cy = (w * xs).sum() / total, (w * ys).sum() / total
    m2 = (w * ((xs - cx) ** 2 + (ys - cy) ** 2)).sum() / total
    return cx, cy, m2, total


@pytest.fixture(scope="module")
def coc_render():
    f, a, focus = 50.0, 150.0, 1.0  # a huge aperture: discs of 10-14 px at 64 px
    cam = {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": f,
           "aperture_radius_mm": a, "focus_distance_m": focus, "sensor_width_mm": 36.0}
    lens = make_scene(cam, [{"type": "sphere", "center": [0, 0, 3], "radius": 0.1,
                             "emitter": {"radiance": [1, 1, 1]}}]).camera.thin_lens()
    k = W * lens.image_distance_m / (lens.sensor_width_mm / 1000)  # px per unit tangent
    points = {"background": ((20.0, 20.0), 4.0), "foreground": ((44.0, 44.0), 0.5)}
    shapes, s_px = [], {}
    for name, ((px, py), z) in points.items():
        s_px[name] = 1.2  # the emitter's own projected radius in pixels
        shapes.append({"type": "sphere", "center": [(W / 2 - px) * z / k, (W / 2 - py) * z / k, z],
                       "radius": s_px[name] * z / k, "emitter": {"radiance": [100.0, 100.0, 100.0]}})
    scene = make_scene(cam, shapes)
    img = render_reference(scene, spp=4096, progress=False)[..., 0].astype(np.float64)
    return scene, lens, points, s_px, img


@pytest.mark.parametrize("name", ["background", "foreground"])
def test_thin_lens_coc_matches_mitsuba_thinlens(coc_render, name):
    scene, lens, points, s_px, img = coc_render
    (px, py), z = points[name]
    ys, xs = np.mgrid[0:W, 0:W] + 0.5
    side = (xs + ys < W) if name == "background" else (xs + ys > W)
    cx, cy, m2, total = disc_stats(img, side, xs, ys)
    assert total > 0
    # A uniform disc of radius R has E[r^2] = R^2 / 2; the emitter's own disc adds s^2 / 2 and the
    # box pixel 1/12 per axis.
    r_measured = math.sqrt(2 * (m2 - s_px[name] ** 2 / 2 - 1 / 6))
    r_expected = abs(float(lens.coc_radius_px(z, W)))
    assert r_expected > 10
    # 1 %: the moment of a 4096-spp disc and the emitter's own spread (modelled as a uniform disc)
    # leave 0.3 % (background) and 0.14 % (foreground) measured; was 1 px (7-10 %), which let a
    # 5 % CoC error through. A camera whose CoC were 2 % or 5 % off now fails:
    assert r_measured == pytest.approx(r_expected, rel=0.01)
    for wrong in (0.95, 0.98, 1.02, 1.05):
        assert r_measured != pytest.approx(wrong * r_expected, rel=0.01)
    # Centred on the pinhole projection, and really a disc: nearly all energy inside R + s + 1,
    # and a flat top: the mean inside R - s - 1 is the total spread over pi R^2.
    assert (cx, cy) == (pytest.approx(px, abs=0.4), pytest.approx(py, abs=0.4))  # ~2 sigma of noise is 0.2
    r = np.hypot(xs - cx, ys - cy)
    assert img[side & (r < r_expected + s_px[name] + 1)].sum() > 0.98 * total
    inner = img[side & (r < r_expected - s_px[name] - 1)].mean()
    assert inner == pytest.approx(total / (math.pi * r_expected ** 2), rel=0.15)
