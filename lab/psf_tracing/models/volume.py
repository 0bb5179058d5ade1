"""Volume (LSR18 section 5.1, Tbl. 1): a point light seen through a homogeneous medium, RGB.

ns = 1: the distance d (metres) between the light and the camera, over [min_distance_m,
max_distance_m] (beta 1, 200 samples). The medium fills space; its extinction sigma_t
(``medium_density``), Henyey-Greenstein anisotropy ``g`` and per-channel single-scattering
``albedo`` are fixed (LSR18: .9, .8, (1, 1, .9)).

Light tracing: a photon leaves the light (at the origin) in a uniform direction; it flies by
Woodcock tracking (:mod:`lab.optics.media`), is absorbed at a real collision with probability
1 - albedo, else scatters by HG. The camera: by the spherical symmetry of the set-up, the
radiance arriving at distance d is the same at every point of the sphere |x| = d, so every
outward crossing of that sphere, anywhere, is a photon entering a camera there that looks at the
light. Counting crossings through the camera's flat aperture counts energy (flux = L cos dA
dOmega), and a pinhole with focal length f images direction w at f tan(angle to the axis): the
histogram of f (w . e1, w . e2) / (w . n) over all crossings is the PSF, its cos^4 falloff
included, with no weights. Unscattered photons (a fraction exp(-sigma_t d)) land in the centre
pixel; scattered ones form the halo.

Colour: ray i is in channel i mod 3 (a third of the rays each, exactly). Only absorption depends
on the channel, and it is drawn once per photon: with u uniform, the photon survives its j-th real
collision iff u <= albedo^j, i.e. j <= ln u / ln albedo -- the albedo coin at every collision
(P(j survived) = albedo^j, each collision independently), at one random number per photon.

A photon may cross the sphere more than once (out, back in, out). Each ray reports one of its
crossings that land in the image, chosen uniformly (reservoir sampling), with the integer
multiplicity k = how many there were (:class:`RayHits` ``weight``), so the expected histogram
counts every crossing. The image here excludes a ``PSF_MARGIN_PX`` border (the sparsifier needs
it empty): the halo is cut off there. Rays whose crossings all miss it land outside; rays
absorbed or lost before crossing are blocked. Photons are dropped once farther than
d + ``escape_mfp`` mean free paths from the light, or after ``max_collisions`` collisions (a
truncation whose effect the tests bound).

Speed (``splatlab bench precompute``; ~3x the straightforward tracer, which the tests keep as
their reference): photons run on persistent SIMD lanes (:func:`lab.psf_tracing.walks.run_walks`),
so a packet of 16 lanes does not wait for its longest walk (a packet of 16 photons takes ~2.9x
the mean number of collisions); every photon's start (direction, absorption, generator) is
computed up front for all rays; the projection onto the camera runs only for crossings inside the
image's cone (a branch packets skip; :func:`_cone`); absorption costs one random number per
photon, not one per collision; the numbers come from a 32-bit-lane generator
(:mod:`lab.psf_tracing.rng32`), and flights, azimuths and scattered directions use the cheaper
forms of :mod:`lab.optics.media` (:func:`~lab.optics.media.log_unit`,
:func:`~lab.optics.media.unit_circle`). Each photon's random numbers depend only on its ray, so
the PSF is bitwise the same however photons are spread over lanes.

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
from drjit.llvm import Array2f, Array3f, Bool, Float, Int32, UInt32, UInt64

from lab.optics.media import frame, hg_sample, log_unit, scatter_direction, unit_circle
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.models.volume_config import VolumeConfig
from lab.psf_tracing.rng32 import Xoroshiro64
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits, TraceResult
from lab.psf_tracing.walks import run_walks

__all__ = ["Volume", "VolumeConfig"]

# SIMD lanes the walks run on: two of Dr.Jit's 16384-lane blocks, one per thread (both draw walks
# from one counter, so neither idles while the other still has work).
WALK_LANES = 2 ** 15
_PIXEL_BIAS = 1 << 15                 # a pixel offset k is stored as k + bias in 16 bits
_NEVER = -1e30                        # 1 / ln(albedo) for albedo 1: no collision absorbs


class _Photon:
    """The state of one photon's walk (a Dr.Jit struct: loops and branches carry it field by field).

    ``p``, ``w``: position (m) and unit direction; ``dist``: the camera sphere's radius d;
    ``left``: real collisions the photon still survives (it ends at the next one when 0; without
    null collisions also the collisions left before ``max_collisions``); ``alive``: the walk goes
    on; ``count``: crossings in the image k, shifted left by one, or-ed with 1 once the photon has
    crossed the sphere at all; ``pixel``: the reservoir's crossing (packed); ``rng``: its
    generator. Few fields: each costs blends and spills every step.
    """

    DRJIT_STRUCT = {"p": Array3f, "w": Array3f, "dist": Float, "left": UInt32, "alive": Bool,
                    "count": UInt32, "pixel": UInt32, "rng": Xoroshiro64}

    def __init__(self, **fields):
        for name, value in fields.items():
            setattr(self, name, value)


class _NullPhoton(_Photon):
    """:class:`_Photon` with ``steps``: tentative collisions left (Woodcock with null collisions)."""

    DRJIT_STRUCT = {**_Photon.DRJIT_STRUCT, "steps": UInt32}


class _Emitted:
    """A photon as the light emits it: direction ``w``, ``left`` (real collisions it survives) and
    its generator ``rng`` after those draws (a Dr.Jit struct)."""

    DRJIT_STRUCT = {"w": Array3f, "left": UInt32, "rng": Xoroshiro64}

    def __init__(self, w=None, left=None, rng=None):
        self.w, self.left, self.rng = w, left, rng


def _emitted(rng, c: VolumeConfig) -> _Emitted:
    """Per ray: its photon's start, from a generator keyed by the tracer's per-ray ``rng``.

    The channel is ray mod 3. Absorption is drawn once: the photon survives S = floor(ln u /
    ln albedo) real collisions (see the module docstring); without null collisions S is capped at
    max_collisions - 1, so one count-down also ends the walk there.
    """
    n = dr.width(rng.state)
    walk_rng = Xoroshiro64.from_pcg32(rng)
    ch = dr.arange(UInt32, n) % 3
    inv = [dr.opaque(Float, _inv_log(a)) for a in c.albedo]
    inv = dr.select(ch == 0, inv[0], dr.select(ch == 1, inv[1], inv[2]))
    cap = dr.opaque(Float, float(c.max_collisions if c.majorant_ratio != 1.0 else c.max_collisions - 1))
    u = (Float(walk_rng.next_uint32() >> 9) + 0.5) * 2.0 ** -23           # in (0, 1), never 0 or 1
    left = UInt32(dr.minimum(log_unit(u) * inv, cap))
    z = 1.0 - 2.0 * walk_rng.next_float32()
    cp, sp = unit_circle(walk_rng.next_float32())
    r = dr.sqrt(dr.maximum(1.0 - z * z, 0.0))
    return _Emitted(Array3f(r * cp, r * sp, z), left, walk_rng)


def _hashed_uniform(ray: UInt32, k: UInt32, key: UInt32) -> Float:
    """The reservoir's number for a ray's k-th crossing in the image: uniform in [0, 1), a hash
    (lowbias32) of the ray, k and the launch's ``key``.

    It depends on no number the photon's walk draws, so it is independent of which crossings
    there are, as reservoir sampling needs; drawing it from the photon's generator instead would
    cost a draw on every step (drawing in the branch routes the generator through its merge).
    """
    x = (ray * 0x9E3779B9) ^ (k * 0x85EBCA6B) ^ key
    x = (x ^ (x >> 16)) * 0x7FEB352D
    x = (x ^ (x >> 15)) * 0x846CA68B
    return Float((x ^ (x >> 16)) >> 8) * 2.0 ** -24


def _cone(radius_px: float, focal_px: float) -> tuple[float, float]:
    """The cheap test for crossings that may land in the image: (cos_lo, near_fraction).

    A crossing landing within ``radius_px`` of the centre on both axes is within sqrt(2)
    radius_px of it, at an angle to the sphere's normal with tangent tan_c = sqrt(2) radius_px /
    focal_px at most. The crossing test's disc equals d^2 cos^2(angle), so the walk projects a
    crossing only if disc >= cos_lo^2 d^2, cos_lo that of the tangent 1.1 tan_c + 0.01: never
    less than what the exact projection keeps as long as disc's rounding (<= 12 eps R^2 with
    |p| <= R = d + escape) stays under d^2 (cos_c^2 - cos_lo^2). Walks with d below
    ``near_fraction`` R, where that could fail (with a factor 10 to spare), project every crossing.
    """
    tan_c = math.sqrt(2.0) * radius_px / focal_px
    cos_c = 1.0 / math.sqrt(1.0 + tan_c * tan_c)
    tan_lo = 1.1 * tan_c + 0.01
    cos_lo = 1.0 / math.sqrt(1.0 + tan_lo * tan_lo)
    return cos_lo, math.sqrt(1e-5 / max(cos_c * cos_c - cos_lo * cos_lo, 1e-30))


def _inv_log(albedo: float) -> float:
    """1 / ln(albedo): a photon survives j real collisions iff j <= ln(u) * this (u in (0, 1))."""
    if albedo >= 1.0:
        return _NEVER
    return 0.0 if albedo <= 0.0 else 1.0 / math.log(albedo)


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
        """Per ray: a photon from the light in channel ray mod 3, tracked until absorbed or lost;
        one of its camera crossings (see the module docstring)."""
        c = self.config
        o = dr.opaque
        n = dr.width(coords[0])
        # per ray: k << 1 | crossed in the low word, the reservoir's pixel (packed) in the high one
        # (one 64-bit scatter per ended photon costs half of two 32-bit ones)
        results = dr.zeros(UInt64, n)
        dr.make_opaque(results)
        inv_sbar = o(Float, 1.0 / (c.medium_density * c.majorant_ratio))
        real_p = o(Float, 1.0 / c.majorant_ratio)
        g = o(Float, c.g)
        fpx = o(Float, c.focal_length_px)
        null_collisions = c.majorant_ratio != 1.0
        # pixels the tracer bins at k = floor(offset + 1/2), kept to [lo, hi]: the image less a
        # PSF_MARGIN_PX border, which the sparsifier needs empty (crossings there count as outside)
        half = c.psf_resolution // 2
        lo, hi = PSF_MARGIN_PX - half, c.psf_resolution - 1 - half - PSF_MARGIN_PX
        scale, hole = self.bins()
        cos_lo, near_fraction = _cone((max(-lo, hi) + 0.5) * scale, c.focal_length_px)
        cos_lo2, near_fraction = o(Float, cos_lo * cos_lo), o(Float, near_fraction)
        escape = o(Float, c.escape_mfp / c.medium_density)
        lo, hi = o(Float, lo), o(Float, hi)
        inv_scale, hole = o(Float, 1.0 / scale), o(Float, hole)
        # every photon's start, computed for all rays at once (all lanes busy) and gathered by a
        # lane when it takes the photon: cheaper than computing it there for the whole packet
        first = _emitted(rng, c)
        dist_all = coords[0]
        dr.eval(first, dist_all)
        key = dr.gather(UInt32, first.rng.s1, UInt32(0))          # this launch's reservoir hash key
        dr.make_opaque(key)

        def start(ray, valid):
            m = dr.width(ray)
            f = dr.gather(_Emitted, first, ray, valid)
            photon = (_NullPhoton if null_collisions else _Photon)(
                p=dr.zeros(Array3f, m), w=f.w, dist=dr.gather(Float, dist_all, ray, valid), left=f.left,
                alive=dr.full(Bool, True, m), count=dr.zeros(UInt32, m), pixel=dr.zeros(UInt32, m), rng=f.rng)
            if null_collisions:
                photon.steps = dr.opaque(UInt32, c.max_collisions - 1) + dr.zeros(UInt32, m)
            return (photon,)

        def project(ray, ph, t):
            """Where the crossing at p + t w lands: a pinhole camera there looking at the light;
            the reservoir keeps it with probability 1/k."""
            x = dr.fma(ph.w, t, ph.p)
            nrm = dr.select(ph.dist > 1e-6, x * dr.rsqrt(dr.squared_norm(x)), ph.w)
            e1, e2 = frame(nrm)
            inv = fpx / dr.dot(ph.w, nrm)
            if scale == 1:
                kx = dr.floor(dr.fma(dr.dot(ph.w, e1), inv, 0.5))
                ky = dr.floor(dr.fma(dr.dot(ph.w, e2), inv, 0.5))
                seen = (kx >= lo) & (kx <= hi) & (ky >= lo) & (ky <= hi)
            else:  # PSF pixels of scale^2 image pixels; the image pixels of the hole are not seen
                ix, iy = dr.dot(ph.w, e1) * inv, dr.dot(ph.w, e2) * inv
                kx, ky = dr.floor(dr.fma(ix, inv_scale, 0.5)), dr.floor(dr.fma(iy, inv_scale, 0.5))
                in_hole = (dr.abs(dr.floor(ix + 0.5)) <= hole) & (dr.abs(dr.floor(iy + 0.5)) <= hole)
                seen = (kx >= lo) & (kx <= hi) & (ky >= lo) & (ky <= hi) & ~in_hole
            ph.count = dr.select(seen, ph.count + 2, ph.count)
            k = ph.count >> 1
            take = seen & (_hashed_uniform(ray, k, key) * Float(k) < 1.0)
            packed = UInt32(Int32(kx) + _PIXEL_BIAS) | (UInt32(Int32(ky) + _PIXEL_BIAS) << 16)
            ph.pixel = dr.select(take, packed, ph.pixel)
            return ph

        def step(ray, ph):
            s = -log_unit(1.0 - ph.rng.next_float32()) * inv_sbar
            # outward crossing of |x| = d on the flight [p, p + s w]: the larger root t+
            b = dr.dot(ph.p, ph.w)
            d2 = ph.dist * ph.dist
            disc = dr.fma(b, b, d2 - dr.squared_norm(ph.p))
            t = dr.sqrt(dr.maximum(disc, 0.0)) - b
            cross = ph.alive & (disc >= 0) & (t >= 0) & (t <= s)
            reach = ph.dist + escape
            cone = dr.select(ph.dist <= near_fraction * reach, 0.0, cos_lo2 * d2)
            ph = dr.if_stmt((ray, ph, t), cross & (disc >= cone), project, lambda ray, ph, t: ph)
            ph.count = ph.count | UInt32(cross)
            ph.p = dr.fma(ph.w, s, ph.p)
            if null_collisions:
                real = ph.rng.next_float32() < real_p
                go_on = (~real | (ph.left > 0)) & (ph.steps > 0)
                ph.left = dr.select(real, ph.left - 1, ph.left)
                ph.steps = ph.steps - 1
            else:
                go_on = ph.left > 0
                ph.left = ph.left - 1
            mu, sin = hg_sample(g, ph.rng.next_float32())
            w = scatter_direction(ph.w, mu, sin, ph.rng.next_float32())
            ph.w = dr.select(real, w, ph.w) if null_collisions else w
            ph.alive &= go_on & (dr.squared_norm(ph.p) <= reach * reach)
            return (ph,)

        def store(ray, ph):
            dr.scatter(results, UInt64(ph.count) | (UInt64(ph.pixel) << 32), ray)

        run_walks(n, min(n, WALK_LANES), start, step, lambda ph: ph.alive, store)
        dr.eval(results)
        counts, pixels = UInt32(results & 0xFFFFFFFF), UInt32(results >> 32)
        k = counts >> 1
        hit = Array2f(Float(Int32(pixels & 0xFFFF) - _PIXEL_BIAS), Float(Int32(pixels >> 16) - _PIXEL_BIAS))
        far = 4.0 * float(c.psf_resolution)
        offset = dr.select(k > 0, hit, Array2f(far, far))             # crossings all beside the image
        return RayHits(offset, active=(counts & 1) == 1, channel=dr.arange(UInt32, n) % 3,
                       weight=dr.maximum(k, 1))

    def bins(self) -> tuple[int, int]:
        """(image pixels per PSF pixel along each axis, the half-width in image pixels of the
        centre square whose crossings are not counted; -1: none). The volume's own PSFs: (1, -1)."""
        return 1, -1

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
        PSF's energy relative to the same point without the medium (estimate; channel c gets the
        rays i = c mod 3, n/3 of them up to one per launch)."""
        per_channel = result.n_rays / 3.0
        return result.counts.sum(axis=(0, 1)) / per_channel
