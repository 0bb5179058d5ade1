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

Colour: ray i is in channel i mod 3 (a third of the rays each, exactly), and rays 3i, 3i + 1,
3i + 2 share one photon path (as hero-wavelength sampling shares a path among wavelengths): only
absorption depends on the channel, and it is drawn once per path: with u uniform, channel c
survives its j-th real collision iff u <= albedo_c^j, i.e. j <= ln u / ln albedo_c -- the albedo
coin at every collision (P(j survived) = albedo_c^j, each collision independently), at one random
number per path. Each channel still gets n / 3 independent photons, so its PSF has the noise it
had with a path per ray; the channels' noise is correlated (the halo's grain is grey), and a path
costs about as much as one photon did.

A photon may cross the sphere more than once (out, back in, out). Each ray reports one of its
crossings that land in the image, chosen in proportion to their weights (weighted reservoir
sampling), with the integer weight W = the sum of the weights (:class:`RayHits` ``weight``), so
the expected histogram counts every crossing. A crossing weighs 2^k after k roulette shells:
a path first passing the radius d + (2^k - 1) ``roulette_mfp`` mean free paths survives with
probability 1/2 (whether it does is drawn at emission: :func:`_emitted`), so the expectation is
unchanged while walks far from the sphere end early; the shells spread out geometrically because
a path's chance to come back falls with its distance, which keeps the heavy weights rare (with
evenly spaced shells, outliers of weight up to 2^12 doubled the spread of a PSF's centroid). The image here excludes a
``PSF_MARGIN_PX`` border (the sparsifier needs it empty): the halo is cut off there. Rays whose
crossings all miss it land outside; rays absorbed or lost before crossing are blocked. Photons
are dropped once farther than d + ``escape_mfp`` mean free paths from the light, or after
``max_collisions`` collisions (a truncation whose effect the tests bound).

Speed (``splatlab bench precompute``; the tests keep the straightforward tracer as their
reference): photon paths run on persistent SIMD lanes (:func:`lab.psf_tracing.walks.run_walks`),
so a packet of 16 lanes does not wait for its longest walk (a packet of 16 photons takes ~2.9x
the mean number of collisions); a lane computes a path's start (direction, absorption, roulette,
generator) when it takes it, from the generator keyed by the path's first ray (computed up front
for all rays); the projection onto the camera runs only for crossings inside the image's cone (a
branch packets skip; :func:`_cone`); absorption costs one random number per path, not one per
collision; the numbers come from a 32-bit-lane generator (:mod:`lab.psf_tracing.rng32`), and
flights, azimuths and scattered directions use the cheaper forms of :mod:`lab.optics.media`
(:func:`~lab.optics.media.log_unit`, :func:`~lab.optics.media.unit_circle`). Each path's random
numbers depend only on its rays, so the PSF is bitwise the same however paths are spread over
lanes. At the benchmark's 5 m, a path took ~33 collisions without roulette and ~10 with it;
shared paths halve the time per ray and the roulette takes off another ~40 % at ~6 % more
variance per ray (measured against a 2^25-ray PSF: 3x the PSF accuracy per second in all).

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
from drjit.llvm import Array2f, Array3f, Array3u, Bool, Float, Int32, UInt32, UInt64

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
_ROULETTE_SHELLS = 12                 # roulette shells at most: weights stay <= 2^12 (UInt32 bins)


class _Photon:
    """The state of one photon path's walk, shared by its three channels (a Dr.Jit struct: loops
    and branches carry it field by field).

    ``p``, ``w``: position (m) and unit direction; ``dist``: the camera sphere's radius d;
    ``lnu``: ln u of its absorption draw (channel c survives S_c = floor(lnu / ln albedo_c) real
    collisions); ``j``: real collisions so far; ``alive``: the walk goes on; ``count`` (per
    channel): the summed weight W of the channel's crossings in the image, shifted left by one,
    or-ed with 1 once it has crossed the sphere at all; ``pixel`` (per channel): the reservoir's
    crossing (packed); ``level``: roulette shells passed (crossings weigh 2^level) in the low byte,
    the shell the path dies at in the next (drawn at emission); ``rng``: its generator. Few
    fields: each costs blends and spills every step.
    """

    DRJIT_STRUCT = {"p": Array3f, "w": Array3f, "dist": Float, "lnu": Float, "j": UInt32,
                    "alive": Bool, "count": Array3u, "pixel": Array3u, "level": UInt32,
                    "rng": Xoroshiro64}

    def __init__(self, **fields):
        for name, value in fields.items():
            setattr(self, name, value)


