"""LES10's depth peeling from the lens centre with the umbra offset: the layers lens rays can see.

Layer 0 is the pinhole view. Along each primary ray from the lens centre, layer k+1 is the first
surface more than the umbra offset x behind layer k's surface at planar depth d (LES10 section 3):

    x = d s / (E - s),   s = 2 e d / f_px,   E = 2 a,

the umbra, seen from the lens (aperture radius a) as a light, of the pixel's surfel extended by
``e`` pixels to each side (LES10: e = 1, to the neighbouring pixel centres; s is its size in
metres at depth d, f_px the image distance in pixels). No lens ray reaches a point in that umbra
without crossing the surfel, so nothing there can be seen. With the CoC scale S = a f_px
(pixels per dioptre) x = e d^2 / (S - e d), and where e d >= S (a surfel larger than the lens)
the umbra never ends: nothing behind is peeled. The runtime's ``layered`` pass treats the
surfels the same way (a cell and a slab of ray travel).

Per pixel and layer, over ``spp`` jittered primary rays each peeled on its own: colour = mean of
the radiance of each ray's k-th surface (path traced in the full scene from just before it, so
shadows of nearer surfaces stay), premultiplied; A = fraction of rays that have a k-th surface,
where in layer 0 the environment counts as a surface at infinity (A = 1 and Z = inf where the
pinhole sees the sky; as in LES10's peeling of geometry, later layers hold no sky); Z = the
planar depth of the k-th surface along the pixel-centre ray (point sampled, as LES10's peeling),
or the rays' mean where the centre ray has none. Empty: A = 0, Z = inf, colour 0. Back faces
are culled (the inside of a closed object is not a layer: a ray behind its front surfel has
entered it through its side).
"""
from __future__ import annotations

import math

import numpy as np
from tqdm import tqdm

from ..errors import UserError
from ..scene import Scene
from .backend import load_scene_dict, mitsuba
from .mitsuba_scene import scene_dict
from .render import pass_seeds, split_spp

BACKOFF = 1e-4      # restart a path this far (relative to its distance) before the peeled surface
EXTENSION_PX = 1.0  # LES10: a surfel reaches the neighbouring pixel centres
BACK_FACES = 2      # back faces skipped in a row per layer (the far sides of closed objects)


def umbra_offset(depth_m, coc_scale_px: float, extension_px: float = EXTENSION_PX):
    """LES10's umbra offset x = d s / (E - s) in metres behind planar depth ``depth_m``.

    Parameters
    ----------
    depth_m : float or ndarray
        Planar depth d of the peeled surface (metres, > 0).
    coc_scale_px : float
        The lens's S = a f_px, CoC radius in pixels per dioptre.
    extension_px : float, default 1
        Half-size e of the extended surfel in pixels.

    Returns
    -------
    float or ndarray
        ``e d^2 / (S - e d)``; ``inf`` where ``e d >= S``.
    """
    d = np.asarray(depth_m, np.float64)
    with np.errstate(divide="ignore"):
        x = np.where(extension_px * d < coc_scale_px, extension_px * d * d / (coc_scale_px - extension_px * d), np.inf)
    return x if x.ndim else float(x)


def _peel_rays(mi, dr, full, integrator, sampler, ray, eye, axis, beyond, scale, ext, max_layers, colour):
    """Peel ``max_layers`` layers along ``ray`` (a batch); per layer the Dr.Jit arrays
    (owned, hit, depth, r, g, b): owned = a k-th surface or the sky, hit = a finite surface."""
    d = ray.d
    cos = dr.dot(d, axis)
    alive = mi.Bool(True)
    current = mi.Ray3f(ray.o, d)
    out = []
    for k in range(max_layers):
        si = full.ray_intersect(current, active=alive)
        for _ in range(BACK_FACES):   # cull back faces: the inside of a closed object is never seen
            back = alive & si.is_valid() & (dr.dot(si.n, d) > 0)
            past = mi.Ray3f(si.p + d * (BACKOFF * dr.dot(si.p - eye, axis) / cos), d)
            si[back] = full.ray_intersect(past, active=back)
        hit = alive & si.is_valid()
        sky = alive & ~si.is_valid() & (k == 0)   # the sky is what the pinhole sees, not a peeled layer
        z = dr.dot(si.p - eye, axis)
        rgb = (mi.Float(0.0),) * 3
        if colour:
            dist = z / cos
            start = dr.select(hit, eye + d * (dist * (1.0 - BACKOFF)), eye + d * beyond)
            radiance, _, _ = integrator.sample(full, sampler, mi.RayDifferential3f(mi.Ray3f(start, d)), None,
                                               hit | sky)
            rgb = tuple(dr.select(hit | sky, radiance[c], 0.0) for c in range(3))
        out.append((hit | sky, hit, dr.select(hit, z, 0.0), *rgb))
        offset = dr.select(ext * z < scale, ext * z * z / (scale - ext * z), dr.inf)
        alive = hit & dr.isfinite(offset)
        current = mi.Ray3f(eye + d * ((z + offset) / cos), d)
        dr.eval(current, alive, *out[-1])   # one kernel per layer, the same for every layer
    return out


