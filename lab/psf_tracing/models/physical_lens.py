"""PhysicalLens (LSR18 section 5.1, Tbl. 1): a thick spherical lens traced by Snell's law, RGB.

ns = 2: the depth of a point (metres from the entrance pupil, over [near_m, far_m], beta 2.5) and
its eccentricity (pixels from the image centre, over [0, max_eccentricity_px], beta 1.2), on a
nested grid of 4000 samples. Three channels, one wavelength each (LES10: 650, 510, 475 nm).

Each ray takes a depth and an eccentricity from the cell's box (pre-filtering) and a channel; the
object point lies right of the axis (+x) where a pinhole at the entrance-pupil centre with focal
distance k (the paraxial chief-ray scale, :meth:`LensSystem.chief_scale_mm`) sees that
eccentricity. :meth:`ThickLensCamera.trace_point` emits it isotropically (exactly uniform in solid
angle) and refracts it through every surface at the channel's index (:mod:`lab.optics.glass`) to
the sensor. The PSF is where the ray lands relative to that pinhole image, in image pixels, so the
lens's distortion and lateral colour show up as offsets (about -6 % and 3 px at the default
lens's corners). Rays rejected by the draw, missing a surface, clipped by an opening or totally
reflected get weight 0 and are counted (:meth:`PhysicalLens.ray_statistics` splits them;
vignetting is the share of the light through the stop that is lost later).

Symmetry ``optical_axis``: the lens is rotation symmetric, so only points right of the image
centre (image +x, ``reference_direction_deg`` = 0) are traced; a runtime draws a pixel at
azimuth phi (counter-clockwise from image +x, y up, as ``motion_direction``) about the image
centre with the stored PSF rotated by phi, and looks it up by its distance from the centre.

A shaped stop (``aperture*`` keys: an iris, a star) breaks that symmetry only through the stop:
turning the whole lens about its axis by phi maps the point at azimuth 0 seen through the stop
turned by -phi onto the pixel at phi seen through the stop. So a third, uniform coordinate
(symmetry ``stop_turn``) holds phi modulo the stop's turn period P in ``angle_bins`` bins; a cell
traces the point at azimuth 0 through the stop turned by minus an angle drawn over its bin, and
the runtime turns the PSF by phi as before. The stop's orientation is then off by at most half a
bin; a turn by a multiple of P maps the stop onto itself.
"""
from __future__ import annotations

import math
from functools import cached_property

import drjit as dr
import numpy as np
from drjit.llvm import Array2f, Float, UInt32

from lab.errors import UserError
from lab.optics.thick_lens import STATUS_OK
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.common import binned_grid, whole_launches
from lab.psf_tracing.models.physical_lens_config import PhysicalLensConfig
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits, lane_rng, trace_psf

__all__ = ["PhysicalLens", "PhysicalLensConfig", "PILOT_RAYS"]

PILOT_RAYS = 2 ** 17  # rays of the quick trace that measures a cell's PSF support