class _NullPhoton(_Photon):
    """:class:`_Photon` with ``steps``: tentative collisions left (Woodcock with null collisions)."""

    DRJIT_STRUCT = {**_Photon.DRJIT_STRUCT, "steps": UInt32}


class _Emitted:
    """A photon path as the light emits it: direction ``w``, ``lnu`` (its absorption draw),
    ``level`` (:class:`_Photon`'s: 0 shells passed, the roulette shell it dies at) and its
    generator ``rng`` after those draws (a Dr.Jit struct)."""

    DRJIT_STRUCT = {"w": Array3f, "lnu": Float, "level": UInt32, "rng": Xoroshiro64}

    def __init__(self, w=None, lnu=None, level=None, rng=None):
        self.w, self.lnu, self.level, self.rng = w, lnu, level, rng


def _emitted(walk_rng: Xoroshiro64) -> _Emitted:
    """A photon path's start from its generator (advanced past these draws).

    Absorption is drawn once for all channels: ln u, u uniform in (0, 1); channel c survives
    S_c = floor(ln u / ln albedo_c) real collisions (see the module docstring and
    :func:`_survives`). So is the roulette: the path dies at shell L + 1 with L the trailing zero
    bits of a uniform 32-bit number, P(L >= k) = 2^-k -- a fair coin at every shell, drawn at
    once (L >= _ROULETTE_SHELLS: it never dies).
    """
    lnu = log_unit((Float(walk_rng.next_uint32() >> 9) + 0.5) * 2.0 ** -23)   # u never 0 or 1
    z = 1.0 - 2.0 * walk_rng.next_float32()
    cp, sp = unit_circle(walk_rng.next_float32())
    r = dr.sqrt(dr.maximum(1.0 - z * z, 0.0))
    dies = dr.minimum(dr.tzcnt(walk_rng.next_uint32()), _ROULETTE_SHELLS) + 1
    return _Emitted(Array3f(r * cp, r * sp, z), lnu, dies << 8, walk_rng)


def _survives(lnu: Float, j: UInt32, inv_log: Float, cap: UInt32) -> Bool:
    """Whether a channel with 1 / ln(albedo) = ``inv_log`` is still carried on flight ``j``
    (after j real collisions): j <= S_c = min(floor(lnu * inv_log), cap), P(S_c >= j) =
    albedo^j -- an independent albedo coin at every collision, per channel."""
    return (Float(j) <= lnu * inv_log) & (j <= cap)


