"""Stochastic-framebuffer input (LSR18 6.2, Fig. 7): per-pixel lens samples and shutter times,
and the re-centring that moves each pixel back to where its surface projects at the lens centre
and mid-shutter, so splatting applies the PSF once."""
from runtime_cl.stochastic.recentre import Recentred, recentre
from runtime_cl.stochastic.samples import (CHANNEL_DEPTHS, CHANNELS, SUBPIXEL, channel_depths, concentric_disc,
                                           inverse_concentric, lens_time_samples)

__all__ = ["CHANNELS", "CHANNEL_DEPTHS", "Recentred", "SUBPIXEL", "channel_depths", "concentric_disc",
           "inverse_concentric", "lens_time_samples", "recentre"]