def peel_layers(scene: Scene, spp: int | None = None, max_layers: int | None = None,
                extension_px: float = EXTENSION_PX, pass_spp: int | None = None,
                progress: bool = True) -> tuple[dict, dict]:
    """The umbra-peeled ``layerN.R/G/B/A/Z`` channels of a thin- or thick-lens scene, and their statistics.

    Parameters
    ----------
    scene : Scene
        Its camera needs a lens with a CoC scale (the lens fixes the umbra).
    spp : int, optional
        Primary rays per pixel; default ``scene.render.input_spp``.
    max_layers : int, optional
        The most layers peeled; default ``scene.render.peel_layers`` (else 8).
    extension_px : float, default 1
        Surfel half-size e of the umbra (pixels).
    pass_spp : int, optional
        Samples per pass (:func:`lab.reference.render.split_spp`).
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    channels : dict of str -> (H, W) float32
        Only the layers some pixel holds (trailing empty layers are dropped).
    stats : dict
        ``layers`` (count), ``occupancy`` (fraction of pixels with A > 0, per layer),
        ``max_layers``, ``extension_px``, ``truncated`` (pixels whose rays still had surfaces
        to peel after the last layer).
    """
    lens = scene.camera.runtime_camera()
    if not hasattr(lens, "coc_scale_px"):
        raise UserError(f"{scene.source} [camera]: peeling needs a lens (the umbra follows from its "
                        "aperture); use model = \"thin\" or \"thick\"")
    max_layers = max_layers or scene.render.peel_layers or 8
    mi = mitsuba()
    import drjit as dr

    full = load_scene_dict(scene_dict(scene, "pinhole"))
    integrator, sensor = full.integrator(), full.sensors()[0]
    w, h = scene.width, scene.height
    scale = float(lens.coc_scale_px(w))   # a thick lens: its paraxial CoC (entrance pupil, chief-ray scale)
    eye = mi.Point3f(*(float(v) for v in scene.camera.position))
    axis = mi.Vector3f(*(float(v) for v in scene.camera.forward()))
    box = full.bbox()
    beyond = float(dr.norm(box.max - box.min) + dr.norm(box.center() - mi.ScalarPoint3f(
        *(float(v) for v in scene.camera.position))))
    n_layers = max_layers + 1                          # one more, to report truncation
    spp = scene.render.input_spp if spp is None else spp

    # Z along the pixel-centre rays (point sampled, as the peeling of LES10).
    idx = dr.arange(mi.UInt32, w * h)
    pos = mi.Point2f((mi.Float(idx % w) + 0.5) / w, (mi.Float(idx // w) + 0.5) / h)
    ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
    centre = _peel_rays(mi, dr, full, integrator, None, ray, eye, axis, beyond, scale, extension_px, n_layers,
                        colour=False)
    centre = [(np.asarray(o, bool), np.asarray(hh, bool), np.asarray(z, np.float64)) for o, hh, z, *_ in centre]

    sums = np.zeros((n_layers, 6, h * w))             # R, G, B, owned, hit, depth sum
    chunks = split_spp(spp, w, h, pass_spp)
    with tqdm(total=spp, unit="spp", desc=f"peel {scene.name}", disable=not progress, leave=False) as bar:
        for n, seed in zip(chunks, pass_seeds(scene.render.seed, "layers", len(chunks))):
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(seed, w * h * n)
            pixel = dr.arange(mi.UInt32, w * h * n) // n
            pos = (mi.Point2f(mi.Float(pixel % w), mi.Float(pixel // w)) + sampler.next_2d()) / mi.ScalarVector2f(w, h)
            ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
            layers = _peel_rays(mi, dr, full, integrator, sampler, ray, eye, axis, beyond, scale, extension_px,
                                n_layers, colour=True)
            for k, (owned, hit, z, r, g, b) in enumerate(layers):
                parts = [r, g, b, dr.select(owned, 1.0, 0.0), dr.select(hit, 1.0, 0.0), z]
                reduced = [dr.block_sum(mi.Float(part), n) for part in parts]
                dr.eval(*reduced)
                for c, part in enumerate(reduced):
                    sums[k, c] += np.asarray(part, np.float64)
            bar.update(n)

    out, occupancy = {}, []
    for k in range(max_layers):
        owned, hits, zsum = sums[k, 3], sums[k, 4], sums[k, 5]
        c_owned, c_hit, c_z = centre[k]
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_z = np.where(hits > 0, zsum / hits, np.inf)
        z = np.where(c_hit, c_z, np.where(c_owned, np.inf, mean_z))
        a = owned / spp
        if not np.any(a > 0):
            break
        occupancy.append(float(np.mean(a > 0)))
        for c, name in enumerate("RGB"):
            out[f"layer{k}.{name}"] = sums[k, c] / spp
        out[f"layer{k}.A"], out[f"layer{k}.Z"] = a, z
    truncated = int(np.count_nonzero(sums[max_layers, 3])) if len(occupancy) == max_layers else 0
    stats = {"layers": len(occupancy), "occupancy": [round(o, 4) for o in occupancy], "max_layers": max_layers,
             "extension_px": extension_px, "truncated_pixels": truncated,
             "umbra_ends_beyond_m": round(scale / extension_px, 3) if math.isfinite(scale) else None}
    channels = {name: v.reshape(h, w).astype(np.float32) for name, v in out.items()}
    return channels, stats