def collisions_survived(lnu: Float, channel: UInt32, c: VolumeConfig) -> UInt32:
    """S = min(floor(lnu / ln albedo), max_collisions - 1) of each photon's channel (a model that
    traces one channel per photon, like :mod:`~lab.psf_tracing.models.volume_box`)."""
    inv = [dr.opaque(Float, _inv_log(a)) for a in c.albedo]
    inv = dr.select(channel == 0, inv[0], dr.select(channel == 1, inv[1], inv[2]))
    return UInt32(dr.minimum(lnu * inv, float(c.max_collisions - 1)))


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
        """Per ray: a photon of channel ray mod 3, tracked until absorbed or lost; one of its
        camera crossings (see the module docstring). Rays 3i, 3i + 1, 3i + 2 share one path."""
        c = self.config
        o = dr.opaque
        n = dr.width(coords[0])
        paths = (n + 2) // 3
        # per ray: k << 1 | crossed in the low word, the reservoir's pixel (packed) in the high one
        # (one 64-bit scatter per ended photon costs half of two 32-bit ones)
        results = dr.zeros(UInt64, n)
        dr.make_opaque(results)
        inv_sbar = o(Float, 1.0 / (c.medium_density * c.majorant_ratio))
        real_p = o(Float, 1.0 / c.majorant_ratio)
        g = o(Float, c.g)
        fpx = o(Float, c.focal_length_px)
        null_collisions = c.majorant_ratio != 1.0
        inv_log = [o(Float, _inv_log(a)) for a in c.albedo]
        # without null collisions the last real collision a path survives is max_collisions - 1,
        # so counting real collisions also ends the walk there
        cap = o(UInt32, c.max_collisions if null_collisions else c.max_collisions - 1)
        inv_max = o(Float, min(_inv_log(a) for a in c.albedo))         # the longest-lived channel
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
        roulette = c.roulette_mfp > 0.0
        shell_step = o(Float, c.roulette_mfp / c.medium_density)
        # path i draws from the generator of ray 3i, computed here for all rays; its start is
        # computed by the lane that takes it
        gens = Xoroshiro64.from_pcg32(rng)
        dist_all = coords[0]
        dr.eval(gens, dist_all)
        key = dr.gather(UInt32, gens.s1, UInt32(0))               # this launch's reservoir hash key
        dr.make_opaque(key)

        def start(path, valid):
            m = dr.width(path)
            f = _emitted(dr.gather(Xoroshiro64, gens, 3 * path, valid))
            photon = (_NullPhoton if null_collisions else _Photon)(
                p=dr.zeros(Array3f, m), w=f.w, dist=dr.gather(Float, dist_all, 3 * path, valid),
                lnu=f.lnu, j=dr.zeros(UInt32, m), alive=dr.full(Bool, True, m),
                count=dr.zeros(Array3u, m), pixel=dr.zeros(Array3u, m), level=f.level, rng=f.rng)
            if null_collisions:
                photon.steps = dr.opaque(UInt32, c.max_collisions - 1) + dr.zeros(UInt32, m)
            return (photon,)

        def carried(ph):
            """Per channel: whether it is still carried on this flight."""
            return [ph.alive & _survives(ph.lnu, ph.j, inv, cap) for inv in inv_log]

        def project(path, ph, t, live):
            """Where the crossing at p + t w lands: a pinhole camera there looking at the light;
            each channel's reservoir keeps it with probability (its weight) / (the weights so far)."""
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
            weight = UInt32(1) << (ph.level & 0xFF)
            packed = UInt32(Int32(kx) + _PIXEL_BIAS) | (UInt32(Int32(ky) + _PIXEL_BIAS) << 16)
            for ch in range(3):
                seen_c = seen & live[ch]
                ph.count[ch] = dr.select(seen_c, ph.count[ch] + (weight << 1), ph.count[ch])
                total = ph.count[ch] >> 1
                u = _hashed_uniform(3 * path + ch, total, key)
                ph.pixel[ch] = dr.select(seen_c & (u * Float(total) < Float(weight)), packed, ph.pixel[ch])
            return ph

        def step(path, ph):
            s = -log_unit(1.0 - ph.rng.next_float32()) * inv_sbar
            # outward crossing of |x| = d on the flight [p, p + s w]: the larger root t+
            b = dr.dot(ph.p, ph.w)
            d2 = ph.dist * ph.dist
            disc = dr.fma(b, b, d2 - dr.squared_norm(ph.p))
            t = dr.sqrt(dr.maximum(disc, 0.0)) - b
            cross = ph.alive & (disc >= 0) & (t >= 0) & (t <= s)
            reach = ph.dist + escape
            cone = dr.select(ph.dist <= near_fraction * reach, 0.0, cos_lo2 * d2)
            live = carried(ph)
            ph = dr.if_stmt((path, ph, t, live), cross & (disc >= cone), project,
                            lambda path, ph, t, live: ph)
            for ch in range(3):
                ph.count[ch] = ph.count[ch] | UInt32(cross & live[ch])
            ph.p = dr.fma(ph.w, s, ph.p)
            # the path goes on while its longest-lived channel survives this collision
            if null_collisions:
                real = ph.rng.next_float32() < real_p
                go_on = (~real | _survives(ph.lnu, ph.j + 1, inv_max, cap)) & (ph.steps > 0)
                ph.j = dr.select(real, ph.j + 1, ph.j)
                ph.steps = ph.steps - 1
            else:
                go_on = _survives(ph.lnu, ph.j + 1, inv_max, cap)
                ph.j = ph.j + 1
            mu, sin = hg_sample(g, ph.rng.next_float32())
            w = scatter_direction(ph.w, mu, sin, ph.rng.next_float32())
            ph.w = dr.select(real, w, ph.w) if null_collisions else w
            r2 = dr.squared_norm(ph.p)
            if roulette:
                passed = ph.level & 0xFF
                shell = dr.fma(shell_step, Float((UInt32(2) << passed) - 1), ph.dist)
                past = ph.alive & (passed < _ROULETTE_SHELLS) & (r2 > shell * shell)
                ph.level = dr.select(past, ph.level + 1, ph.level)
                go_on &= ~(past & ((ph.level & 0xFF) == (ph.level >> 8)))
            ph.alive &= go_on & (r2 <= reach * reach)
            return (ph,)

        def store(path, ph):
            for ch in range(3):
                ray = 3 * path + ch
                dr.scatter(results, UInt64(ph.count[ch]) | (UInt64(ph.pixel[ch]) << 32), ray, ray < n)

        run_walks(paths, min(paths, WALK_LANES), start, step, lambda ph: ph.alive, store)
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
