"""The passes that render with a spreadlet database: LSR18's spreadlets and its two baselines.

All three draw the same PSFs (the database's), so they differ only by method
(:class:`runtime_cl.spreadlets.renderer.Renderer`). The per-pixel PSF coordinates and angles
come from the camera, the depth and, for motion databases, the motion vectors
(:func:`runtime_cl.coords.maps.psf_coords`).
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from runtime_cl.coords.maps import needs_motion, psf_coords
from runtime_cl.passes.registry import RuntimePass, register_pass
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import RUN_MAX
from runtime_cl.timing import CallTimes

__all__ = ["SpreadletPass", "SpreadletsPass", "SplatPass", "FilterPass"]


class SpreadletPass(RuntimePass):
    """A :class:`Renderer` method on a database of any model the runtime has coordinates for.

    Options: ``tile``, ``run_max`` and ``spreadlet_rotation`` as for :class:`Renderer`.
    """

    method: ClassVar[str]
    database_models = None
    channels = ("R", "G", "B", "Z")
    layered = False

    def configure(self, *, tile=None, run_max: int = RUN_MAX, spreadlet_rotation: str = "bilinear"):
        self.renderer = Renderer(self.db, self.device, tile=tile, run_max=run_max,
                                 spreadlet_rotation=spreadlet_rotation)

    def prepare(self, frame):
        motion = frame.motion if needs_motion(self.db.model) else None
        return np.asarray(frame.rgb), psf_coords(self.camera, frame.depth, self.db, motion)

    def __call__(self, prepared):
        rgb, coords = prepared
        image, t = self.renderer.render(rgb, coords.coords, self.method, angle=coords.angle)
        return image, CallTimes(device_ms=t["kernel_ms"], transfer_ms=t["upload_ms"] + t["download_ms"],
                                counts={k: int(t[k]) for k in ("pixels", "spreadlets", "dense_pixels")})


@register_pass("spreadlets")
class SpreadletsPass(SpreadletPass):
    summary = "LSR18 Laplacian spreadlets, exact FFT Poisson integration"
    method = "spreadlets"


@register_pass("splat")
class SplatPass(SpreadletPass):
    summary = "dense PSF splatting (LSR18's Splat baseline)"
    method = "splat"
    timing_reference = True


@register_pass("filter")
class FilterPass(SpreadletPass):
    summary = "gathering with each pixel's PSF (LSR18's Filter baseline)"
    method = "filter"

