"""Moving scenes in Mitsuba: the animated scene against the same scene built still at that time,
motion vectors against the projection of each point's path, and the sub-frame reference."""
from dataclasses import replace

import numpy as np
import pytest

from lab.paths import SCENES
from lab.reference.labelled import pixel_centre_hits, render_labelled
from lab.reference.motion import Animator, MotionJob, project, subframes_for
from lab.reference.passes import RenderJob
from lab.reference.render import load
from lab.scene import load_scene


@pytest.fixture(scope="module")
def moving():
    """tiny_motion at 32x32: a spinning, translating sphere, a turning cube (a mesh), rising and
    drifting spheres."""
    scene = load_scene(SCENES / "tiny_motion.toml")
    return replace(scene, info=replace(scene.info, resolution=(32, 32)))


def frozen_at(scene, t):
    """The scene built still, every shape placed where it is at time t (to_world), the camera too."""
    shapes = tuple(replace(s, to_world=tuple(map(tuple, s.to_world_at(t))), center=None, radius=None,
                           scale=None, rotate=None, velocity=None, angular_velocity_deg=None)
                   for s in scene.shapes)
    cam = scene.camera
    camera = replace(cam, position=tuple(cam.position_at(t)),
                     look_at=tuple(np.add(cam.look_at, cam.position_at(t) - np.asarray(cam.position))),
                     velocity=None)
    return replace(scene, shapes=shapes, camera=camera)


@pytest.mark.parametrize("t", [0.0, 0.7])
def test_the_animated_scene_is_the_scene_built_still_at_that_time(moving, t):
    """Sub-frame t of a moving scene (spheres by to_world, the cube's mesh by its vertices, the
    camera by its sensor) renders the same pixels, with the same seed, as the scene placed
    still where everything is at t."""
    scene = replace(moving, camera=replace(moving.camera, velocity=(0.05, 0.02, 0.1)))
    job = MotionJob(scene, 4, "input", "pinhole", subframes=1)
    one = replace(job.passes()[0], variant=(("time", t),))
    animated = job.render(one)
    still = frozen_at(scene, t)
    points, valid = pixel_centre_hits(scene, job.mitsuba_scene())
    still_points, still_valid = pixel_centre_hits(still)
    np.testing.assert_array_equal(valid, still_valid)
    np.testing.assert_allclose(points[valid], still_points[valid], atol=1e-4)   # float32 geometry
    np.testing.assert_allclose(animated, RenderJob(still, 4, "input", "pinhole").render(one), atol=1e-3)


@pytest.mark.parametrize("aperture", [{"blades": 6}, {"shape": "star"}])
def test_a_moving_camera_moves_the_shaped_aperture_sensor_too(moving, aperture):
    """The reference of a moving thin lens with an iris or a shape renders through a Python
    sensor (lab.reference.aperture_lens), which must list its to_world for the sub-frames to
    move it: sub-frame t renders as the still scene placed at t does."""
    scene = replace(moving, camera=replace(moving.camera, velocity=(0.05, 0.02, 0.1), aperture=aperture))
    job = MotionJob(scene, 4, "reference", "scene", subframes=1)
    one = replace(job.passes()[0], variant=(("time", 0.7),))
    animated = job.render(one)
    still = RenderJob(frozen_at(scene, 0.7), 4, "reference", "scene").render(one)
    np.testing.assert_allclose(animated, still, atol=1e-3)
    assert np.abs(animated - RenderJob(scene, 4, "reference", "scene").render(one)).max() > 0.05


def test_pixel_centre_hits_project_back_to_their_pixels(moving):
    scene = replace(moving, camera=replace(moving.camera, velocity=(0.05, 0.0, 0.1)))
    mi_scene = load(scene, "pinhole")
    Animator(scene, mi_scene).set_time(0.5)
    points, valid = pixel_centre_hits(scene, mi_scene)
    xy = project(scene, points, 0.5)
    ys, xs = np.nonzero(valid)
    np.testing.assert_allclose(xy[valid], np.stack([xs + 0.5, ys + 0.5], axis=-1), atol=2e-3)


def test_motion_vectors_follow_a_translating_sphere(moving):
    """The green sphere rises 0.25 m over the shutter: the point seen at its centre pixel, at
    planar depth z, moves up on screen by focal_px * (v . camera up) / z (to first order in the
    small step along the view axis), and not sideways."""
    image = render_labelled(moving, spp=1, progress=False)
    cam = moving.camera
    focal_px = 0.5 * moving.width / np.tan(np.radians(cam.fov_x_deg()) / 2)
    left = np.cross(cam.up, cam.forward())
    up = np.cross(cam.forward(), left / np.linalg.norm(left))
    green = moving.shapes[4]
    mid = np.asarray(green.center) + 0.5 * np.asarray(green.velocity)
    x, y = project(moving, mid[None], 0.5)[0]
    flow = np.stack([image.extra["motion.X"], image.extra["motion.Y"]], axis=-1)
    centre, z = flow[int(y), int(x)], image.depth[int(y), int(x)]
    assert centre[1] == pytest.approx(focal_px * (np.asarray(green.velocity) @ up) / z, rel=0.02)
    assert abs(centre[0]) < 0.02 * centre[1]
    assert np.all(flow[~np.isfinite(image.depth)] == 0)             # the sky does not move


def test_the_subject_moves_left_on_screen_when_it_moves_along_world_plus_x(moving):
    """Mitsuba's look-at frame puts world +x on the image's left: X < 0 for velocity +x."""
    still = [replace(s, velocity=None, angular_velocity_deg=None) for s in moving.shapes]
    still[2] = replace(still[2], velocity=(0.1, 0.0, 0.0))
    image = render_labelled(replace(moving, shapes=tuple(still)), spp=1, progress=False)
    mx = image.extra["motion.X"]
    assert mx.min() < -1.0 and mx.max() <= 1e-6


def test_subframes_and_their_passes(moving):
    assert subframes_for(0.0) == 1 and subframes_for(17.8) == 18 and subframes_for(4.0, 0.5) == 8
    job = MotionJob(moving, 10, subframes=4)
    passes = job.passes()              # 3 spp per sub-frame, as power-of-two passes 2 + 1
    assert [p.get("time") for p in passes] == [0.125, 0.125, 0.375, 0.375, 0.625, 0.625, 0.875, 0.875]
    assert [p.spp for p in passes] == [2, 1] * 4 and len({p.seed for p in passes}) == 8
    assert [p.index for p in passes] == list(range(8))
    shutter = replace(moving, camera=replace(moving.camera, shutter=(-1.0, 1.0)))
    assert MotionJob(shutter, 4, subframes=2).times() == [-0.5, 0.5]


def test_twice_the_subframes_changes_the_reference_by_less_than_its_noise(moving):
    """The stepping check: n sub-frames (one per pixel of motion) against 2n, both at the same
    spp, differ by no more than two seeds of the n-sub-frame reference do."""
    image = render_labelled(moving, spp=1, progress=False)
    n = subframes_for(float(np.hypot(image.extra["motion.X"], image.extra["motion.Y"]).max()))
    spp = 4 * n

    def ref(subframes, seed):
        scene = replace(moving, render=replace(moving.render, seed=seed))
        return MotionJob(scene, spp, subframes=subframes).run(progress=False)

    a, b, fine = ref(n, 1), ref(n, 2), ref(2 * n, 1)
    noise = np.abs(a - b).mean()
    assert np.abs(fine - b).mean() <= 1.1 * noise