@register_model("physical_lens")
class PhysicalLens(PSFModel):
    """Thick spherical lens PSFs over (depth, eccentricity), RGB (LSR18's PhysicalLens)."""

    Config = PhysicalLensConfig
    channels = 3
    # A lens's caustics are thin rims, which TAU's 0.5-1 px blur at 2048 rays per pixel softened:
    # rain at 256^2 scored spreadlets 0.942 against Splat's 0.951 (Splat of the PSFs so blurred:
    # 0.943); at 0.1 (0-0.5 px) spreadlets 0.949, at 0.03 0.947 (2026-12-03, README).
    denoise_tau = 0.1
    reference_direction_deg = 0.0  # traced pixels lie at image +x of the centre (see symmetry)

    def __init__(self, config: PhysicalLensConfig):
        super().__init__(config)
        self.camera = config.camera
        self._resolution_ok = False

    @property
    def symmetries(self) -> tuple:
        return ("optical_axis", "stop_turn") if self.config.angle_bins else ("optical_axis",)

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        period = self.camera.stop_shape.turn_period_deg if c.angle_bins else 0.0
        return binned_grid(c.samples, c.beta, ((c.near_m, c.far_m), (0.0, c.max_eccentricity)),
                           ("depth_m", "eccentricity_px"), c.angle_bins, period, "stop_turn_deg")

    def fingerprint(self) -> dict:
        """What a ``"thick"`` header (:mod:`runtime_cl.camera.thick_lens`) must say of the traced
        lens: its surfaces, paraxial focal length at the focus wavelength, focus distance and
        rule, and sensor width; and no medium (:meth:`PSFModel.fingerprint`)."""
        c = self.config
        return super().fingerprint() | {
            "surfaces": [list(row) for row in c.surfaces], "focus": c.focus,
            "focal_length_mm": self.camera.lens.effective_focal_length_mm(c.focus_wavelength_nm),
            "focus_distance_m": c.focus_distance_m, "sensor_width_mm": c.sensor_width_mm}

    # --- per ray --------------------------------------------------------------------------------
    def _trace(self, coords, rng, status: bool = False):
        cam = self.camera
        c = dr.opaque
        depth = coords[0] * 1000.0                                   # mm from the entrance pupil
        tan_f = coords[1] * c(Float, 1.0 / (cam.px_per_mm * cam.chief_scale_mm))
        px, pz = tan_f * depth, c(Float, cam.pupil_z_mm) - depth     # object point (px, 0, pz)
        u_r, u_phi = rng.next_float32(), rng.next_float32()
        # one number gives the channel and the keep draw (its remaining ~22 bits)
        u = rng.next_float32() * float(self.channels)
        ch = dr.minimum(UInt32(u), self.channels - 1)
        eta = [self._eta(ch, i) for i in range(len(cam.lens))]
        turn = None
        if self.config.angle_bins:   # the pixel at azimuth phi: the stop turned by -phi
            s, co = dr.sincos(dr.deg2rad(coords[2]))
            turn = (co, -s)
        sx, sy, ok, code, keep = cam.trace_point(px, pz, u_r, u_phi, u - Float(ch), eta, status, turn)
        centre = -cam.chief_scale_mm * tan_f                         # pinhole image of the point
        k = c(Float, cam.px_per_mm)
        offset = Array2f(-k * (sx - centre), k * sy)                  # image (col right, row down)
        return offset, ok, ch, code, keep

    def _eta(self, ch, i: int):
        """Relative index at surface i for channel ``ch`` (a select over the channels' values)."""
        values = self.camera.eta[i]
        if all(v == values[0] for v in values):
            return dr.opaque(Float, values[0])
        e = dr.opaque(Float, values[-1])
        for j in range(len(values) - 2, -1, -1):
            e = dr.select(ch == j, dr.opaque(Float, values[j]), e)
        return e

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: (depth m, eccentricity px[, stop turn deg]) -> object point -> lens -> sensor,
        image pixels."""
        offset, active, ch, _, _ = self._trace(coords, rng)
        return RayHits(offset, active=active, channel=ch)

    # --- statistics and checks ------------------------------------------------------------------
    def ray_statistics(self, lo, hi, n_rays: int = 2 ** 20, seed: int = 0) -> dict:
        """Where ``n_rays`` rays drawn over the box [lo, hi] (depth m, eccentricity px) end.

        Returns
        -------
        dict
            ``rays``; ``rejected`` (by the solid-angle draw); ``missed_entrance`` and ``stopped``
            (outside the first surface or the stop when rays are drawn on the first surface's
            plane; 0 when they are drawn on the stop's opening); ``vignetted`` (clipped by any
            other opening); ``total_internal_reflection``; ``reached`` (the sensor); and
            ``vignetting_rate`` = (vignetted + total internal reflection) / (those + reached):
            the share of the light through the stop that is lost. (With refracting elements in
            front of the stop, a ray clipped there counts as vignetted even if the stop would
            have blocked it too.)
        """
        rng = lane_rng(n_rays, seed)
        coords = [dr.opaque(Float, a) + dr.opaque(Float, b - a) * rng.next_float32() for a, b in zip(lo, hi)]
        _, _, _, code, accept = self._trace(coords, rng, status=True)
        rejected = 1 + 2 * len(self.camera.lens) + 1
        values = np.asarray(dr.select(accept, code, UInt32(rejected)).numpy(), np.int64)
        hist = np.bincount(values, minlength=rejected + 1)
        n, stop = len(self.camera.lens), self.camera.lens.stop
        drawn_on_stop = self.camera.first_traced > 0
        entrance = 0 if drawn_on_stop else int(hist[1])
        shaped = self.camera.stop_shape is not None   # its shape stops rays drawn on the round opening
        stopped = 0 if (drawn_on_stop and not shaped) or stop == 0 else int(hist[1 + stop])
        vignetted = int(hist[1:1 + n].sum()) - entrance - stopped
        tir = int(hist[1 + n:2 + 2 * n].sum())
        reached = int(hist[STATUS_OK])
        lost = vignetted + tir
        return {"rays": int(n_rays), "rejected": int(hist[rejected]), "missed_entrance": entrance,
                "stopped": stopped, "vignetted": vignetted, "total_internal_reflection": tir,
                "reached": reached, "vignetting_rate": lost / (lost + reached) if lost + reached else 0.0}

    def required_resolution(self, n_rays: int = PILOT_RAYS) -> int:
        """Smallest odd R holding the PSFs at the corners of the space (near/far depth x centre,
        half and full eccentricity), measured by tracing ``n_rays`` each into a large image."""
        c = self.config
        big = 4 * max(c.psf_resolution, 64) + 1
        reach = 0
        for depth in (c.near_m, c.far_m, min(max(c.focus_distance_m, c.near_m), c.far_m)):
            for ecc in (0.0, 0.5 * c.max_eccentricity, c.max_eccentricity):
                point = (depth, ecc) + ((0.0,) if c.angle_bins else ())   # the stop unturned
                t = trace_psf(self.rays, point, point, big, n_rays, c.seed, channels=3)
                if t.n_outside:
                    raise UserError(f"physical_lens: the PSF at depth {depth} m, eccentricity {ecc} px "
                                    f"is wider than {big} px; check the lens, near_m and far_m")
                rows, cols = np.nonzero(t.counts.sum(axis=2))
                reach = max(reach, int(np.abs(rows - big // 2).max()), int(np.abs(cols - big // 2).max()))
        margin = 2 + math.ceil(0.1 * reach)  # rarer rays of a full trace reach a little farther
        return 2 * (reach + margin) + 1

    def check_resolution(self) -> None:
        """UserError (before the first real trace) if psf_resolution cannot hold the PSFs."""
        if not self._resolution_ok:
            need = self.required_resolution()
            if self.config.psf_resolution < need:
                raise UserError(f"physical_lens: psf_resolution = {self.config.psf_resolution} cannot hold "
                                f"the widest PSFs of this lens and depth range; use psf_resolution >= {need} "
                                "(or narrow near_m .. far_m)")
            self._resolution_ok = True

    def trace_checked(self, cell: int, n_rays: int | None = None, seed: int | None = None):
        """:meth:`PSFModel.trace_checked` after :meth:`check_resolution` (once per model)."""
        self.check_resolution()
        return super().trace_checked(cell, n_rays, seed)

    def rays_for_cell(self, cell: int) -> int:
        """max(rays_per_psf, rays_per_pixel * 3 * support / landed share), whole launches.

        The support (pixels hit in any channel) and the share of rays that land come from a
        quick pilot trace of :data:`PILOT_RAYS` rays, so every cell has about the same relative
        noise per pixel and channel, ~1/sqrt(rays_per_pixel)."""
        c = self.config
        pilot = self.trace_cell(cell, n_rays=PILOT_RAYS, seed=c.seed)
        support = int(np.count_nonzero(pilot.counts.sum(axis=2)))
        landed = max(int(pilot.counts.sum()), 1) / pilot.n_rays
        n = max(c.rays_per_psf, math.ceil(c.rays_per_pixel * self.channels * support / landed))
        return whole_launches(n, c.rays_per_launch)
