"""Volume (LSR18 section 5.1, Tbl. 1): a point light seen through a homogeneous medium, RGB.

ns = 1: the distance d (metres) between the light and the camera, over [min_distance_m,
max_distance_m] (beta 1, 200 samples). The medium fills space; its extinction sigma_t
(``medium_density``), Henyey-Greenstein anisotropy ``g`` and per-channel single-scattering
``albedo`` are fixed (LSR18: .9, .8, (1, 1, .9)).

Light tracing: a photon leaves the light (at the origin) in a uniform direction, in one colour
channel; it flies by Woodcock tracking (:mod:`lab.optics.media`), is absorbed at a real
collision with probability 1 - albedo, else scatters by HG. The camera: by the spherical
symmetry of the set-up, the radiance arriving at distance d is the same at every point of the
sphere |x| = d, so every outward crossing of that sphere, anywhere, is a photon entering a
camera there that looks at the light. Counting crossings through the camera's flat aperture
counts energy (flux = L cos dA dOmega), and a pinhole with focal length f images direction w at
f tan(angle to the axis): the histogram of f (w . e1, w . e2) / (w . n) over all crossings is the
PSF, its cos^4 falloff included, with no weights. Unscattered photons (a fraction
exp(-sigma_t d)) land in the centre pixel; scattered ones form the halo.

A photon may cross the sphere more than once (out, back in, out). Each ray reports one of its
crossings that land in the image, chosen uniformly (reservoir sampling), with the integer
multiplicity k = how many there were (:class:`RayHits` ``weight``), so the expected histogram
counts every crossing. The image here excludes a ``PSF_MARGIN_PX`` border (the sparsifier needs
it empty): the halo is cut off there. Rays whose crossings all miss it land outside; rays
absorbed or lost before crossing are blocked. Photons are dropped once farther than d + ``escape_mfp`` mean
free paths from the light, or after ``max_collisions`` collisions (a truncation whose effect the
tests bound).

The traced PSF is normalised per channel inside the image (the tracer's contract). The energy
that reaches the image relative to the point without the medium, per channel, is
``counts[..., c].sum() / rays in channel c`` (:meth:`Volume.window_energy`): transmittance,
absorption and out-scattering beyond the image lost, in-scattering gained. It is the model's
:meth:`~lab.psf_tracing.models.base.PSFModel.energy`, so the database stores each PSF with it and
a render through the medium darkens as a volpath reference does (Beer-Lambert for an absorbing
medium); colour shifts of the halo come from the albedo. Symmetry ``rotation``: the PSF is
rotation invariant.
"""
from __future__ import annotations

import math
from functools import cached_property

import drjit as dr
import numpy as np
from drjit.llvm import Array2f, Array3f, Bool, Float, UInt32

from lab.optics.media import exp_step, frame, hg_sample, scatter_direction
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.models.volume_config import VolumeConfig
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits, TraceResult

__all__ = ["Volume", "VolumeConfig"]


