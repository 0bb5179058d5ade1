"""Volume, far field: the part of a point light's halo beyond the volume PSF's window, coarse.

In fog the halo of a light reaches across the whole frame (HG g = 0.6, sigma_t = 0.25/m: a light
at 2.5 m brightens pixels 500 px away at 1024^2), but a full-resolution PSF that wide (2047^2 px,
3 channels, 200 samples) is tens of GB. The halo far from the centre is smooth, so it is traced
here at a coarser pixel scale: the ``volume`` database keeps the centre at full resolution (its
``psf_resolution`` window), this model the rest, binned into PSF pixels of ``pixel_scale`` x
``pixel_scale`` image pixels, with the window of the ``volume`` PSFs left out exactly: a crossing
that lands in an image pixel k with |kx|, |ky| <= ``hole_half_px`` belongs to the volume PSF and is
not counted here (``hole_half_px`` = the volume PSF's kept half-width, psf_resolution // 2 minus
its margin). The two together count every crossing once.

The same photons, medium and camera as :mod:`lab.psf_tracing.models.volume` (one tracer), so
the stored PSFs carry their energy the same way: flux per PSF pixel per photon of the channel.
The runtime adds the far field of every pixel by FFT convolution on a grid of ``pixel_scale``
blocks (:mod:`runtime_cl.psf.far_field`); the halo varies slowly with the distance, so few
samples do (default 16, interpolated linearly between them).
"""
from __future__ import annotations

from dataclasses import dataclass

from lab.errors import UserError
from lab.psf_tracing.models.base import register_model
from lab.psf_tracing.models.common import check_number
from lab.psf_tracing.models.simple_lens import PSF_MARGIN_PX
from lab.psf_tracing.models.volume import Volume
from lab.psf_tracing.models.volume_config import VolumeConfig

__all__ = ["VolumeFar", "VolumeFarConfig"]


@dataclass(frozen=True)
class VolumeFarConfig(VolumeConfig):
    """:class:`~lab.psf_tracing.models.volume_config.VolumeConfig` with the far field's binning.

    ``width_px``, ``focal_length_mm`` and ``sensor_width_mm`` are the image's (as the volume
    model's); ``psf_resolution`` counts PSF pixels of ``pixel_scale`` image pixels each.

    Parameters (beside the volume's; defaults differ: samples 16, psf_resolution 261,
    rays_per_psf 2**25)
    ----------
    pixel_scale : int, default 8
        Image pixels per PSF pixel along each axis (>= 2).
    hole_half_px : int, default 125
        Half-width in image pixels of the centre square left to the volume PSFs (>= 0): that of a
        ``volume`` database with psf_resolution 255.
    """

    samples: int = 16
    psf_resolution: int = 261
    rays_per_psf: int = 2 ** 25
    pixel_scale: int = 8
    hole_half_px: int = 125

    def __post_init__(self):
        super().__post_init__()
        check_number("pixel_scale", self.pixel_scale, integer=True)
        check_number("hole_half_px", self.hole_half_px, integer=True, zero_ok=True)
        if self.pixel_scale < 2:
            raise UserError(f"pixel_scale = {self.pixel_scale}: the far field is binned coarser than the "
                            "image; use 2 or more (a volume database holds the full-resolution PSF)")
        reach = (self.psf_resolution // 2 - PSF_MARGIN_PX) * self.pixel_scale
        if self.hole_half_px >= reach:
            raise UserError(f"hole_half_px = {self.hole_half_px}: the far field's window reaches only {reach} "
                            f"image pixels (psf_resolution {self.psf_resolution} x pixel_scale "
                            f"{self.pixel_scale}); raise psf_resolution or pixel_scale")


@register_model("volume_far")
class VolumeFar(Volume):
    """The far field of :class:`~lab.psf_tracing.models.volume.Volume`'s PSFs, coarse, by distance."""

    Config = VolumeFarConfig

    def bins(self) -> tuple[int, int]:
        return self.config.pixel_scale, self.config.hole_half_px
