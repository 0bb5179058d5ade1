"""The guard band (LSR18 "Boundary"): render the labelled input beyond the frame.

Splatting spreads only the pixels it has, so near the frame's border the blur of what lies just
outside the frame is missing (a bright light beside the frame should bleed in). The input is
therefore rendered with a margin of the largest CoC radius plus half the largest motion on
every side: the same camera with a sensor wider by the margin's share and the same pixel pitch,
so every frame pixel and its CoC stay where they were. The runtime renders the whole and crops
the margin (:meth:`runtime_cl.frame.Frame.crop`); the EXR says how wide it is (header
``splatlab.guard_px``) and its camera header describes the widened sensor.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import UserError

__all__ = ["guard_margin", "guarded_scene"]


def guard_margin(scene, mi_scene) -> int:
    """Margin in pixels: ceil(largest |CoC| + half the largest motion) over the frame's pixel centres."""
    from ..motion import mid_shutter, scene_moves
    from .labelled import pixel_centre_hits, planar_depth
    from .motion import motion_vectors

    moves = scene_moves(scene)
    points, valid, shape_ids = pixel_centre_hits(scene, mi_scene, shapes=True)
    z = planar_depth(scene, hits=(points, valid), t=mid_shutter(scene.camera) if moves else 0.0)
    coc = np.abs(scene.camera.runtime_camera().coc_radius_px(z, scene.width))
    motion = 0.0
    if moves:
        flow = motion_vectors(scene, mi_scene, points, valid, shape_ids)
        motion = float(np.hypot(flow[..., 0], flow[..., 1]).max())
    return int(math.ceil(float(coc.max()) + 0.5 * motion))


def guarded_scene(scene, margin: int):
    """``scene`` seen through a sensor ``margin`` pixels wider on every side (same pixel pitch)."""
    w, h = scene.width, scene.height
    if margin < 0:
        raise UserError(f"guard band: margin {margin} px must be >= 0")
    sensor = scene.camera.sensor_width_mm * (w + 2 * margin) / w
    return replace(scene, info=replace(scene.info, resolution=(w + 2 * margin, h + 2 * margin)),
                   camera=replace(scene.camera, sensor_width_mm=sensor))
