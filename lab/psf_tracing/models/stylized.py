"""Stylized (LSR18 section 5.1, Tbl. 1): bokeh in the shape of an aperture image, with colour fringes.

ns = 1, RGB. The coordinate is the distance to the focal plane expressed as the |CoC radius| in
pixels over [0, max_coc_px] (beta 1.5, 200 samples): the thin lens maps depth to CoC linearly in
1/z, so one database serves every lens and focus, and the PSF is the aperture image scaled to
that radius. Channel c is scaled once more by ``channel_scale[c]``: unequal scales give the
coloured fringes of longitudinal chromatic aberration (with the default, red spreads widest).

Each ray takes its radius from the cell's box (pre-filtering), a channel uniformly, a point of the
aperture (intensity-weighted for image apertures) scaled by the channel's factor, and goes through
the canonical thin lens from the near-side depth whose CoC is -r, like SimpleLens.

Orientation (symmetry ``coc_sign``, see :mod:`lab.psf_tracing.models.common`): the stored PSFs are
those of points in front of the focal plane, where a lens shows the aperture rotated by 180
degrees -- a star with a tip up is stored tip down. A runtime draws points behind the focal plane
(signed CoC > 0, the background) with the PSF rotated by 180 degrees, i.e. upright.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import drjit as dr
from drjit.llvm import Float, UInt32

from lab.errors import UserError
from lab.optics.aperture import Aperture
from lab.optics.thin_lens import ThinLens
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.common import (ApertureKeys, BasisKeys, LensKeys, check_common, check_number,
                                           whole_launches)
from lab.psf_tracing.models.simple_lens import min_psf_resolution
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits

__all__ = ["Stylized", "StylizedConfig"]


@dataclass(frozen=True)
class StylizedConfig(LensKeys, ApertureKeys, BasisKeys):
    """Settings of the Stylized model (a scene's ``[psf.stylized]`` table).

    Parameters
    ----------
    max_coc_px : float
        Largest |CoC radius| in pixels the database covers (> 0).
    aperture : str, default "star"
        The bokeh shape: ``star``, ``heart``, ``image`` (with ``aperture_image = "file.png"``),
        ``polygon`` or ``circle``; the other ``aperture*`` keys as in
        :class:`~lab.psf_tracing.models.common.ApertureKeys`.
    channel_scale : (float, float, float), default (1.0, 0.95, 0.9)
        Size of the R, G, B PSFs relative to the CoC radius (each > 0).
    samples : int, default 200
        Minimum number of PSF samples (LSR18: 200).
    beta : float, default 1.5
        Power-remapping exponent (> 0; LSR18: 1.5).
    psf_resolution : int, default 512
        R; must hold 2 (max(channel_scale) max_coc_px + margin) + 1 pixels.
    rays_per_psf : int, default 3 * 2**23
        Minimum rays per PSF (all channels together).
    rays_per_pixel : int, default 8192
        Rays per pixel of each channel's shape (aperture area x (scale r + 1/2)^2 at the cell's
        largest r); a cell gets max(rays_per_psf, 3 rays_per_pixel area) rays, whole launches.
    rays_per_launch : int, default 2**22
        Rays per Dr.Jit launch (1 .. 2**30).
    density : float, default 1.0
        Relative spreadlet density for the sparsifier (> 0).
    seed : int, default 0
        Random seed (>= 0).

    ``basis`` (:class:`~lab.psf_tracing.models.common.BasisKeys`) picks Laplacian or row-difference
    spreadlets. The ``lens_*`` keys (:class:`~lab.psf_tracing.models.common.LensKeys`) set the canonical lens.
    """

    max_coc_px: float
    aperture: str = field(default="star", kw_only=True)
    channel_scale: tuple[float, float, float] = (1.0, 0.95, 0.9)
    samples: int = 200
    beta: float = 1.5
    psf_resolution: int = 512
    rays_per_psf: int = 3 * 2 ** 23
    rays_per_pixel: int = 8192
    rays_per_launch: int = 2 ** 22
    density: float = 1.0
    seed: int = 0

    def __post_init__(self):
        check_number("max_coc_px", self.max_coc_px)
        check_number("beta", self.beta)
        if isinstance(self.channel_scale, list):
            object.__setattr__(self, "channel_scale", tuple(self.channel_scale))
        if not (isinstance(self.channel_scale, tuple) and len(self.channel_scale) == 3):
            raise UserError(f"channel_scale = {self.channel_scale!r}: needs three factors (R, G, B), "
                            "e.g. [1.0, 0.95, 0.9]")
        for s in self.channel_scale:
            check_number("channel_scale", s)
        check_common(self)
        largest = self.max_coc_px * max(self.channel_scale)
        need = min_psf_resolution(largest)
        if self.psf_resolution < need:
            raise UserError(
                f"psf_resolution = {self.psf_resolution} cannot hold a PSF of radius max_coc_px x "
                f"max(channel_scale) = {largest:g} px plus the margin; use psf_resolution >= {need} "
                "(or a smaller max_coc_px / channel_scale)")
        self.check_aperture()
        self.check_lens()
        self.check_basis()


@register_model("stylized")
class Stylized(PSFModel):
    """Aperture-image bokeh with per-channel scale, indexed by |CoC radius| in pixels."""

    Config = StylizedConfig
    symmetries = ("coc_sign",)
    channels = 3

    def __init__(self, config: StylizedConfig):
        super().__init__(config)
        self.lens: ThinLens = config.lens
        self.aperture: Aperture = config.build_aperture()
        self._scale = Float([float(s) for s in config.channel_scale])

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        return NestedGrid.for_samples(c.samples, (c.beta,), ((0.0, c.max_coc_px),), ("coc_radius_px",))

    def rays_for_cell(self, cell: int) -> int:
        """max(rays_per_psf, 3 rays_per_pixel * the largest channel's shape area), whole launches."""
        c = self.config
        r = self.boxes[cell].hi[0] * max(c.channel_scale)
        area = self.aperture.area * (r + 0.5) ** 2
        n = max(c.rays_per_psf, math.ceil(self.channels * c.rays_per_pixel * area))
        return whole_launches(n, c.rays_per_launch)

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: |CoC| r -> channel, near-side depth, scaled aperture point -> image pixels."""
        width = self.config.lens_width_px
        channel = dr.minimum(UInt32(rng.next_float32() * self.channels), self.channels - 1)
        scale = dr.gather(Float, self._scale, channel)
        inv_depth = self.lens.inv_depth_for_coc_px(-coords[0], width)
        h = self.aperture.sample_rng(rng) * (scale * self.lens.aperture_radius_m)
        return RayHits(self.lens.psf_offset_px(h, inv_depth, width), channel=channel)
