"""Combined (LSR18 section 5.1, Tbl. 1): thin-lens depth of field plus linear motion blur.

ns = 2 (3 with a shaped aperture, below), monochrome. Coordinates: the |CoC radius| in pixels over [0, max_coc_px] (beta 2) and the
motion length in pixels over [0, max_motion_px] (beta 1), on a nested grid of 400 samples. Each
ray takes both from the cell's box (pre-filtering), the near-side depth whose CoC is -r (as
SimpleLens), an aperture point and a shutter time t; it lands where the thin lens sends it plus
the motion displacement (t - 1/2) * length along the reference direction
(:class:`lab.optics.motion.LinearMotion`). The result is the capsule: the aperture swept along a
segment, darker at the ends where fewer shutter times cover a pixel.

Symmetries (see :mod:`lab.psf_tracing.models.common`): ``coc_sign`` -- stored PSFs are points in
front of the focal plane; one behind it is drawn rotated by 180 degrees (the centred motion
segment maps onto itself, so this is exact). For the round aperture, ``motion_direction`` -- only
the reference direction ``motion_direction_deg`` is traced; a runtime rotates the spreadlets by
the pixel's motion angle minus it, which is exact for a disc.

A shaped aperture (polygon iris, star, heart, image) does not turn with the motion: its corners
stay put in the frame. Its PSFs take a third, uniform coordinate (``motion_angle``): the motion
direction modulo the aperture's turn period P (60 degrees for a hexagon, 72 for the star, 360 for
a heart), in ``angle_bins`` bins of width w = P / bins centred on 0, w, 2w, ... Each cell is traced
with the aperture upright and the motion direction drawn over its bin (pre-filtering); a pixel
moving at phi takes the bin of phi mod P and is drawn turned by phi minus the bin's centre: the
motion direction is exact and the aperture is off by at most w / 2 (and by none for motion along
a bin centre, e.g. horizontal). Turns by multiples of P are exact, as the shape maps onto itself.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import drjit as dr

from lab.errors import UserError
from lab.optics.aperture import Aperture
from lab.optics.motion import LinearMotion, offset_along_px
from lab.optics.thin_lens import ThinLens
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.common import (ApertureKeys, LensKeys, binned_grid, check_angle_bins, check_common,
                                           check_number, whole_launches)
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits

__all__ = ["Combined", "CombinedConfig", "min_combined_resolution"]


def min_combined_resolution(max_coc_px: float, max_motion_px: float, direction_deg: float | None = 0.0) -> int:
    """Smallest R whose image, centred at R//2, holds every capsule of the range plus the margin.

    The largest capsule reaches max_coc_px + |cos| max_motion_px / 2 from the centre along x and
    max_coc_px + |sin| max_motion_px / 2 along y (direction ``direction_deg``; None: any direction).
    """
    a = math.radians(direction_deg or 0.0)
    reach = 1.0 if direction_deg is None else max(abs(math.cos(a)), abs(math.sin(a)))
    half = max_coc_px + 0.5 * max_motion_px * reach
    return 2 * (math.ceil(half - 1e-9) + PSF_MARGIN_PX) + 1


@dataclass(frozen=True)
class CombinedConfig(LensKeys, ApertureKeys):
    """Settings of the Combined model (a scene's ``[psf.combined]`` table).

    Parameters
    ----------
    max_coc_px : float
        Largest |CoC radius| in pixels the database covers (> 0).
    max_motion_px : float
        Longest motion over the shutter in pixels (> 0; for no motion use ``simple_lens``).
    samples : int, default 400
        Minimum number of PSF samples (nested-grid cells; LSR18: 400).
    beta : (float, float), default (2.0, 1.0)
        Power-remapping exponents of (CoC, motion), each > 0 (LSR18: 2.0, 1.0).
    psf_resolution : int, default 512
        R, the PSF image edge in pixels; at least :func:`min_combined_resolution`.
    rays_per_psf : int, default 2**24
        Minimum rays per PSF.
    rays_per_pixel : int, default 8192
        Rays per pixel of the cell's largest capsule (aperture area (r + 1/2)^2 + (2 r + 1) l);
        a cell gets max(rays_per_psf, rays_per_pixel * area) rays, rounded up to whole launches.
    rays_per_launch : int, default 2**22
        Rays per Dr.Jit launch (1 .. 2**30), bounding memory.
    density : float, default 1.0
        Relative spreadlet density for the sparsifier (> 0).
    seed : int, default 0
        Random seed (>= 0); same seed, same PSFs bitwise.
    motion_direction_deg : float, default 0
        The reference direction traced for the round aperture, degrees counter-clockwise from
        image +x (y up); the runtime rotates from it (symmetry ``motion_direction``). A shaped
        aperture traces every direction (``angle_bins``) and takes none.
    angle_bins : int, optional
        Shaped apertures only: bins of the motion direction modulo the aperture's turn period
        (symmetry ``motion_angle``); default: bins of at most 10 degrees (6 for a hexagon, 8 for
        the star, 36 for a heart). ``samples`` PSFs are traced per bin.
    basis : {"dual", "laplacian"}, default "dual"
        What the sparsifier stores. ``"dual"``: every cell twice, as LSR18's Laplacian
        spreadlets and as row differences (:mod:`lab.sparsify.rows`); the runtime draws a pixel
        turned by 0 or pi (a still one: ``coc_sign``; one moving along the reference direction,
        horizontal by default) from its row differences, exactly and 2-4x sparser, and every
        other turn from its Laplacian. ``"laplacian"``: LSR18's alone.

    The ``aperture*`` keys (:class:`~lab.psf_tracing.models.common.ApertureKeys`) choose the
    iris, e.g. ``aperture = "polygon"``, ``aperture_blades = 6``; the ``lens_*`` keys
    (:class:`~lab.psf_tracing.models.common.LensKeys`) the canonical thin lens.
    """

    max_coc_px: float
    max_motion_px: float
    samples: int = 400
    beta: tuple[float, float] = (2.0, 1.0)
    psf_resolution: int = 512
    rays_per_psf: int = 2 ** 24
    rays_per_pixel: int = 8192
    rays_per_launch: int = 2 ** 22
    density: float = 1.0
    seed: int = 0
    motion_direction_deg: float = 0.0
    angle_bins: int | None = None
    basis: str = "dual"

    def __post_init__(self):
        check_number("max_coc_px", self.max_coc_px)
        if isinstance(self.max_motion_px, (int, float)) and self.max_motion_px == 0:
            raise UserError("max_motion_px = 0: the motion range must be > 0; without motion use the "
                            "simple_lens model")
        check_number("max_motion_px", self.max_motion_px)
        if isinstance(self.beta, list):
            object.__setattr__(self, "beta", tuple(self.beta))
        if not (isinstance(self.beta, tuple) and len(self.beta) == 2):
            raise UserError(f"beta = {self.beta!r}: needs two exponents (CoC, motion), e.g. [2.0, 1.0]")
        for b in self.beta:
            check_number("beta", b)
        check_common(self)
        LinearMotion(self.motion_direction_deg)
        period = self.check_aperture().turn_period_deg
        check_angle_bins(self, period)
        if period and self.motion_direction_deg != 0.0:
            raise UserError(f"motion_direction_deg = {self.motion_direction_deg!r}: aperture = {self.aperture!r} "
                            "traces every motion direction (angle_bins); remove the key")
        direction = None if self.angle_bins else self.motion_direction_deg
        need = min_combined_resolution(self.max_coc_px, self.max_motion_px, direction)
        if self.psf_resolution < need:
            raise UserError(
                f"psf_resolution = {self.psf_resolution} cannot hold a capsule of CoC radius "
                f"{self.max_coc_px} px and motion {self.max_motion_px} px plus a {PSF_MARGIN_PX}-pixel "
                f"margin; use psf_resolution >= {need} (or smaller max_coc_px / max_motion_px)")
        self.check_lens()
        if self.basis not in ("dual", "laplacian"):
            raise UserError(f"basis = {self.basis!r}: choose one of ['dual', 'laplacian'] (row differences "
                            "alone cannot be turned by a pixel's motion angle)")


@register_model("combined")
class Combined(PSFModel):
    """DoF + linear motion PSFs indexed by (|CoC radius|, motion length) in pixels, and for a shaped
    aperture the motion angle modulo its turn period in degrees."""

    Config = CombinedConfig
    channels = 1

    def __init__(self, config: CombinedConfig):
        super().__init__(config)
        self.lens: ThinLens = config.lens
        self.aperture: Aperture = config.build_aperture()
        self.motion = LinearMotion(config.motion_direction_deg)

    @property
    def symmetries(self) -> tuple:
        return ("motion_angle" if self.config.angle_bins else "motion_direction", "coc_sign")

    @property
    def reference_direction_deg(self) -> float:
        """The traced motion direction of the round aperture (counter-clockwise from image +x, y up)."""
        return self.config.motion_direction_deg

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        return binned_grid(c.samples, c.beta, ((0.0, c.max_coc_px), (0.0, c.max_motion_px)),
                           ("coc_radius_px", "motion_px"), c.angle_bins, self.aperture.turn_period_deg,
                           "motion_angle_deg")

    def rays_for_cell(self, cell: int) -> int:
        """max(rays_per_psf, rays_per_pixel * capsule area at the cell's largest r and l)."""
        c = self.config
        r, length = self.boxes[cell].hi[:2]
        area = self.aperture.area * (r + 0.5) ** 2 + (2.0 * r + 1.0) * length
        return whole_launches(max(c.rays_per_psf, math.ceil(c.rays_per_pixel * area)), c.rays_per_launch)

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: (|CoC| r, motion l[, motion angle]) -> near-side depth, aperture point, shutter
        time -> pixels."""
        r, length = coords[:2]
        width = self.config.lens_width_px
        inv_depth = self.lens.inv_depth_for_coc_px(-r, width)
        h = self.aperture.sample_rng(rng) * self.lens.aperture_radius_m
        t = rng.next_float32()
        if self.config.angle_bins:   # the ray's own direction, drawn over the cell's bin
            s, c = dr.sincos(dr.deg2rad(coords[2]))
            motion = offset_along_px(t, length, c, s)
        else:
            motion = self.motion.offset_px(t, length)
        return RayHits(self.lens.psf_offset_px(h, inv_depth, width) + motion)
