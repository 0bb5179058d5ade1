"""Motion over the shutter in Dr.Jit: linear motion of constant projected speed (LSR18's Combined).

A point moves along a straight line in the image at constant speed while a box shutter is open
(time t uniform in [0, 1)); ``length_px`` is the distance it travels in image pixels, the
labelled-pixel image's ``|motion|``. The displacement is measured from the point's position at
mid-shutter, so a motion-blurred PSF is centred on the pixel that shows the point at t = 1/2 and
is point-symmetric in time: a runtime whose pixels hold the position at shutter open shifts the
splat by half the motion vector.

For a thin lens this image-space model is exact for lateral object motion at constant depth:
the paraxial map is linear, so moving the object point shifts every lens ray's sensor hit by the
chief ray's shift, ``v * displacement / z`` on the sensor (:func:`chief_ray_shift_px`), whatever
the lens point; defocus and motion add. Motion in depth (changing CoC) is not modelled.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from drjit.llvm import Array2f

from lab.errors import UserError

__all__ = ["LinearMotion", "chief_ray_shift_px", "offset_along_px"]


@dataclass(frozen=True)
class LinearMotion:
    """Straight-line motion along ``direction_deg``, centred on the mid-shutter position.

    Parameters
    ----------
    direction_deg : float, default 0
        Direction of motion, degrees counter-clockwise from image +x (right), with y up; 90 moves
        the point up the image (towards row 0).
    """

    direction_deg: float = 0.0

    def __post_init__(self):
        d = self.direction_deg
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d):
            raise UserError(f"motion_direction_deg = {d!r}: must be a finite angle in degrees")

    @property
    def unit_px(self) -> tuple[float, float]:
        """Unit direction in image pixel axes (column right, row down)."""
        a = math.radians(self.direction_deg)
        return math.cos(a), -math.sin(a)

    def offset_px(self, t, length_px) -> Array2f:
        """Displacement at shutter time ``t`` in [0, 1) for a travel of ``length_px`` pixels
        (Dr.Jit Floats), in image pixels (column, row) from the mid-shutter position."""
        a = math.radians(self.direction_deg)
        return offset_along_px(t, length_px, math.cos(a), math.sin(a))

    def offset_px_np(self, t, length_px) -> tuple[np.ndarray, np.ndarray]:
        """numpy mirror of :meth:`offset_px`: (column, row) arrays."""
        dx, dy = self.unit_px
        s = (np.asarray(t, dtype=np.float64) - 0.5) * np.asarray(length_px, dtype=np.float64)
        return s * dx, s * dy


def offset_along_px(t, length_px, cos, sin) -> Array2f:
    """:meth:`LinearMotion.offset_px` along a direction given per ray by the ``cos`` and ``sin`` of
    its angle (counter-clockwise from image +x, y up): image pixels (column, row)."""
    s = (t - 0.5) * length_px
    return Array2f(s * cos, -s * sin)


def chief_ray_shift_px(lens, width_px: int, lateral_m, inv_depth):
    """Image shift in pixels (x right, y up) of a point at 1/z = ``inv_depth`` moved laterally by
    ``lateral_m`` metres (x right, y up, as seen from the camera): ``k v * lateral / z``.

    ``lens`` is a :class:`lab.optics.thin_lens.ThinLens`; works on numpy or Dr.Jit values. It
    converts object motion to the ``length_px`` of :class:`LinearMotion`.
    """
    return lateral_m * inv_depth * (lens.pixels_per_metre(width_px) * lens.image_distance_m)
