"""The tilted-sensor Mitsuba reference (Scheimpflug) against the runtime's per-pixel focus: its rays
of one film point meet on the chief ray at the depth the runtime's map gives, its chief rays are the
pinhole input's, and a textured plane lying on the focal plane renders as sharp as the pinhole image
(and visibly blurred through the untilted lens of the same axial focus)."""
import numpy as np
import pytest

from lab.reference.backend import mitsuba
from lab.reference.mitsuba_scene import scene_dict
from lab.reference.render import render_pinhole, render_reference
from lab.scene import parse_scene
from runtime_cl.camera.focal_surface import scheimpflug_tilt

W, H = 48, 36


def scene_with(focus_m, tilt, f_number=0.5, shapes=()):
    cam = {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50.0,
           "f_number": f_number, "focus_distance_m": focus_m, "sensor_width_mm": 36.0,
           "sensor_tilt_deg": list(tilt)}
    return parse_scene({"scene": {"name": "tilt", "resolution": [W, H]}, "camera": cam,
                        "render": {"max_depth": 2, "seed": 3},
                        "materials": {"checks": {"checkerboard": {"color0": [0.9, 0.9, 0.9],
                                                                  "color1": [0.05, 0.05, 0.05], "scale": 24.0}}},
                        "shapes": list(shapes), "emitters": [{"type": "constant", "radiance": [1.0, 1.0, 1.0]}]},
                       "tilt.toml")


def test_rays_of_a_film_point_meet_where_the_runtime_focuses():
    scene = scene_with(0.8, (6.0, -4.0))
    lens = scene.camera.runtime_camera()
    mi = mitsuba()
    sensor = mi.load_dict(scene_dict(scene, "scene")["sensor"])
    pinhole = mi.load_dict(scene_dict(scene, "pinhole")["sensor"])
    inv_focus = lens.inverse_focus_map(H, W)
    for x, y in [(0, 0), (47, 35), (30, 8), (5, 30)]:
        film = mi.Point2f((x + 0.5) / W, (y + 0.5) / H)
        origins, dirs = [], []
        for u, v in [(0.5, 0.5), (0.1, 0.5), (0.9, 0.2), (0.4, 0.95)]:
            ray, weight = sensor.sample_ray(0.0, 0.5, film, mi.Point2f(u, v))
            origins.append(np.array(ray.o, np.float64).ravel())
            dirs.append(np.array(ray.d, np.float64).ravel())
            assert float(np.array(weight).ravel()[0]) == 1.0
        chief, _ = pinhole.sample_ray(0.0, 0.5, film, mi.Point2f(0.5, 0.5))
        np.testing.assert_allclose(dirs[0], np.array(chief.d).ravel(), atol=1e-6)   # the pinhole's pixel
        # Where each ray reaches the depth of the runtime's focus for this pixel (float32 rays).
        z = 1.0 / inv_focus[y, x]
        points = [o + (z - o[2]) / d[2] * d for o, d in zip(origins, dirs)]
        spread = max(np.linalg.norm(p - points[0]) for p in points)
        off = max(np.linalg.norm((o + (1.3 * z - o[2]) / d[2] * d) - (origins[0] + (1.3 * z - origins[0][2])
                                                                         / dirs[0][2] * dirs[0]))
                  for o, d in zip(origins, dirs))
        assert spread < 2e-5 * z and off > 1e-3, (x, y, spread, off)


@pytest.fixture(scope="module")
def renders():
    """A fine checkerboard on a plane turned 35 degrees about the vertical, 0.5 to 1 m away; the
    sensor tilted to focus it (its plane, from the shape's own placement)."""
    board = {"type": "rectangle", "material": "checks", "center": [0.0, 0.0, 0.8], "scale": [1.0, 1.0, 1.0],
             "rotate": [0.0, 215.0, 0.0]}
    m = scene_with(1.0, (0.0, 0.0), shapes=[board]).shapes[0].to_world_matrix()
    normal_world = m[:3, 2] / np.linalg.norm(m[:3, 2])
    normal = normal_world * np.array([-1.0, 1.0, 1.0])             # camera space: image-right is world -x
    focus, tilt = scheimpflug_tilt(normal, float(normal_world @ m[:3, 3]), 0.05)
    tilted = scene_with(focus, tilt, f_number=0.25, shapes=[board])
    flat = scene_with(focus, (0.0, 0.0), f_number=0.25, shapes=[board])
    return (render_pinhole(tilted, spp=256, progress=False), render_reference(tilted, spp=256, progress=False),
            render_reference(flat, spp=256, progress=False), tilted.camera.runtime_camera(), tilt)


def test_a_plane_on_the_focal_plane_is_sharp_in_the_reference(renders):
    pinhole, tilted, flat, lens, tilt = renders
    assert abs(tilt[0]) > 2.0 and abs(tilt[1]) < 1e-9
    assert np.abs(lens.coc_radius_px(np.full((H, W), 0.8), W)).max() > 1.5    # the tilt matters: an upright plane at 0.8 m blurs at the sides
    # 0.03: the noise of 2 x 256 samples per pixel at checker edges (pixels straddling an edge)
    assert np.abs(tilted - pinhole).mean() < 0.03
    assert np.abs(flat - pinhole).mean() > 3 * np.abs(tilted - pinhole).mean()
