"""The labelled-pixel input: pinhole colour, coverage A and planar depth Z from Mitsuba.

Z is the camera-space planar depth at each pixel centre: one ray per pixel centre from the same
``perspective`` sensor that renders the colour, ``Scene.ray_intersect``, then
Z = dot(hit - camera position, optical axis). (The sensor moves ray origins to the near-clip
plane, so the hit distance ``t`` alone is not measured from the camera; the hit point is.)
Rays that miss give Z = inf and A = 0; A = 1 where the centre ray hits a surface.
A moving scene is shown at mid-shutter, with ``motion.X``, ``motion.Y`` from
:func:`lab.reference.motion.motion_vectors`.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..exr_io import LabelledImage
from ..scene import Scene
from .backend import mitsuba
from ..motion import mid_shutter, scene_moves
from .guard_band import guard_margin, guarded_scene
from .layered import render_layers
from .peel import peel_layers
from .motion import Animator, motion_vectors
from .render import load, render_passes


def _centre_interactions(scene: Scene, mi_scene):
    """Mitsuba's surface interactions of one pinhole ray per pixel centre (row-major)."""
    mi = mitsuba()
    import drjit as dr

    w, h = scene.width, scene.height
    idx = dr.arange(mi.UInt32, w * h)
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    ray, _ = mi_scene.sensors()[0].sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
    return mi_scene.ray_intersect(ray)


def pixel_centre_hits(scene: Scene, mi_scene=None, shapes: bool = False):
    """Hit points of one pinhole ray per pixel centre.

    Returns
    -------
    points : (H, W, 3) float64
        World-space hit points (undefined where ``valid`` is False).
    valid : (H, W) bool
        True where the ray hits a surface.
    shape_ids : (H, W) uint32
        Only with ``shapes``: Mitsuba's id of the shape hit (``dr.reinterpret_array(UInt32, ShapePtr)``).
    """
    import drjit as dr

    mi_scene = load(scene, "pinhole") if mi_scene is None else mi_scene
    si = _centre_interactions(scene, mi_scene)
    h, w = scene.height, scene.width
    points = np.stack([np.asarray(si.p[i], dtype=np.float64) for i in range(3)], axis=-1).reshape(h, w, 3)
    valid = np.asarray(si.is_valid(), dtype=bool).reshape(h, w)
    if not shapes:
        return points, valid
    return points, valid, np.asarray(dr.reinterpret_array(mitsuba().UInt32, si.shape)).reshape(h, w)


def planar_depth(scene: Scene, mi_scene=None, hits=None, t: float = 0.0) -> np.ndarray:
    """(H, W) float32 planar camera depth in metres at pixel centres; ``inf`` where nothing is hit.

    ``hits``: the :func:`pixel_centre_hits` of ``mi_scene`` if already traced; ``t``: the shutter
    time the scene shows (the camera may move).
    """
    points, valid = pixel_centre_hits(scene, mi_scene) if hits is None else hits
    cam = scene.camera
    z = (points - cam.position_at(t)) @ cam.forward()
    return np.where(valid, z, np.inf).astype(np.float32)


def render_labelled(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                    progress: bool = True) -> LabelledImage:
    """Render the labelled-pixel input of ``scene``: R,G,B (path traced), A, Z, camera header.

    Parameters
    ----------
    scene : Scene
    spp : int, optional
        Colour samples per pixel; default ``scene.render.input_spp``.
    pass_spp : int, optional
        Samples per render pass (see :func:`lab.reference.render.split_spp`).
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    LabelledImage
        ``camera`` is the scene camera's JSON (a thin lens for a DoF scene: the lens the runtime
        must simulate), although the pixels themselves are pinhole. When shapes carry a
        ``layer`` key, ``extra`` also holds the layered input's ``layerN.*`` channels
        (:mod:`lab.reference.layered`, same spp); with ``[render] peel_layers``, the umbra-peeled
        layers instead (:mod:`lab.reference.peel`). With ``[render] guard_band``, the pixels
        reach beyond the frame by ``guard_px`` (:mod:`lab.reference.guard_band`).
    """
    mi_scene = load(scene, "pinhole")
    if scene.render.guard_band:   # LSR18 "Boundary": the input reaches beyond the frame
        margin = guard_margin(scene, mi_scene)
        inner = replace(scene, render=replace(scene.render, guard_band=False))
        image = render_labelled(guarded_scene(inner, margin), spp, pass_spp, progress)
        return replace(image, guard_px=margin)
    moves = scene_moves(scene)
    t = mid_shutter(scene.camera) if moves else 0.0
    if moves:
        Animator(scene, mi_scene).set_time(t)
    spp = scene.render.input_spp if spp is None else spp
    rgb = render_passes(mi_scene, spp, scene.render.seed, "input", pass_spp, progress,
                        desc=f"input {scene.name}")
    points, valid, shape_ids = pixel_centre_hits(scene, mi_scene, shapes=True)
    z = planar_depth(scene, hits=(points, valid), t=t)
    alpha = np.isfinite(z).astype(np.float32)
    if scene.render.peel_layers is not None:
        peel_spp = scene.render.peel_spp or spp
        extra, _ = peel_layers(scene, peel_spp, pass_spp=pass_spp, progress=progress)
        for c, name in enumerate("RGB"):   # layer 0 is what the pinhole sees (A = 1): the input itself
            extra[f"layer0.{name}"] = rgb[..., c].astype(np.float32)
    else:
        extra = render_layers(scene, spp, pass_spp, progress)
    if moves:
        flow = motion_vectors(scene, mi_scene, points, valid, shape_ids)
        extra.update({"motion.X": flow[..., 0], "motion.Y": flow[..., 1]})
    header = scene.camera.camera_json()
    if scene.medium is not None:
        header["medium"] = scene.medium.header_json(scene.camera)   # the runtime adds it: the pixels are without it
    return LabelledImage(rgb=rgb, alpha=alpha, depth=z, camera=header, extra=extra)
