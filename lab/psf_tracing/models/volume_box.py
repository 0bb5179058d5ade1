"""Volume in a box: the scattered light of a point seen through a segment of homogeneous medium.

A ``[medium]`` with a ``box`` fills only that box. A pixel's light leaves the point it sees, at
distance D from the camera, and crosses medium only over the segment [t0, t1] of its camera ray
inside the box (:mod:`runtime_cl.coords.medium_box`). Its PSF depends on the three lengths along
the ray, the PSF coordinates (metres, each in [0, max]):

- ``camera_gap_m`` a = t0 (clear air between the camera and the box; a halo formed far from the
  camera subtends a smaller angle),
- ``medium_length_m`` L = t1 - t0 (how much the light scatters),
- ``light_gap_m`` g = D - t1 (clear air between the point and the box; light scattered close to
  the point is seen at a smaller angle than light scattered close to the camera).

Geometry (the approximation): the medium is the spherical shell g <= |x| <= g + L about the light,
the camera on the sphere |x| = d = a + L + g. Along the light-camera line this is the segment
exactly; off it the shell curves about the light where the box's wall is flat and unbounded where
the box ends. The halo a PSF window holds comes from within a few degrees of that line, where the
shell and a slab agree to second order in the angle. The shell keeps the spherical symmetry of
:mod:`lab.psf_tracing.models.volume`, so its exact camera trick holds: every crossing of the
camera sphere is a photon entering a camera there that looks at the light. Photons cross it once:
the shell lies inside it, and a photon leaving the shell outward never returns (|x| grows along
a straight line once it grows), while one leaving inward crosses the empty ball and re-enters.

Each photon leaves the light (origin) in a uniform direction, flies to the shell, and is tracked
there: a free path of optical depth Exp(1) is walked over the medium along its line (the shell's
one or two pieces of the line); a collision absorbs with probability 1 - albedo (drawn once per
photon as in :mod:`~lab.psf_tracing.models.volume`) or scatters by HG; a photon that runs out of
medium escapes and is projected where it crosses the camera sphere.

The stored PSF is the *scattered* light only: photons that never collided (exp(-sigma_t L) of
them, all in the centre pixel) are not counted, because the runtime adds that part per pixel
exactly, exp(-sigma_t L) times the pixel's colour, from the pixel's own L (a cell's PSF is
pre-filtered over its box of coordinates, so its transmittance would be a cell average). The
energy kept with each PSF (:meth:`energy`) is then the scattered light that reaches the window.
Symmetry ``rotation``.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import drjit as dr
from drjit.llvm import Array2f, Array3f, Bool, Float, Int32, UInt32, UInt64

from lab.errors import UserError
from lab.optics.media import frame, hg_sample, log_unit, scatter_direction
from lab.psf_tracing.models.base import register_model
from lab.psf_tracing.models.common import check_number
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.models.volume import WALK_LANES, Volume, _emitted, collisions_survived
from lab.psf_tracing.models.volume_config import VolumeConfig
from lab.psf_tracing.rng32 import Xoroshiro64
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits
from lab.psf_tracing.walks import run_walks

__all__ = ["VolumeBox", "VolumeBoxConfig"]

_PIXEL_BIAS = 1 << 15                 # a pixel offset k is stored as k + bias in 16 bits
_NAMES = ("camera_gap_m", "medium_length_m", "light_gap_m")


@dataclass(frozen=True)
class VolumeBoxConfig(VolumeConfig):
    """:class:`~lab.psf_tracing.models.volume_config.VolumeConfig`'s medium, camera and sampling,
    over the three lengths of the module docstring instead of one distance.

    Parameters (beside the volume's medium, camera, ``samples``, ``psf_resolution``, rays and
    ``seed``; ``min_distance_m``, ``max_distance_m``, ``escape_mfp`` and ``majorant_ratio`` do not
    apply: the medium is bounded and tracked exactly)
    ----------
    max_camera_gap_m, max_medium_length_m, max_light_gap_m : float, default 5, 2, 5
        Upper ends of the three PSF coordinates (metres, > 0; each starts at 0).
    box_center, box_axes, box_half_size : optional
        The box in the camera's frame (:func:`lab.medium_box.camera_frame`), recorded for the
        database's fingerprint and the runtime's per-pixel segments; the PSFs do not depend on it.
    """

    samples: int = 64
    max_camera_gap_m: float = 5.0
    max_medium_length_m: float = 2.0
    max_light_gap_m: float = 5.0
    box_center: tuple[float, float, float] | None = None
    box_axes: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]] | None = None
    box_half_size: tuple[float, float, float] | None = None

    def __post_init__(self):
        super().__post_init__()
        defaults = VolumeConfig()
        for key in ("min_distance_m", "max_distance_m", "escape_mfp", "majorant_ratio", "roulette_mfp"):
            if getattr(self, key) != getattr(defaults, key):
                raise UserError(f"{key} = {getattr(self, key)!r} does not apply to volume_box (its coordinates "
                                "are max_camera_gap_m, max_medium_length_m, max_light_gap_m; the box's medium is "
                                "tracked exactly); remove it")
        for key in ("max_camera_gap_m", "max_medium_length_m", "max_light_gap_m"):
            check_number(key, getattr(self, key))
        if min(self.albedo) <= 0.0:
            raise UserError(f"albedo = {list(self.albedo)!r}: a channel of albedo 0 scatters nothing, so its "
                            "scattered-light PSFs are empty; give every channel an albedo > 0")
        box = (self.box_center, self.box_axes, self.box_half_size)
        if any(v is None for v in box) and any(v is not None for v in box):
            raise UserError("box_center, box_axes and box_half_size come together (the scene's [medium] box "
                            "sets them); give all three or none")

    def header_box(self) -> dict | None:
        if self.box_center is None:
            return None
        return {"center": list(self.box_center), "axes": [list(a) for a in self.box_axes],
                "half_size": list(self.box_half_size)}


class _ShellPhoton:
    """One photon's walk in the shell (a Dr.Jit struct): position ``p``, direction ``w``, the
    shell's radii ``r0``, ``r1`` and the camera sphere's ``d``, real collisions it still survives
    ``left``, ``alive``, ``scattered`` (it has collided), ``hit`` (it escaped scattered and its
    camera crossing landed in the window), ``pixel`` (packed), generator ``rng``."""

    DRJIT_STRUCT = {"p": Array3f, "w": Array3f, "r0": Float, "r1": Float, "d": Float, "left": UInt32,
                    "alive": Bool, "scattered": Bool, "hit": Bool, "pixel": UInt32, "rng": Xoroshiro64}

    def __init__(self, **fields):
        for name, value in fields.items():
            setattr(self, name, value)


@register_model("volume_box")
class VolumeBox(Volume):
    """Scattered-light PSFs of a point seen through a segment of medium (LSR18's Volume, boxed)."""

    Config = VolumeBoxConfig

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        return NestedGrid.for_samples(c.samples, (c.beta,) * 3, ((0.0, c.max_camera_gap_m),
                                      (0.0, c.max_medium_length_m), (0.0, c.max_light_gap_m)), _NAMES)

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: a photon from the light in channel ray mod 3 through the shell (module docstring);
        where it crosses the camera sphere, if it scattered."""
        c = self.config
        o = dr.opaque
        n = dr.width(coords[0])
        results = dr.zeros(UInt64, n)
        dr.make_opaque(results)
        inv_sigma = o(Float, 1.0 / c.medium_density)
        g = o(Float, c.g)
        fpx = o(Float, c.focal_length_px)
        half = c.psf_resolution // 2
        lo, hi = o(Float, PSF_MARGIN_PX - half), o(Float, c.psf_resolution - 1 - half - PSF_MARGIN_PX)
        first = _emitted(Xoroshiro64.from_pcg32(rng))
        survived = collisions_survived(first.lnu, dr.arange(UInt32, n) % 3, c)   # channel ray mod 3
        gap_cam, length, gap_light = coords
        dr.eval(first, survived, gap_cam, length, gap_light)

        def start(ray, valid):
            m = dr.width(ray)
            f = dr.gather(type(first), first, ray, valid)
            left = dr.gather(UInt32, survived, ray, valid)
            r0 = dr.gather(Float, gap_light, ray, valid)
            r1 = r0 + dr.gather(Float, length, ray, valid)
            d = r1 + dr.gather(Float, gap_cam, ray, valid)
            # clear air from the light to the shell: the photon enters it at radius r0
            return (_ShellPhoton(p=f.w * r0, w=f.w, r0=r0, r1=r1, d=d, left=left, alive=dr.full(Bool, True, m),
                                 scattered=dr.full(Bool, False, m), hit=dr.full(Bool, False, m),
                                 pixel=dr.zeros(UInt32, m), rng=f.rng),)

        def step(ray, ph):
            tau = -log_unit(1.0 - ph.rng.next_float32()) * inv_sigma      # metres of medium to fly
            b = dr.dot(ph.p, ph.w)
            pp = dr.squared_norm(ph.p)
            t_out = dr.maximum(dr.sqrt(dr.maximum(dr.fma(b, b, ph.r1 * ph.r1 - pp), 0.0)) - b, 0.0)
            disc_in = dr.fma(b, b, ph.r0 * ph.r0 - pp)
            through = (disc_in > 0) & (b < 0) & (ph.r0 > 0)                # the line crosses the empty ball
            root = dr.sqrt(dr.maximum(disc_in, 0.0))
            t_a, t_b = dr.maximum(-b - root, 0.0), -b + root
            first_piece = dr.select(through, t_a, t_out)
            second_piece = dr.select(through, dr.maximum(t_out - t_b, 0.0), 0.0)
            in_first = tau <= first_piece
            collide = in_first | (tau - first_piece <= second_piece)
            t = dr.select(in_first, tau, t_b + (tau - first_piece))
            # an escaping photon crosses the camera sphere |x| = d ahead (d >= r1 >= |p|)
            t_cam = dr.sqrt(dr.maximum(dr.fma(b, b, ph.d * ph.d - pp), 0.0)) - b
            escape = ph.alive & ~collide
            x = dr.fma(ph.w, t_cam, ph.p)
            nrm = x * dr.rsqrt(dr.maximum(dr.squared_norm(x), 1e-30))
            e1, e2 = frame(nrm)
            inv = fpx / dr.dot(ph.w, nrm)
            kx = dr.floor(dr.fma(dr.dot(ph.w, e1), inv, 0.5))
            ky = dr.floor(dr.fma(dr.dot(ph.w, e2), inv, 0.5))
            seen = escape & ph.scattered & (kx >= lo) & (kx <= hi) & (ky >= lo) & (ky <= hi)
            ph.hit |= seen
            packed = UInt32(Int32(kx) + _PIXEL_BIAS) | (UInt32(Int32(ky) + _PIXEL_BIAS) << 16)
            ph.pixel = dr.select(seen, packed, ph.pixel)
            # a collision: absorbed when no survivals are left, else scattered by HG
            ph.p = dr.select(collide, dr.fma(ph.w, t, ph.p), ph.p)
            go_on = collide & (ph.left > 0)
            ph.left = dr.select(collide, ph.left - 1, ph.left)
            mu, sin = hg_sample(g, ph.rng.next_float32())
            w = scatter_direction(ph.w, mu, sin, ph.rng.next_float32())
            ph.w = dr.select(collide, w, ph.w)
            ph.scattered |= collide
            ph.alive &= go_on
            return (ph,)

        def store(ray, ph):
            dr.scatter(results, UInt64(UInt32(ph.hit)) | (UInt64(ph.pixel) << 32), ray)

        run_walks(n, min(n, WALK_LANES), start, step, lambda ph: ph.alive, store)
        dr.eval(results)
        hit, pixels = (results & 1) == 1, UInt32(results >> 32)
        offset = Array2f(Float(Int32(pixels & 0xFFFF) - _PIXEL_BIAS), Float(Int32(pixels >> 16) - _PIXEL_BIAS))
        return RayHits(offset, active=hit, channel=dr.arange(UInt32, n) % 3)

    def fingerprint(self) -> dict:
        """The medium with its box and the pinhole's field of view a header must match."""
        out = super().fingerprint()
        box = self.config.header_box()
        if box is not None:
            out["medium"]["box"] = box
        return out
