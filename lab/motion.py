"""A scene's motion: rigid motion of shapes and linear motion of the camera over the shutter.

Units: positions in metres, times in the unit of ``[camera] shutter = [open, close]`` (default
``[0, 1]``), ``velocity`` in metres per time unit, ``angular_velocity_deg`` in degrees per time
unit. What a scene file places (``center``, ``to_world``, the camera ``position``) is where it
is at time 0; at time t a shape has moved by ``velocity * t`` and turned by the rotation vector
``angular_velocity_deg * t`` about an axis through its centre (the translation of its
``to_world``), and the camera has moved by its ``velocity * t`` (its view direction stays).

The labelled-pixel input shows the scene at mid-shutter; its motion vectors are the chord of
each surface point's image from shutter open to shutter close. A rotating point's image moves
on a curve: the runtime's PSFs are linear, so the chord is the linear motion per pixel (its
length 2 r sin(theta / 2) against the arc r theta: 1 % short at theta = 28 degrees).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import UserError

__all__ = ["check_vector", "rigid_motion", "scene_moves", "mid_shutter", "describe_motion", "read_motion"]


def check_vector(key: str, value) -> None:
    """UserError unless ``value`` is None or three finite numbers."""
    if value is not None and not (len(value) == 3 and all(math.isfinite(v) for v in value)):
        raise UserError(f"{key} = {list(value)!r} must be three finite numbers, e.g. {key} = [0.5, 0, 0]")


def rigid_motion(centre, velocity, angular_velocity_deg, t: float) -> np.ndarray:
    """The 4x4 world-space motion at time t: turn about ``centre`` by ``angular_velocity_deg * t``,
    then move by ``velocity * t``. Identity at t = 0; ``None`` velocities are zero."""
    m = np.eye(4)
    c = np.asarray(centre, dtype=np.float64)
    if angular_velocity_deg is not None:
        r = Rotation.from_rotvec(np.radians(np.asarray(angular_velocity_deg, dtype=np.float64)) * t).as_matrix()
        m[:3, :3] = r
        m[:3, 3] = c - r @ c
    if velocity is not None:
        m[:3, 3] += np.asarray(velocity, dtype=np.float64) * t
    return m


def mid_shutter(camera) -> float:
    """The time the labelled input shows: the middle of the camera's shutter."""
    return 0.5 * (camera.shutter[0] + camera.shutter[1])


def _nonzero(v) -> bool:
    return v is not None and any(x != 0.0 for x in v)


def scene_moves(scene) -> bool:
    """Whether anything moves while the shutter is open (a shape or the camera, and open < close)."""
    open_, close = scene.camera.shutter
    if close <= open_:
        return False
    return _nonzero(scene.camera.velocity) or any(_nonzero(s.velocity) or _nonzero(s.angular_velocity_deg)
                                                  for s in scene.shapes)


def describe_motion(scene) -> str:
    """One line for the plan's effects: what moves, over which shutter."""
    if not scene_moves(scene):
        return "none"
    moving = [i + 1 for i, s in enumerate(scene.shapes) if _nonzero(s.velocity) or _nonzero(s.angular_velocity_deg)]
    parts = []
    if moving:
        turning = sum(_nonzero(scene.shapes[i - 1].angular_velocity_deg) for i in moving)
        parts.append(f"{len(moving)} moving shape(s), {turning} turning")
    if _nonzero(scene.camera.velocity):
        parts.append(f"camera velocity {list(scene.camera.velocity)} m per time unit")
    o, c = scene.camera.shutter
    return f"linear per pixel ({', '.join(parts)}; shutter [{o:g}, {c:g}])"


def read_motion(image, path, model: str) -> np.ndarray:
    """The labelled image's per-pixel motion (H, W, 2): channels ``motion.X``, ``motion.Y`` in pixels
    over the shutter, X right, Y up (what a ``model`` database needs)."""
    missing = [c for c in ("motion.X", "motion.Y") if c not in image.extra]
    if missing:
        raise UserError(f"{path}: channel(s) {missing} missing; a {model!r} database needs per-pixel motion "
                        "(motion.X, motion.Y: pixels over the shutter, Y up); write them into the EXR")
    return np.stack([image.extra["motion.X"], image.extra["motion.Y"]], axis=-1)
