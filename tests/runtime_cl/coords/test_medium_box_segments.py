"""Each pixel's segment inside a box of medium (runtime_cl.coords.medium_box) against a brute-force
numpy march along the ray, and the box's camera frame (lab.medium_box) against Mitsuba's look_at."""
import numpy as np
import pytest

from runtime_cl.camera.pinhole import Pinhole
from runtime_cl.coords.medium_box import box_segments, pixel_rays


def random_box(rng) -> dict:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))           # a random orthonormal frame
    return {"center": list(rng.uniform([-1, -1, 1], [1, 1, 5])), "axes": q.tolist(),
            "half_size": list(rng.uniform(0.2, 1.5, 3))}


def brute_force(directions, distance, box, steps=20000):
    """Length of each ray's part inside the box, and its first inside point, by testing ``steps``
    points (midpoints of equal steps) along [0, distance]."""
    axes, c, h = np.asarray(box["axes"]), np.asarray(box["center"]), np.asarray(box["half_size"])
    s = (np.arange(steps) + 0.5) / steps
    t = distance[..., None] * s                                       # (..., steps)
    p = directions[..., None, :] * t[..., None]                       # (..., steps, 3)
    local = (p - c) @ axes.T
    inside = np.all(np.abs(local) < h, axis=-1)
    length = inside.mean(axis=-1) * distance
    first = np.where(inside.any(axis=-1), t[np.arange(len(t)), inside.argmax(axis=-1)], np.nan)
    return length, first


@pytest.mark.parametrize("seed", range(4))
def test_segments_match_a_brute_force_march(seed):
    rng = np.random.default_rng(seed)
    box = random_box(rng)
    d = rng.normal(size=(400, 3)) * [0.4, 0.4, 1.0] + [0, 0, 1.5]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    distance = rng.uniform(0.5, 8.0, 400)
    t0, t1 = box_segments(d, distance, box)
    length, first = brute_force(d, distance, box)
    # a march of 20000 steps resolves each end to distance / 20000 (<= 0.4 mm); 1 mm covers both
    assert np.all(t1 >= t0) and np.all(t0 >= 0) and np.all(t1 <= distance)
    assert np.abs((t1 - t0) - length).max() < 1e-3
    hit = ~np.isnan(first)
    assert np.abs(t0[hit] - first[hit]).max() < 1e-3
    assert 40 < hit.sum() < 400                                         # the draw covers hits and misses


def test_rays_parallel_to_a_face_and_points_inside_the_box():
    """A ray along a slab (u = 0 on an axis) is inside it or never; a ray ending inside the box stops
    there (t1 = distance); the camera inside the box starts at t0 = 0."""
    box = {"center": [0.0, 0.0, 3.0], "axes": np.eye(3).tolist(), "half_size": [0.5, 0.5, 1.0]}
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    distance = np.array([10.0, 2.5, 4.0])
    t0, t1 = box_segments(d, distance, box)
    assert np.allclose(t0[:2], [2.0, 2.0]) and np.allclose(t1[:2], [4.0, 2.5])
    assert t1[2] == t0[2]                                    # along x at z = 0: it never meets the box
    inside = dict(box, center=[0.0, 0.0, 0.5])
    t0, t1 = box_segments(d[:1], np.array([5.0]), inside)
    assert t0[0] == 0.0 and t1[0] == pytest.approx(1.5)
    beside = dict(box, center=[0.5, 0.0, 3.0])           # the ray runs along the face x = 0: outside
    t0, t1 = box_segments(d[:1], np.array([10.0]), dict(beside, center=[0.5000001, 0.0, 3.0]))
    assert t1[0] - t0[0] == 0.0


def test_pixel_rays_reach_the_distance_the_volume_model_uses():
    from runtime_cl.coords.lens import light_distance

    cam = Pinhole(fov_deg=40.0)
    z = np.random.default_rng(1).uniform(1, 7, (8, 12))
    d, dist = pixel_rays(cam, z)
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    assert np.allclose(dist, light_distance(cam, z))
    assert np.allclose(d[..., 2] * dist, z)                 # planar depth along the axis


def test_the_box_in_the_camera_frame_follows_mitsubas_look_at():
    """lab.medium_box.camera_frame against Mitsuba's own look_at transform: a world point maps to
    the camera frame (x right = -Mitsuba's local x, y up, z forward)."""
    mi = pytest.importorskip("mitsuba")
    from lab.cameras.pinhole import PinholeCamera
    from lab.medium_box import MediumBox, camera_frame
    from lab.reference.backend import mitsuba

    mitsuba()
    cam = PinholeCamera(model="pinhole", position=(0.3, 0.6, -0.2), look_at=(-0.5, 0.4, 4.0), up=(0.1, 1.0, 0.0),
                        fov_deg=40.0)
    box = MediumBox(center=(-0.6, 0.9, 2.75), size=(1.4, 1.2, 1.5))
    frame = camera_frame(box, cam)
    to_world = mi.ScalarTransform4f().look_at(origin=list(cam.position), target=list(cam.look_at), up=list(cam.up))
    local = np.array(to_world.inverse() @ mi.ScalarPoint3f(*box.center))
    assert np.allclose(frame["center"], [-local[0], local[1], local[2]], atol=1e-5)
    corner = np.add(box.center, [0.7, -0.6, 0.75])          # +x, -y, +z corner: centre + axes . half
    local = np.array(to_world.inverse() @ mi.ScalarPoint3f(*corner))
    axes = np.asarray(frame["axes"])
    assert np.allclose(np.asarray(frame["center"]) + axes.T @ [0.7, -0.6, 0.75], [-local[0], local[1], local[2]],
                       atol=1e-5)


def test_segments_match_mitsubas_own_intersections_with_the_reference_cube():
    """Every pixel-centre ray of scenes/tiny_fogbox.toml, cut by the header's box, against Mitsuba
    intersecting the same rays with the reference's cube (lab.reference.mitsuba_scene): the lengths
    inside agree to 1e-4 m (float32 ray tracing), so the runtime's segments are the reference's."""
    pytest.importorskip("mitsuba")
    from lab.medium_box import camera_frame
    from lab.paths import SCENES
    from lab.reference.backend import mitsuba
    from lab.reference.mitsuba_scene import _box_boundary, sensor_dict
    from lab.scene import load_scene

    mi = mitsuba()
    s = load_scene(SCENES / "tiny_fogbox.toml")
    cube = {**_box_boundary(s.medium.box), "bsdf": {"type": "diffuse"}}
    cube.pop("interior")
    scene = mi.load_dict({"type": "scene", "box": cube, "sensor": sensor_dict(s, "pinhole", 1)})
    h, w = s.height, s.width
    yy, xx = np.mgrid[:h, :w]
    u = mi.Point2f(((xx + 0.5) / w).ravel(), ((yy + 0.5) / h).ravel())
    ray, _ = scene.sensors()[0].sample_ray(0.0, 0.5, u, mi.Point2f(0.5, 0.5))
    first = scene.ray_intersect(ray)
    second = scene.ray_intersect(mi.Ray3f(first.p + ray.d * 1e-4, ray.d))
    hit = np.asarray(first.is_valid())
    mi_length = np.where(hit, np.asarray(second.t) + 1e-4, 0.0).reshape(h, w)
    d, _ = pixel_rays(s.camera.runtime_camera(), np.ones((h, w)))
    t0, t1 = box_segments(d, np.full((h, w), 1e3), camera_frame(s.medium.box, s.camera))
    assert 0.2 < hit.mean() < 0.8
    np.testing.assert_allclose(t1 - t0, mi_length, atol=1e-4)
