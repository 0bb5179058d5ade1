"""The reference through a scene-filling homogeneous medium, with equi-angular light sampling.

Mitsuba's ``volpath`` picks a scattering distance along each ray in proportion to transmittance
and only then connects to a light. Fog's small, bright lights sit in the medium, and most of their
glow is scattered within a few centimetres of them, where free-flight sampling rarely lands: a
pixel's estimate is almost always the dim background with a rare large spike (a per-sample
relative spread of ~1.4 on ``fog``; two 16384-spp references at 256^2 agree at SSIM 0.89).

This estimator computes the same integral (the same lights, surfaces, medium and path depth) with
the direct light in-scattered along every path segment sampled *equi-angularly* about each light
(Kulla and Fajardo 2012, "Importance sampling techniques for path tracing in participating
media"): the distance t along the segment has density D / ((theta_b - theta_a) (D^2 + (t - Delta)^2)),
where D is the light's distance from the ray and Delta the foot of the perpendicular, so the
inverse-square falloff of the light's contribution is cancelled and the spikes are gone. Radiance
along a segment that ends on a surface at distance T is split into

* the light emitted by that surface, times the transmittance exp(-sigma_t T), evaluated exactly;
* the direct in-scattered light: for every light, one equi-angular distance and one point sampled
  on the light (Mitsuba's ``Emitter.sample_direction``), weighted by sigma_s, the HG phase
  function and the transmittances on both sides;
* the light the surface reflects straight from a light: next-event estimation (one light sample,
  Mitsuba's ``Scene.sample_emitter_direction``) times the transmittance of the segment and of the
  shadow ray;
* everything else (indirect in-scattering and indirect reflection) by the usual free-flight
  choice: scatter at t with probability 1 - exp(-sigma_t T) and continue with weight albedo in an
  HG-sampled direction, or reach the surface and continue by BSDF sampling. The next segment then
  does not count a light it hits directly (the light samples above took that light), except
  after a mirror (a delta BSDF, which no light sample can evaluate).

A path has at most ``max_depth`` segments, as in ``volpath``. Unbiasedness is checked against
``volpath`` itself (``tests/lab/reference/test_equiangular.py``). Lights at infinity send nothing
through a scene-filling medium (nor in ``volpath``). Cost: :data:`STRATA` light samples and
shadow rays per light per segment, so a scene with many lights pays for each. Samples run as a
Dr.Jit wavefront (one kernel per path segment) over Mitsuba's ray queries, with one PCG32 stream
per sample and numpy-seeded pixel jitter, all from the pass's seed; the pixels' sums are numpy
``bincount``s, so a pass is the same on any thread count.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Scene
from .backend import load_scene_dict, mitsuba
from .passes import RenderJob, RenderPass

__all__ = ["EquiAngularJob", "applies", "hg_cos_sample", "hg_phase", "trace"]

LANES = 1 << 20   # samples per wavefront (Dr.Jit arrays of a few hundred bytes each)
STRATA = 4        # equi-angular distances per light and segment, stratified in angle


def applies(scene: Scene) -> bool:
    """Whether the scene's medium fills it (a box's walls change the medium along a ray; those
    scenes keep ``volpath``)."""
    return scene.medium is not None and scene.medium.box is None and scene.medium.sigma_t > 0


def hg_phase(cos, g: float):
    """Henyey-Greenstein phase function per steradian (numpy or Dr.Jit); ``cos`` between the
    propagation directions before and after scattering (g > 0 scatters forward)."""
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * cos) ** 1.5)


def hg_cos_sample(u, g: float):
    """cos of a direction drawn from :func:`hg_phase` (inverse CDF; u in [0, 1); numpy or Dr.Jit)."""
    if abs(g) < 1e-3:
        return 1 - 2 * u
    s = (1 - g * g) / (1 - g + 2 * g * u)
    c = (1 + g * g - s * s) / (2 * g)
    if isinstance(c, np.ndarray):
        return np.clip(c, -1.0, 1.0)
    import drjit as dr

    return dr.clip(c, -1.0, 1.0)


def _light_centres(mi_scene) -> list:
    """(emitter, centre) of every light at a finite position (shape lights: their bounding box's
    centre; point lights: the point)."""
    mi = mitsuba()
    out = []
    for em in mi_scene.emitters():
        if em.is_environment() or not em.bbox().valid():
            continue   # at infinity: nothing of it crosses a scene-filling medium
        out.append((em, mi.Point3f(em.bbox().center())))
    return out


def _inscatter(mi_scene, em, centre, o, d, t_max, alive, rng, sigma_t: float, g: float, k: int):
    """Color3f estimate of the light of emitter ``em`` scattered toward the ray origin along each
    segment o + t d, t in [0, t_max], per unit sigma_s (albedo and throughput not applied): an
    equi-angular distance about ``centre`` in angle stratum ``k`` of :data:`STRATA`, and a point
    sampled on the light."""
    mi = mitsuba()
    import drjit as dr

    rel = centre - o
    foot = dr.dot(rel, d)
    dist = dr.maximum(dr.norm(rel - foot * d), 1e-6)
    th_a = dr.atan2(-foot, dist)
    th_b = dr.select(dr.isfinite(t_max), dr.atan2(t_max - foot, dist), 0.5 * np.pi)
    th = th_a + (k + rng.next_float32()) / STRATA * (th_b - th_a)
    t = dr.clip(foot + dist * dr.tan(th), 0.0, t_max)
    pdf_t = dist / ((th_b - th_a) * (dr.square(dist) + dr.square(t - foot)))
    it = dr.zeros(mi.Interaction3f, dr.width(o))
    it.p = o + t * d
    ok = alive & (th_b > th_a) & (pdf_t > 0)
    lds, spec = em.sample_direction(it, mi.Point2f(rng.next_float32(), rng.next_float32()), ok)
    shadow = mi.Ray3f(it.p, lds.d)
    shadow.maxt = lds.dist * (1 - 1e-4)
    ok &= ~mi_scene.ray_test(shadow, ok)
    w = sigma_t * dr.exp(-sigma_t * (t + lds.dist)) * hg_phase(dr.dot(d, lds.d), g) / pdf_t
    return dr.select(ok, w * spec, 0.0)


def trace(mi_scene, scene: Scene, film_xy: np.ndarray, seed: int) -> np.ndarray:
    """Radiance (N, 3) of one camera sample per row of ``film_xy`` ((N, 2) film positions in [0, 1)^2
    of the whole frame), through ``scene``'s medium; ``mi_scene`` holds its surfaces and lights
    (no medium). Random numbers: one PCG32 stream per sample from ``seed``. See the module
    docstring."""
    mi = mitsuba()
    import drjit as dr

    med = scene.medium
    sigma_t, g = float(med.sigma_t), float(med.g)
    albedo = mi.Color3f(*(float(a) for a in med.albedo))
    n = len(film_xy)
    rng = mi.PCG32(size=n, initstate=seed, initseq=dr.arange(mi.UInt64, n))
    sensor = mi_scene.sensors()[0]
    lights = _light_centres(mi_scene)
    ctx = mi.BSDFContext()
    xy = mi.Point2f(*(mi.Float(np.ascontiguousarray(c, np.float32)) for c in film_xy.T))
    ray, beta = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), xy, mi.Point2f(rng.next_float32(), rng.next_float32()))
    o, d = mi.Point3f(ray.o), mi.Vector3f(ray.d)
    radiance = dr.zeros(mi.Color3f, n)
    alive = dr.full(mi.Bool, True, n)
    count_light = dr.full(mi.Bool, True, n)   # a light the segment hits is this path's, not a light sample's
    for depth in range(scene.render.max_depth):   # ``depth``: vertices before this segment
        si = mi_scene.ray_intersect(mi.Ray3f(o, d), alive)
        hit = si.is_valid() & alive
        t_max = dr.select(hit, si.t, dr.inf)
        tr_max = dr.exp(-sigma_t * t_max)
        radiance += dr.select(hit & count_light, tr_max * beta * si.emitter(mi_scene).eval(si, hit), 0.0)
        if depth + 2 > scene.render.max_depth:
            break
        for em, centre in lights:     # the direct light scattered along the segment
            for k in range(STRATA):
                radiance += _inscatter(mi_scene, em, centre, o, d, t_max, alive, rng, sigma_t, g, k) \
                    * (albedo * beta / STRATA)
        # the direct light the surface reflects, through the segment's exact transmittance
        bsdf = si.bsdf()
        lds, spec = mi_scene.sample_emitter_direction(si, mi.Point2f(rng.next_float32(), rng.next_float32()), True, hit)
        val = bsdf.eval(ctx, si, si.to_local(lds.d), hit)
        radiance += dr.select(hit, tr_max * dr.exp(-sigma_t * lds.dist) * beta * val * spec, 0.0)
        bs, bw = bsdf.sample(ctx, si, rng.next_float32(), mi.Point2f(rng.next_float32(), rng.next_float32()), hit)
        # the rest: scatter in the medium (probability 1 - tr_max) or reach the surface
        u = rng.next_float32()
        scatter = alive & (u < 1 - tr_max)
        surf = alive & ~scatter & hit
        t_s = -dr.log(1 - dr.select(scatter, u, 0.0)) / sigma_t
        cos = hg_cos_sample(rng.next_float32(), g)
        phi = 2 * np.pi * rng.next_float32()
        sin = dr.safe_sqrt(1 - cos * cos)
        d_s = mi.Frame3f(d).to_world(mi.Vector3f(sin * dr.cos(phi), sin * dr.sin(phi), cos))
        out = si.spawn_ray(si.to_world(bs.wo))
        o = dr.select(scatter, o + t_s * d, dr.select(surf, out.o, o))
        d = dr.select(scatter, d_s, dr.select(surf, out.d, d))
        beta = dr.select(scatter, beta * albedo, dr.select(surf, beta * bw, 0.0))
        # a light hit after a smooth bounce or a scatter was sampled above; after a mirror it was not
        count_light = surf & mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
        alive = (scatter | surf) & dr.any(beta > 0)
        dr.eval(o, d, beta, radiance, alive, count_light, rng)   # one wavefront step per kernel
    out = np.stack([np.asarray(radiance[i], np.float64) for i in range(3)], axis=1)
    return np.nan_to_num(out, nan=0.0, posinf=0.0)


@dataclass
class EquiAngularJob(RenderJob):
    """:class:`~lab.reference.passes.RenderJob` whose passes :func:`trace` the scene (the scene
    camera's sensor, its medium; the job's ``medium`` flag is implied). Picklable."""

    def mitsuba_scene(self):
        """Surfaces, lights and the sensor of the whole frame (a crop picks pixels of it)."""
        if self._loaded is None:
            from .mitsuba_scene import scene_dict

            self._loaded = load_scene_dict(scene_dict(self.scene, self.sensor))
        return self._loaded

    def render(self, p: RenderPass) -> np.ndarray:
        """One pass: (H, W, 3) float32 mean of its ``spp`` samples per pixel (box filter)."""
        w, h = self.size
        x0, y0 = (0, 0) if self.crop is None else self.crop[:2]
        total = np.zeros((h * w, 3))
        pixels = np.repeat(np.arange(h * w), p.spp)
        for lo in range(0, pixels.size, LANES):
            pix = pixels[lo:lo + LANES]
            jitter = np.random.default_rng([p.seed, lo]).random((pix.size, 2))
            xy = np.stack([x0 + pix % w, y0 + pix // w], axis=1) + jitter
            # one 64-bit PCG32 state per (pass, chunk): seed + lo could repeat across passes
            radiance = trace(self.mitsuba_scene(), self.scene, xy / [self.scene.width, self.scene.height],
                             (p.seed << 32) + lo // LANES)
            for c in range(3):
                total[:, c] += np.bincount(pix, radiance[:, c], minlength=h * w)
        return (total / p.spp).reshape(h, w, 3).astype(np.float32)
