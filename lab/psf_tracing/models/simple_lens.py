"""SimpleLens (LSR18 section 5.1, Tbl. 1): thin-lens depth of field, ns = 1, monochrome.

The PSF space is the magnitude of the circle-of-confusion radius in pixels, over [0, max_coc_px],
power-remapped with beta = 2 on a nested grid of 100 samples. In CoC space the PSF does not depend
on the lens, so one canonical thin lens traces all of them: each ray takes its CoC radius r from
the cell's box (pre-filtering), the object depth whose CoC is -r (the near side of the focus
plane, which exists for every r), a point of the aperture, and the physical path
point -> aperture -> thin lens -> sensor, binned in image orientation.

On the near side the image PSF is the aperture rotated by 180 degrees; for the circle that is the
same disc. Other apertures (``aperture = "polygon"`` with ``aperture_blades`` etc., see
:class:`~lab.psf_tracing.models.common.ApertureKeys`) are not rotation invariant: the model then
lists the symmetry ``coc_sign`` instead of ``rotation`` -- a runtime draws points behind the focal
plane with the stored PSF rotated by 180 degrees (it matters for odd blade counts).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

from lab.errors import UserError
from lab.optics.aperture import Aperture
from lab.optics.thin_lens import ThinLens
from lab.psf_tracing.models.base import PSFModel, register_model
from lab.psf_tracing.models.common import (ApertureKeys, BasisKeys, LensKeys, check_common, check_number,
                                           whole_launches)
from lab.psf_tracing.space import NestedGrid
from lab.psf_tracing.tracer import RayHits

__all__ = ["SimpleLens", "SimpleLensConfig", "PSF_MARGIN_PX", "min_psf_resolution"]

# Empty border around the largest CoC: one pixel for hits on the support edge that round outward,
# one so the Laplacian (3x3 stencil) of the PSF stays inside the image.
PSF_MARGIN_PX = 2


def min_psf_resolution(max_coc_px: float) -> int:
    """Smallest R whose image, centred at R//2, holds a CoC of radius ``max_coc_px`` plus the margin."""
    return 2 * (math.ceil(max_coc_px) + PSF_MARGIN_PX) + 1


@dataclass(frozen=True)
class SimpleLensConfig(LensKeys, ApertureKeys, BasisKeys):
    """Settings of the SimpleLens model (a scene's ``[psf.simple_lens]`` table).

    Parameters
    ----------
    max_coc_px : float
        Largest |CoC radius| in pixels the database covers (> 0); the scene decides it.
    samples : int, default 100
        Minimum number of PSF samples (cells of the nested grid; LSR18: 100).
    beta : float, default 2.0
        Power-remapping exponent (> 0; LSR18: 2.0): more cells at small CoC.
    psf_resolution : int, default 512
        R, the PSF image edge in pixels; must hold 2 (max_coc_px + margin) + 1 pixels.
    rays_per_psf : int, default 2**24
        Minimum rays traced per PSF (LSR18 used 700 M on a GPU).
    rays_per_pixel : int, default 8192
        Rays per pixel of the PSF's disc (pi (r + 1/2)^2 at the cell's largest radius); a cell
        gets max(rays_per_psf, rays_per_pixel * area) rays, so every PSF has about the same
        relative noise, ~1/sqrt(rays_per_pixel) per pixel (1.1 % at the default).
    rays_per_launch : int, default 2**22
        Rays per Dr.Jit launch, bounding memory (1 .. 2**30).
    density : float, default 1.0
        Relative spreadlet density for the sparsifier (> 0; 1 = its default).
    seed : int, default 0
        Random seed (>= 0); same seed, same PSFs bitwise.

    ``basis`` (:class:`~lab.psf_tracing.models.common.BasisKeys`) picks Laplacian or row-difference
    spreadlets. The ``aperture*`` keys (:class:`~lab.psf_tracing.models.common.ApertureKeys`) choose the
    aperture shape, e.g. ``aperture = "polygon"``, ``aperture_blades = 6``; the ``lens_*`` keys
    (:class:`~lab.psf_tracing.models.common.LensKeys`) the canonical thin lens, which the PSFs do
    not depend on beyond rounding.
    """

    max_coc_px: float
    samples: int = 100
    beta: float = 2.0
    psf_resolution: int = 512
    rays_per_psf: int = 2 ** 24
    rays_per_pixel: int = 8192
    rays_per_launch: int = 2 ** 22
    density: float = 1.0
    seed: int = 0

    def __post_init__(self):
        check_common(self)
        for name in ("max_coc_px", "beta"):
            check_number(name, getattr(self, name))
        need = min_psf_resolution(self.max_coc_px)
        if self.psf_resolution < need:
            raise UserError(
                f"psf_resolution = {self.psf_resolution} cannot hold a CoC of radius max_coc_px = "
                f"{self.max_coc_px} plus a {PSF_MARGIN_PX}-pixel margin around the centre pixel; "
                f"use psf_resolution >= {need} (or a smaller max_coc_px)")
        self.check_aperture()
        self.check_lens()
        self.check_basis()


@register_model("simple_lens")
class SimpleLens(PSFModel):
    """Thin-lens DoF PSFs indexed by |CoC radius| in pixels (LSR18's SimpleLens)."""

    Config = SimpleLensConfig
    channels = 1

    def __init__(self, config: SimpleLensConfig):
        super().__init__(config)
        self.lens: ThinLens = config.lens
        self.aperture: Aperture = config.build_aperture()

    @property
    def symmetries(self) -> tuple[str, ...]:
        """("rotation",) for the circle (no angle dimension); ("coc_sign",) for other shapes."""
        return ("rotation",) if self.config.aperture == "circle" else ("coc_sign",)

    @cached_property
    def grid(self) -> NestedGrid:
        c = self.config
        return NestedGrid.for_samples(c.samples, (c.beta,), ((0.0, c.max_coc_px),), ("coc_radius_px",))

    def rays_for_cell(self, cell: int) -> int:
        """max(rays_per_psf, rays_per_pixel * disc area at the cell's largest radius), whole launches."""
        c = self.config
        area = math.pi * (self.boxes[cell].hi[0] + 0.5) ** 2
        n = max(c.rays_per_psf, math.ceil(c.rays_per_pixel * area))
        return whole_launches(n, c.rays_per_launch)

    def rays(self, coords: list, rng) -> RayHits:
        """Per ray: |CoC| r (pixels) -> near-side depth -> aperture point -> sensor, image pixels."""
        width = self.config.lens_width_px
        inv_depth = self.lens.inv_depth_for_coc_px(-coords[0], width)
        h = self.aperture.sample_rng(rng) * self.lens.aperture_radius_m
        return RayHits(self.lens.psf_offset_px(h, inv_depth, width))
