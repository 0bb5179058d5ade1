"""``[medium] box = { center = [x, y, z], size = [sx, sy, sz] }``: the medium fills an axis-aligned box.

Three things need the box: the labelled input's header (the box in the camera's frame, so the
runtime, which has no world, finds each pixel's segment inside it:
:func:`runtime_cl.coords.medium_box.box_segments`), the Mitsuba reference (a ``cube`` with a
``null`` BSDF and the medium as its interior, :mod:`lab.reference.mitsuba_scene`) and its check
that every shape lies wholly inside or wholly outside the box (Mitsuba gives a surface the medium
of its own ``exterior``; a shape crossing the box's wall would have it on one side only).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import UserError

__all__ = ["MediumBox", "camera_frame"]

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class MediumBox:
    """An axis-aligned box of medium: ``center`` and edge lengths ``size`` in metres (world axes)."""

    center: Vec3
    size: Vec3

    def __post_init__(self):
        for key in ("center", "size"):
            v = getattr(self, key)
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v):
                raise UserError(f"{key} = {list(v)!r}: give three finite numbers in metres")
        if not all(s > 0 for s in self.size):
            raise UserError(f"size = {list(self.size)!r}: every edge length must be > 0 metres "
                            "(leave out box for a medium filling the scene)")

    @property
    def lo(self) -> np.ndarray:
        return np.subtract(self.center, np.multiply(self.size, 0.5))

    @property
    def hi(self) -> np.ndarray:
        return np.add(self.center, np.multiply(self.size, 0.5))

    def contains(self, point) -> bool:
        """Whether ``point`` (world, metres) lies strictly inside the box."""
        p = np.asarray(point, np.float64)
        return bool(np.all(p > self.lo) and np.all(p < self.hi))

    def side_of(self, corners: np.ndarray) -> str:
        """``"inside"``, ``"outside"`` or ``"across"`` for a shape bounded by the points ``corners``
        (N, 3): by their axis-aligned bounds, so a rotated shape near the wall may read "across"."""
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        if np.all(lo > self.lo) and np.all(hi < self.hi):
            return "inside"
        if np.any(hi <= self.lo) or np.any(lo >= self.hi):
            return "outside"
        return "across"

    def describe(self) -> str:
        return f"in a box centred at {list(self.center)} m of size {list(self.size)} m"


# Object-space z extent of each Mitsuba shape type (x and y span [-1, 1]): flat ones lie at z = 0.
_Z_EXTENT = {"sphere": (-1.0, 1.0), "cube": (-1.0, 1.0), "rectangle": (0.0, 0.0), "disk": (0.0, 0.0)}


def shape_corners(shape) -> np.ndarray:
    """(8, 3): the world corners of the shape's object-space bounds ([-1, 1]^2 x its z extent)."""
    c = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in _Z_EXTENT[shape.type]])
    return (c @ shape.to_world_matrix().T)[:, :3]


def camera_frame(box: MediumBox, camera) -> dict:
    """The box in the camera's frame (x right, y up, z along the optical axis; metres): ``center``,
    ``axes`` (the box's x, y, z edge directions as rows) and ``half_size``, as the input header and
    the ``volume_box`` database store it.

    Mitsuba's ``look_at`` (the reference's and the input's sensor): ``left = up x forward``, image
    +x is -left; camera up = forward x left.
    """
    forward = camera.forward()
    left = np.cross(camera.up, forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    rot = np.stack([-left, up, forward])           # world -> camera
    center = rot @ (np.asarray(box.center, np.float64) - np.asarray(camera.position, np.float64))
    return {"center": [float(v) for v in center], "axes": [[float(v) for v in row] for row in rot.T],
            "half_size": [0.5 * float(s) for s in box.size]}


def shapes_inside(box: MediumBox, shapes, source: str) -> list[bool]:
    """Per shape: whether it lies inside the box (its surface then borders the medium). A shape across
    the box's wall would have the medium on one side only in Mitsuba: a UserError naming it."""
    sides = [box.side_of(shape_corners(shape)) for shape in shapes]
    for i, side in enumerate(sides):
        if side == "across":
            raise UserError(f"{source} [[shapes]] #{i + 1} ({shapes[i].type}) crosses the wall of [medium] box "
                            f"(centre {list(box.center)}, size {list(box.size)}); move it wholly inside or outside "
                            "the box (its bounds decide), or resize the box")
    return [side == "inside" for side in sides]
