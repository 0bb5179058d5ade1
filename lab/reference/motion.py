"""Moving scenes in Mitsuba: the scene at any shutter time, motion vectors, and the sub-frame
motion-blur reference.

Mitsuba 3.9.1 cannot blur moving shapes (``shutter_open/close`` only stamp the ray time), so the
reference accumulates *sub-frames*: the shutter is cut into n equal slices, and each slice's
midpoint is rendered with its own seed after :class:`Animator` moves the shapes and the camera
there through ``mi.traverse`` (the compiled kernels are reused). With the slices at most
:data:`SUBFRAME_STEP_PX` apart on screen, each copy of a moving edge lies within a pixel of
the next; the box pixel filter then averages the staircase away.

The motion vectors of the labelled input (:func:`motion_vectors`) follow each pixel centre's
surface point from shutter open to close (:mod:`lab.motion`: the chord, a linear motion per pixel).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..motion import mid_shutter
from ..scene import Scene
from .backend import mitsuba
from .passes import RenderJob, RenderPass, pass_seeds, split_spp

__all__ = ["Animator", "MotionJob", "SUBFRAME_STEP_PX", "motion_vectors", "project", "subframes_for"]

SUBFRAME_STEP_PX = 1.0   # the largest screen step between consecutive sub-frames


class Animator:
    """Moves a loaded Mitsuba scene's shapes and sensor to a shutter time.

    It reads the meshes' vertices and the sensor's transform as they are when it is made, as
    time 0: make one per freshly loaded scene (a second one on a moved scene would move it twice).

    Parameters
    ----------
    scene : Scene
        The scene the Mitsuba scene was loaded from (:func:`lab.reference.mitsuba_scene.scene_dict`:
        shape ``i`` is ``shape_i``).
    mi_scene : mitsuba.Scene
    """

    def __init__(self, scene: Scene, mi_scene):
        mi = mitsuba()
        self.scene, self.mi_scene = scene, mi_scene
        self.params = mi.traverse(mi_scene)
        self.time = 0.0
        self._meshes = {}
        for i, shape in enumerate(scene.shapes):
            key = f"shape_{i}.vertex_positions"
            if key in self.params:   # a mesh (cube): its vertices are world-space at time 0
                normals = self.params.get(f"shape_{i}.vertex_normals")
                self._meshes[i] = (np.asarray(self.params[key], dtype=np.float64).reshape(-1, 3),
                                   None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3))
        # (4, 4, 1): a JIT variant's matrix holds one transform
        self._sensor0 = np.asarray(self.params["sensor.to_world"].matrix, dtype=np.float64).reshape(4, 4)

    def set_time(self, t: float) -> None:
        """Place every moving shape and the camera at time ``t`` (static ones are not touched)."""
        mi = mitsuba()
        for i, shape in enumerate(self.scene.shapes):
            if shape.velocity is None and shape.angular_velocity_deg is None:
                continue
            if i in self._meshes:
                vertices, normals = self._meshes[i]
                motion = shape.to_world_at(t) @ np.linalg.inv(shape.to_world_matrix())
                self.params[f"shape_{i}.vertex_positions"] = mi.Float(
                    (vertices @ motion[:3, :3].T + motion[:3, 3]).astype(np.float32).ravel())
                if normals is not None:
                    self.params[f"shape_{i}.vertex_normals"] = mi.Float(
                        (normals @ motion[:3, :3].T).astype(np.float32).ravel())
            else:
                self.params[f"shape_{i}.to_world"] = mi.Transform4f(shape.to_world_at(t).tolist())
        if self.scene.camera.velocity is not None:
            sensor = self._sensor0.copy()
            sensor[:3, 3] = self.scene.camera.position_at(t)
            self.params["sensor.to_world"] = mi.Transform4f(sensor.tolist())
        self.params.update()
        self.time = t


def project(scene: Scene, points: np.ndarray, t: float) -> np.ndarray:
    """Pixel coordinates (x right, y down; pixel centres at i + 0.5) of world ``points`` (..., 3)
    through the pinhole of the labelled input, with the camera where it is at time ``t``."""
    cam = scene.camera
    forward = cam.forward()
    left = np.cross(np.asarray(cam.up, dtype=np.float64), forward)   # Mitsuba's look-at: +x is left
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    rel = points - cam.position_at(t)
    z = rel @ forward
    scale = 0.5 * scene.width / math.tan(math.radians(cam.fov_x_deg()) / 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = 0.5 * scene.width - scale * (rel @ left) / z
        y = 0.5 * scene.height - scale * (rel @ up) / z
    return np.stack([x, y], axis=-1)


def motion_vectors(scene: Scene, mi_scene, hits: np.ndarray, valid: np.ndarray, shape_ids: np.ndarray) -> np.ndarray:
    """(H, W, 2) float32 motion in pixels over the shutter (X right, Y up) of the labelled input.

    Parameters
    ----------
    scene : Scene
    mi_scene : mitsuba.Scene
        The pinhole scene at mid-shutter (:class:`Animator`), which ``hits`` were traced in.
    hits : (H, W, 3) float64
        World-space points seen at the pixel centres at mid-shutter.
    valid : (H, W) bool
        Where a ray hit a surface; elsewhere (the sky at infinity) the motion is 0, which a
        translating camera does not change.
    shape_ids : (H, W) uint32
        The Mitsuba shape hit at each pixel (:func:`lab.reference.labelled.pixel_centre_hits`).
    """
    mi = mitsuba()
    import drjit as dr

    t_mid = mid_shutter(scene.camera)
    t_open, t_close = scene.camera.shutter
    start, end = hits.copy(), hits.copy()
    ids = {sh.id(): int(np.asarray(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(sh)))[0])
           for sh in mi_scene.shapes()}
    for i, shape in enumerate(scene.shapes):
        if shape.velocity is None and shape.angular_velocity_deg is None:
            continue
        on = valid & (shape_ids == ids[f"shape_{i}"])
        back = np.linalg.inv(shape.to_world_at(t_mid))
        local = hits[on] @ back[:3, :3].T + back[:3, 3]            # object space
        for out, t in ((start, t_open), (end, t_close)):
            m = shape.to_world_at(t)
            out[on] = local @ m[:3, :3].T + m[:3, 3]
    flow = project(scene, end, t_close) - project(scene, start, t_open)
    flow[..., 1] *= -1.0                                            # Y up
    flow[~valid] = 0.0
    return flow.astype(np.float32)


def subframes_for(max_motion_px: float, step_px: float = SUBFRAME_STEP_PX) -> int:
    """Sub-frames so that consecutive ones lie at most ``step_px`` apart on screen (>= 1)."""
    return max(1, math.ceil(max_motion_px / step_px))


@dataclass
class MotionJob(RenderJob):
    """A render over the shutter by sub-frame accumulation.

    ``subframes`` slices of the shutter, each rendered at its midpoint with ``ceil(spp /
    subframes)`` samples (so every slice weighs the same; the total may exceed ``spp`` by less
    than ``subframes``), in seeded passes of at most :data:`~lab.reference.passes.MAX_SAMPLES_PER_PASS`.
    """

    subframes: int = 1
    _animator: object = field(default=None, init=False, repr=False, compare=False)

    def __getstate__(self):
        return super().__getstate__() | {"_animator": None}

    def times(self) -> list[float]:
        """The sub-frames' shutter times (slice midpoints)."""
        o, c = self.scene.camera.shutter
        return [o + (k + 0.5) / self.subframes * (c - o) for k in range(self.subframes)]

    @property
    def spp_per_subframe(self) -> int:
        return math.ceil(self.spp / self.subframes)

    def passes(self) -> list[RenderPass]:
        w, h = self.size
        plan = [(t, n) for t in self.times() for n in split_spp(self.spp_per_subframe, w, h, self.pass_spp,
                                                                   one_thread=self.crop is not None)]
        seeds = pass_seeds(self.scene.render.seed, self.stream, len(plan))
        return [RenderPass(i, n, s, (float(n),) * 3, (("time", t),))
                for i, ((t, n), s) in enumerate(zip(plan, seeds))]

    def render(self, p: RenderPass) -> np.ndarray:
        if self._animator is None:
            self._animator = Animator(self.scene, self.mitsuba_scene())
        if self._animator.time != p.get("time"):
            self._animator.set_time(p.get("time"))
        return super().render(p)
