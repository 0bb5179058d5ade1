"""The layered labelled input: one pinhole image per group of objects, with coverage and depth.

A scene's ``[[shapes]]`` may carry ``layer = 0, 1, ...`` (0 the nearest); untagged shapes and the
sky form the last layer (:meth:`lab.scene.Scene.input_layers`). Layer k holds what its shapes show
in front of every later layer's shapes, as if the nearer layers were not there: the background
layer continues behind a foreground object, so a blurred foreground can reveal it.

Per camera sample (pinhole, uniform over the pixel: the box filter of the flat input) the rays
are intersected with the peeled scenes S_k (shapes of layers >= k). Layer k owns the sample when
S_k's first hit is one of its own shapes (the last layer also owns misses: the sky). Its
radiance is path traced in the *full* scene from just before that hit, so shadows and light
from the nearer objects stay (the foreground's shadow on the background is in the background
layer). Per pixel and layer: colour = mean over samples of owned radiance (premultiplied),
A = fraction of owned samples that hit a surface, Z = mean planar depth of those hits (``inf``
where none). Composited "over" front to back without blur, the layers give back the flat input.
"""
from __future__ import annotations

import numpy as np
from tqdm import tqdm

from ..scene import Scene
from .backend import load_scene_dict, mitsuba
from .mitsuba_scene import scene_dict
from .render import pass_seeds, split_spp

# Restart a path this far (relative) before the surface it hit in a peeled scene.
BACKOFF = 1e-4


def render_layers(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                  progress: bool = True) -> dict:
    """The ``layerN.R/G/B/A/Z`` channels of ``scene`` (``{}`` when no shape has a ``layer``).

    Parameters
    ----------
    scene : Scene
    spp : int, optional
        Samples per pixel; default ``scene.render.input_spp``.
    pass_spp : int, optional
        Samples per pass (see :func:`lab.reference.render.split_spp`).
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    dict of str -> (H, W) float32
    """
    groups = scene.input_layers()
    if not groups:
        return {}
    mi = mitsuba()
    import drjit as dr

    base = scene_dict(scene, "pinhole")
    full = load_scene_dict(base)
    peeled = [full]
    for k in range(1, len(groups)):
        nearer = {f"shape_{i}" for g in groups[:k] for i in g}
        peeled.append(load_scene_dict({key: v for key, v in base.items() if key not in nearer}))
    integrator, sensor = full.integrator(), full.sensors()[0]
    eye = mi.Point3f(*(float(v) for v in scene.camera.position))
    axis = mi.Vector3f(*(float(v) for v in scene.camera.forward()))
    box = full.bbox()
    beyond = float(dr.norm(box.max - box.min) + dr.norm(box.center() - mi.ScalarPoint3f(
        *(float(v) for v in scene.camera.position))))   # a start past everything: the sky

    spp = scene.render.input_spp if spp is None else spp
    w, h = scene.width, scene.height
    chunks = split_spp(spp, w, h, pass_spp)
    sums = np.zeros((len(groups), 5, h * w))           # R, G, B, covered samples, depth sum
    with tqdm(total=spp, unit="spp", desc=f"layers {scene.name}", disable=not progress, leave=False) as bar:
        for n, seed in zip(chunks, pass_seeds(scene.render.seed, "layers", len(chunks))):
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(seed, w * h * n)
            pixel = dr.arange(mi.UInt32, w * h * n) // n
            pos = (mi.Point2f(mi.Float(pixel % w), mi.Float(pixel // w)) + sampler.next_2d()) \
                / mi.ScalarVector2f(w, h)
            ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
            hits = [s.ray_intersect(ray) for s in peeled]
            dr.eval(ray, [(si.t, si.p) for si in hits])             # traced once, shared by the layers
            for k, si in enumerate(hits):
                hit = si.is_valid()
                own = hit & (si.t < hits[k + 1].t) if k + 1 < len(hits) else mi.Bool(True)
                start = dr.select(hit, si.t * (1.0 - BACKOFF), beyond)
                restart = mi.RayDifferential3f(mi.Ray3f(ray.o + ray.d * start, ray.d))
                sampler.seed(int(np.random.SeedSequence([seed, k]).generate_state(1)[0]), w * h * n)
                radiance, _, _ = integrator.sample(full, sampler, restart, None, own)
                covered = own & hit
                z = dr.dot(si.p - eye, axis)
                parts = [dr.select(own, radiance[c], 0.0) for c in range(3)] + \
                        [dr.select(covered, 1.0, 0.0), dr.select(covered, z, 0.0)]
                reduced = [dr.block_sum(mi.Float(part), n) for part in parts]
                dr.eval(*reduced)                                  # one kernel for all five sums
                for c, part in enumerate(reduced):
                    sums[k, c] += np.asarray(part, np.float64)
            bar.update(n)
    out = {}
    for k in range(len(groups)):
        count = sums[k, 3]
        out[f"layer{k}.R"], out[f"layer{k}.G"], out[f"layer{k}.B"] = sums[k, :3] / spp
        out[f"layer{k}.A"] = count / spp
        with np.errstate(invalid="ignore", divide="ignore"):
            out[f"layer{k}.Z"] = np.where(count > 0, sums[k, 4] / count, np.inf)
    return {name: v.reshape(h, w).astype(np.float32) for name, v in out.items()}
