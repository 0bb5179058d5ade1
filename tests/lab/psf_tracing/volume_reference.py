"""A plain reference for the Volume model's tracer: the textbook algorithm, written independently.

One photon per lane in a random channel, the tracer's PCG32 for every number, free flights by
``dr.log``, an albedo coin at every collision, Duff's basis + ``dr.sincos`` + ``dr.normalize`` for
the scattered direction, and every sphere crossing projected (no cone test). No persistent lanes,
no per-photon absorption draw, no generator of its own: what :mod:`lab.psf_tracing.models.volume`
does faster must give the same distribution (statistical tests compare them).
"""
import math

import drjit as dr
from drjit.llvm import Array2f, Array3f, Bool, Float, UInt32

from lab.optics.media import frame, hg_sample
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.models.volume_config import VolumeConfig
from lab.psf_tracing.tracer import RayHits, trace_psf


def reference_rays(c: VolumeConfig):
    """The per-ray function of the reference tracer for settings ``c`` (majorant ratio 1)."""
    assert c.majorant_ratio == 1.0

    def rays(coords, rng):
        n = dr.width(coords[0])
        dist = coords[0]
        ch = dr.minimum(UInt32(rng.next_float32() * 3.0), 2)
        albedo = dr.select(ch == 0, c.albedo[0], dr.select(ch == 1, c.albedo[1], c.albedo[2]))
        z = 1.0 - 2.0 * rng.next_float32()
        sp, cp = dr.sincos(2.0 * math.pi * rng.next_float32())
        r = dr.sqrt(dr.maximum(1.0 - z * z, 0.0))
        half = c.psf_resolution // 2
        lo, hi = PSF_MARGIN_PX - half, c.psf_resolution - 1 - half - PSF_MARGIN_PX
        reach = dist + c.escape_mfp / c.medium_density

        def body(p, w, alive, k, hit, crossed, steps, rng):
            s = -dr.log(1.0 - rng.next_float32()) / c.medium_density
            b = dr.dot(p, w)
            disc = b * b - (dr.squared_norm(p) - dist * dist)
            t = dr.sqrt(dr.maximum(disc, 0.0)) - b
            cross = alive & (disc >= 0) & (t >= 0) & (t <= s)
            x = p + w * t
            nrm = dr.select(dist > 1e-6, x / dr.maximum(dist, 1e-6), w)
            e1, e2 = frame(nrm)
            inv = c.focal_length_px / dr.dot(w, nrm)
            off = Array2f(dr.dot(w, e1) * inv, dr.dot(w, e2) * inv)
            kx, ky = dr.floor(off.x + 0.5), dr.floor(off.y + 0.5)
            seen = cross & (kx >= lo) & (kx <= hi) & (ky >= lo) & (ky <= hi)
            k = k + UInt32(dr.select(seen, 1, 0))
            take = seen & (rng.next_float32() * Float(k) < 1.0)
            hit = dr.select(take, off, hit)
            crossed = crossed | cross
            p = dr.select(alive, p + w * s, p)
            scatter = rng.next_float32() < albedo
            mu, sin = hg_sample(c.g, rng.next_float32())
            t1, t2 = frame(w)
            sa, ca = dr.sincos(2.0 * math.pi * rng.next_float32())
            w = dr.select(scatter, dr.normalize(w * mu + (t1 * ca + t2 * sa) * sin), w)
            steps = steps + 1
            alive = alive & scatter & (dr.squared_norm(p) <= reach * reach) & (steps < c.max_collisions)
            return p, w, alive, k, hit, crossed, steps, rng

        state = (dr.zeros(Array3f, n), Array3f(r * cp, r * sp, z), dr.full(Bool, True, n), dr.zeros(UInt32, n),
                 dr.zeros(Array2f, n), dr.zeros(Bool, n), dr.zeros(UInt32, n), rng)
        _, _, _, k, hit, crossed, _, _ = dr.while_loop(state, lambda p, w, alive, *_: alive, body)
        far = 4.0 * c.psf_resolution
        return RayHits(dr.select(k > 0, hit, Array2f(far, far)), active=crossed, channel=ch,
                       weight=dr.maximum(k, 1))
    return rays


def reference_trace(c: VolumeConfig, distance: float, n_rays: int, seed: int):
    """The reference's trace of the PSF at ``distance`` (m): a :class:`TraceResult`."""
    return trace_psf(reference_rays(c), (distance,), (distance,), c.psf_resolution, n_rays, seed,
                     channels=3, stream=12345, rays_per_launch=c.rays_per_launch)