@register_model("volume")
class Volume(PSFModel):
    """Point-light PSFs in a homogeneous scattering medium, by distance (LSR18's Volume)."""

    Config = VolumeConfig
    symmetries = ("rotation",)
    channels = 3

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        return NestedGrid.for_samples(c.samples, (c.beta,), ((c.min_distance_m, c.max_distance_m),),
                                      ("distance_m",))

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: a photon from the light, tracked until absorbed or lost; one camera crossing."""
        c = self.config
        o = dr.opaque
        n = dr.width(coords[0])
        dist = coords[0]
        u = rng.next_float32() * 3.0
        ch = dr.minimum(UInt32(u), 2)
        albedo = dr.select(ch == 0, o(Float, c.albedo[0]), dr.select(ch == 1, o(Float, c.albedo[1]),
                                                                      o(Float, c.albedo[2])))
        z = 1.0 - 2.0 * rng.next_float32()
        sp, cp = dr.sincos(2.0 * math.pi * rng.next_float32())
        r = dr.sqrt(dr.maximum(1.0 - z * z, 0.0))
        w = Array3f(r * cp, r * sp, z)
        sbar = o(Float, c.medium_density * c.majorant_ratio)
        real_p = o(Float, 1.0 / c.majorant_ratio)
        g = o(Float, c.g)
        fpx = o(Float, c.focal_length_px)
        # pixels the tracer bins at k = floor(offset + 1/2), kept to [lo, hi]: the image less a
        # PSF_MARGIN_PX border, which the sparsifier needs empty (crossings there count as outside)
        half = c.psf_resolution // 2
        lo, hi = o(Float, PSF_MARGIN_PX - half), o(Float, c.psf_resolution - 1 - half - PSF_MARGIN_PX)
        reach = dist + o(Float, c.escape_mfp / c.medium_density)
        reach2 = reach * reach

        def cond(p, w, alive, k, hit, crossed, steps, rng):
            return alive

        def body(p, w, alive, k, hit, crossed, steps, rng):
            s = exp_step(sbar, rng.next_float32())
            # outward crossing of |x| = dist on the flight [p, p + s w]: the larger root t+
            b = dr.dot(p, w)
            disc = b * b - (dr.squared_norm(p) - dist * dist)
            t = dr.sqrt(dr.maximum(disc, 0.0)) - b
            cross = alive & (disc >= 0) & (t >= 0) & (t <= s)
            x = p + w * t
            nrm = dr.select(dist > 1e-6, x / dr.maximum(dist, 1e-6), w)
            e1, e2 = frame(nrm)
            inv = fpx / dr.dot(w, nrm)
            off = Array2f(dr.dot(w, e1) * inv, dr.dot(w, e2) * inv)
            kx, ky = dr.floor(off.x + 0.5), dr.floor(off.y + 0.5)
            seen = cross & (kx >= lo) & (kx <= hi) & (ky >= lo) & (ky <= hi)
            k = k + UInt32(dr.select(seen, 1, 0))
            take = seen & (rng.next_float32() * Float(k) < 1.0)      # reservoir: keep w.p. 1/k
            hit = dr.select(take, off, hit)
            crossed = crossed | cross
            p = dr.select(alive, p + w * s, p)
            real = alive if c.majorant_ratio == 1.0 else alive & (rng.next_float32() < real_p)
            scatter = real & (rng.next_float32() < albedo)
            mu, sin = hg_sample(g, rng.next_float32())
            w = dr.select(scatter, scatter_direction(w, mu, sin, rng.next_float32()), w)
            steps = steps + 1
            alive = alive & ~(real & ~scatter) & (dr.squared_norm(p) <= reach2) & (steps < c.max_collisions)
            return p, w, alive, k, hit, crossed, steps, rng

        state = (dr.zeros(Array3f, n), w, dr.full(Bool, True, n), dr.zeros(UInt32, n),
                 dr.zeros(Array2f, n), dr.zeros(Bool, n), dr.zeros(UInt32, n), rng)
        _, _, _, k, hit, crossed, _, _ = dr.while_loop(state, cond, body)
        far = 4.0 * float(c.psf_resolution)
        offset = dr.select(k > 0, hit, Array2f(far, far))             # crossings all beside the image
        return RayHits(offset, active=crossed, channel=ch, weight=dr.maximum(k, 1))

    def trace_checked(self, cell: int, n_rays: int | None = None, seed: int | None = None) -> TraceResult:
        """:meth:`trace_cell`: light scattered beyond the image's field is expected (the halo is
        cut at the PSF's edge), so rays landing outside are not an error here."""
        return self.trace_cell(cell, n_rays, seed)

    def fingerprint(self) -> dict:
        """The medium and the pinhole's field of view (the PSFs' pixel scale) a header must match."""
        c = self.config
        fov = math.degrees(2.0 * math.atan(c.sensor_width_mm / (2.0 * c.focal_length_mm)))
        return {"medium": {"sigma_t": float(c.medium_density), "albedo": [float(a) for a in c.albedo],
                           "g": float(c.g)}, "fov_x_deg": fov}

    def energy(self, traced: TraceResult) -> np.ndarray:
        """:meth:`window_energy`: the medium's losses stay in the PSF."""
        return self.window_energy(traced)

    @staticmethod
    def window_energy(result: TraceResult) -> np.ndarray:
        """Per channel: (weighted) crossings inside the image per photon of that channel, i.e. the
        PSF's energy relative to the same point without the medium (estimate; channels get
        ~n/3 photons each, binomially)."""
        per_channel = result.n_rays / 3.0
        return result.counts.sum(axis=(0, 1)) / per_channel
