"""The reference through a homogeneous medium (filling the scene or a box), with equi-angular
light sampling.

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
inverse-square falloff of the light's contribution is cancelled and the spikes are gone. The
medium along a segment is its span [a, b] (all of it, or its part inside the box: a slab test;
no shape crosses the box's wall, the scene's check), so the segment's transmittance is
exp(-sigma_t (b - a)). Radiance along a segment is split into

* the light emitted by the surface it ends on (or, missing every surface, the environment's),
  times that transmittance, evaluated exactly;
* the direct in-scattered light: for every light, STRATA distances in [a, b] -- equi-angular, or
  for a light at infinity (environment, directional: only a box lets them in) in proportion to
  the transmittance -- each with a point sampled on the light (Mitsuba's
  ``Emitter.sample_direction``), weighted by sigma_s, the HG phase function and the
  transmittances on both sides;
* the light the surface reflects straight from a light: next-event estimation (one light sample,
  Mitsuba's ``Scene.sample_emitter_direction``) times the transmittance of the segment and of the
  shadow ray;
* everything else (indirect in-scattering and indirect reflection) by the usual free-flight
  choice: scatter in [a, b] with probability 1 - exp(-sigma_t (b - a)) and continue with weight
  albedo in an HG-sampled direction, or reach the surface and continue by BSDF sampling. The
  next segment then does not count a light it hits directly (the light samples above took that
  light), except after a mirror (a delta BSDF, which no light sample can evaluate).

A path has at most ``max_depth`` segments, as in ``volpath``. Unbiasedness is checked against
``volpath`` itself (``tests/lab/reference/test_equiangular.py``, a box with an environment light
too). Lights at infinity send nothing through a scene-filling medium (nor in ``volpath``).
Cost: :data:`STRATA` light samples and shadow rays per light per segment, so a scene with many
lights pays for each. Samples run as a Dr.Jit wavefront (one kernel per path segment) over
Mitsuba's ray queries, with one PCG32 stream per sample and numpy-seeded pixel jitter, all from
the pass's seed; the pixels' sums are numpy ``bincount``s, so a pass is the same on any thread
count.
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
    """Whether the scene has a medium to trace (``sigma_t`` > 0)."""
    return scene.medium is not None and scene.medium.sigma_t > 0


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


def _lights(mi_scene) -> list:
    """(emitter, centre) of every light: shape lights at their bounding box's centre, point lights
    at the point, lights at infinity (environment, directional) with centre None."""
    mi = mitsuba()
    out = []
    for em in mi_scene.emitters():
        finite = not em.is_environment() and em.bbox().valid()
        out.append((em, mi.Point3f(em.bbox().center()) if finite else None))
    return out


@dataclass(frozen=True)
class _Extent:
    """Where the medium is: everywhere (``lo`` None) or the axis-aligned box [lo, hi] (world)."""

    sigma_t: float
    lo: tuple | None = None
    hi: tuple | None = None

    def span(self, o, d, t_max):
        """(a, b): the part of the segment o + t d, t in [0, t_max], inside the medium (a == b when
        it misses the box; b may be inf for a segment to infinity in a scene-filling medium)."""
        import drjit as dr

        if self.lo is None:
            return dr.zeros(type(t_max), dr.width(t_max)), t_max
        mi = mitsuba()
        inv = dr.rcp(dr.select(dr.abs(d) > 1e-9, d, 1e-9))   # a slab the ray runs along: +-inf bounds
        t0 = (mi.ScalarPoint3f(self.lo) - o) * inv
        t1 = (mi.ScalarPoint3f(self.hi) - o) * inv
        near = dr.max(dr.minimum(t0, t1))
        far = dr.min(dr.maximum(t0, t1))
        a = dr.clip(near, 0.0, t_max)
        return a, dr.maximum(dr.clip(far, 0.0, t_max), a)

    def transmittance(self, o, d, length):
        """exp(-sigma_t x), x the length of o + t d, t in [0, length], inside the medium."""
        import drjit as dr

        a, b = self.span(o, d, length)
        return dr.exp(-self.sigma_t * (b - a))


def _inscatter(mi_scene, em, centre, o, d, span, alive, rng, extent: _Extent, g: float, k: int):
    """Color3f estimate of the light of emitter ``em`` scattered toward the ray origin along the
    medium's part ``span`` = (a, b) of the segment o + t d, per unit sigma_s (albedo and throughput
    not applied): a distance in stratum ``k`` of :data:`STRATA` -- equi-angular about ``centre``, or
    for a light at infinity in proportion to the transmittance from a -- and a point sampled on the
    light."""
    mi = mitsuba()
    import drjit as dr

    sigma_t = extent.sigma_t
    a, b = span
    u = (k + rng.next_float32()) / STRATA
    if centre is None:   # no falloff to cancel: the transmittance is the integrand's shape
        loss = 1 - dr.exp(-sigma_t * (b - a))
        t = dr.minimum(a - dr.log(1 - u * loss) / sigma_t, b)
        pdf_t = sigma_t * dr.exp(-sigma_t * (t - a)) / loss
        ok = alive & (loss > 0)
    else:
        rel = centre - o
        foot = dr.dot(rel, d)
        dist = dr.maximum(dr.norm(rel - foot * d), 1e-6)
        th_a = dr.atan2(a - foot, dist)
        th_b = dr.select(dr.isfinite(b), dr.atan2(b - foot, dist), 0.5 * np.pi)
        th = th_a + u * (th_b - th_a)
        t = dr.clip(foot + dist * dr.tan(th), a, b)
        pdf_t = dist / ((th_b - th_a) * (dr.square(dist) + dr.square(t - foot)))
        ok = alive & (th_b > th_a)
    ok &= pdf_t > 0
    it = dr.zeros(mi.Interaction3f, dr.width(o))
    it.p = o + t * d
    lds, spec = em.sample_direction(it, mi.Point2f(rng.next_float32(), rng.next_float32()), ok)
    shadow = mi.Ray3f(it.p, lds.d)
    shadow.maxt = lds.dist * (1 - 1e-4)
    ok &= ~mi_scene.ray_test(shadow, ok)
    w = sigma_t * dr.exp(-sigma_t * (t - a)) * extent.transmittance(it.p, lds.d, lds.dist) \
        * hg_phase(dr.dot(d, lds.d), g) / pdf_t
    return dr.select(ok, w * spec, 0.0)


def trace(mi_scene, scene: Scene, film_xy: np.ndarray, seed: int) -> np.ndarray:
    """Radiance (N, 3) of one camera sample per row of ``film_xy`` ((N, 2) film positions in [0, 1)^2
    of the whole frame), through ``scene``'s medium; ``mi_scene`` holds its surfaces and lights
    (no medium). Random numbers: one PCG32 stream per sample from ``seed``. See the module
    docstring."""
    mi = mitsuba()
    import drjit as dr

    med = scene.medium
    box = med.box
    extent = _Extent(float(med.sigma_t), *((None, None) if box is None else (tuple(map(float, box.lo)),
                                                                              tuple(map(float, box.hi)))))
    sigma_t, g = extent.sigma_t, float(med.g)
    albedo = mi.Color3f(*(float(a) for a in med.albedo))
    n = len(film_xy)
    rng = mi.PCG32(size=n, initstate=seed, initseq=dr.arange(mi.UInt64, n))
    sensor = mi_scene.sensors()[0]
    # nothing from infinity crosses a scene-filling medium (nor in volpath)
    lights = [(em, c) for em, c in _lights(mi_scene) if c is not None or box is not None]
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
        span = extent.span(o, d, dr.select(hit, si.t, dr.inf))
        tr_seg = dr.exp(-sigma_t * (span[1] - span[0]))
        # what the segment ends on: a surface's emission, or (a miss) the environment's
        radiance += dr.select(alive & count_light, tr_seg * beta * si.emitter(mi_scene).eval(si, alive), 0.0)
        if depth + 2 > scene.render.max_depth:
            break
        for em, centre in lights:     # the direct light scattered along the segment
            for k in range(STRATA):
                radiance += _inscatter(mi_scene, em, centre, o, d, span, alive, rng, extent, g, k) \
                    * (albedo * beta / STRATA)
        # the direct light the surface reflects, through the transmittances of the segment and shadow ray
        bsdf = si.bsdf()
        lds, spec = mi_scene.sample_emitter_direction(si, mi.Point2f(rng.next_float32(), rng.next_float32()), True, hit)
        val = bsdf.eval(ctx, si, si.to_local(lds.d), hit)
        radiance += dr.select(hit, tr_seg * extent.transmittance(si.p, lds.d, lds.dist) * beta * val * spec, 0.0)
        bs, bw = bsdf.sample(ctx, si, rng.next_float32(), mi.Point2f(rng.next_float32(), rng.next_float32()), hit)
        # the rest: scatter in the medium (probability 1 - tr_seg) or reach the surface
        u = rng.next_float32()
        scatter = alive & (u < 1 - tr_seg)
        surf = alive & ~scatter & hit
        t_s = span[0] - dr.log(1 - dr.select(scatter, u, 0.0)) / sigma_t
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
