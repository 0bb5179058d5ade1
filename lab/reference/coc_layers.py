"""LES09's scene decomposition: layers spaced uniformly in signed CoC, with 10 % overlap (eq. 4).

Layer l holds, per pixel-centre ray from the lens centre, the first surface whose planar depth d
lies in its interval, as if the scene were rendered between two clipping planes (LES09 4.1):

    l(d) = floor(S (1/d_near - 1/d) / delta),   S = a f_px (the CoC scale, px per dioptre),

so the signed CoC C(d) = S (1/F - 1/d) grows by ``delta`` pixels from one layer to the next: a
lens ray then travels about the same image distance through every layer. Each interval is
widened by ``overlap`` delta at its far end (LES09: 10 %), which hides seams from pixel
quantisation; a surface in the overlap is in both layers (the nearer layer wins a tie in the
tracer). The last layer reaches to infinity and holds the sky.

This is the alternative to :mod:`lab.reference.peel` (LES10's umbra peeling, what scenes use):
it needs more layers (a fixed count by the depth range, not by what is hidden) but bounds each
layer's depth range, which LES09's false-position search relies on.
"""
from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..scene import Scene
from .backend import load_scene_dict, mitsuba
from .mitsuba_scene import scene_dict

OVERLAP = 0.1   # LES09: layers overlap by 10 % of their CoC spacing


def coc_bounds(near_m: float, coc_scale_px: float, delta_px: float, n_layers: int,
               overlap: float = OVERLAP) -> np.ndarray:
    """Inverse-depth bounds ``(n_layers, 2)`` = (far, near) of LES09's layers, 1/m.

    Layer l spans C(d) - C(near) in [l delta, (l + 1 + overlap) delta]; the last one reaches
    infinity (inverse depth 0). Raises UserError for a near plane or spacing that is not > 0.
    """
    if not (near_m > 0 and delta_px > 0 and coc_scale_px > 0 and n_layers >= 1):
        raise UserError(f"near = {near_m} m, delta = {delta_px} px, layers = {n_layers}: need a near plane "
                        "> 0, a CoC spacing > 0 px and at least one layer")
    step = delta_px / coc_scale_px                       # inverse depth per layer
    l = np.arange(n_layers, dtype=np.float64)
    near = 1.0 / near_m - l * step
    far = np.maximum(1.0 / near_m - (l + 1 + overlap) * step, 0.0)
    far[-1] = 0.0
    return np.stack([far, near], axis=-1)


def coc_layers(scene: Scene, n_layers: int, delta_px: float, near_m: float, spp: int = 16,
               overlap: float = OVERLAP) -> dict:
    """The ``layerN.R/G/B/A/Z`` channels of LES09's decomposition of ``scene`` (pixel-centre depth,
    colour path traced from just before each layer's surface, averaged over ``spp`` paths).

    Parameters
    ----------
    scene : Scene
        A thin-lens scene (the lens fixes the CoC spacing).
    n_layers : int
    delta_px : float
        CoC growth per layer in pixels (LES09: ~10 px for 6 layers at 800x600).
    near_m : float
        The near plane (metres), in front of every surface.
    spp : int, default 16
        Paths per pixel and layer for the colour (the depth is point sampled).
    overlap : float, default 0.1
    """
    thin = getattr(scene.camera, "thin_lens", None)
    if thin is None:
        raise UserError(f"{scene.source} [camera]: the CoC decomposition needs a lens; use model = \"thin\"")
    mi = mitsuba()
    import drjit as dr

    w, h = scene.width, scene.height
    bounds = coc_bounds(near_m, thin().coc_scale_px(w), delta_px, n_layers, overlap)
    full = load_scene_dict(scene_dict(scene, "pinhole"))
    integrator, sensor = full.integrator(), full.sensors()[0]
    eye = mi.Point3f(*(float(v) for v in scene.camera.position))
    axis = mi.Vector3f(*(float(v) for v in scene.camera.forward()))
    idx = dr.arange(mi.UInt32, w * h * spp) // spp
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
    cos = dr.dot(ray.d, axis)
    sampler = mi.load_dict({"type": "independent"})
    out = {}
    for k, (far, near) in enumerate(bounds.tolist()):
        sampler.seed(int(np.random.SeedSequence([scene.render.seed, 13, k]).generate_state(1)[0]), w * h * spp)
        start = 1.0 / near
        si = full.ray_intersect(mi.Ray3f(eye + ray.d * (start / cos), ray.d))
        z = dr.dot(si.p - eye, axis)
        inside = si.is_valid() & ((far <= 0.0) | (z * far <= 1.0))
        sky = ~si.is_valid() & (far <= 0.0)
        back = eye + ray.d * (dr.select(inside, z * (1.0 - 1e-4), 1e6) / cos)
        radiance, _, _ = integrator.sample(full, sampler, mi.RayDifferential3f(mi.Ray3f(back, ray.d)), None,
                                           inside | sky)
        rgb = [dr.block_sum(dr.select(inside | sky, radiance[c], 0.0), spp) / spp for c in range(3)]
        got = [np.asarray(c, np.float32).reshape(h, w) for c in rgb]
        hit = np.asarray(inside, bool).reshape(h, w, spp)[..., 0]
        open_sky = np.asarray(sky, bool).reshape(h, w, spp)[..., 0]
        depth = np.asarray(z, np.float32).reshape(h, w, spp)[..., 0]
        for c, name in enumerate("RGB"):
            out[f"layer{k}.{name}"] = got[c]
        out[f"layer{k}.A"] = (hit | open_sky).astype(np.float32)
        out[f"layer{k}.Z"] = np.where(hit, depth, np.inf).astype(np.float32)
    return out
