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
from runtime_cl.errors import InputError
from runtime_cl.integrate import DEFAULT_INTEGRATOR, get_integrator
from runtime_cl.passes.registry import RuntimePass, integrating_passes, register_pass
from runtime_cl.psf.far_field import FarField
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import RUN_MAX
from runtime_cl.timing import CallTimes

__all__ = ["SpreadletPass", "SpreadletsPass", "SplatPass", "FilterPass"]


class SpreadletPass(RuntimePass):
    """A :class:`Renderer` method on a database of any model the runtime has coordinates for.

    Options: ``tile``, ``run_max``, ``spreadlet_rotation`` and, for a pass that integrates a
    Laplacian canvas (``integrates``), ``integrator`` as for :class:`Renderer` (a name from
    :func:`runtime_cl.integrate.integrator_names`; default ``"exact"``); ``far_field``: a
    ``volume_far`` database whose halos are added to a ``volume`` database's render
    (:class:`runtime_cl.psf.far_field.FarField`).
    """

    method: ClassVar[str]
    database_models = None
    channels = ("R", "G", "B", "Z")
    layered = False
    far_field = True

    def configure(self, *, tile=None, run_max: int = RUN_MAX, spreadlet_rotation: str = "bilinear",
                  far_field=None, integrator: str = DEFAULT_INTEGRATOR):
        get_integrator(integrator)   # an unknown name is an error for every pass
        if integrator != DEFAULT_INTEGRATOR and not self.integrates:
            raise InputError(f"integrator = {integrator!r}: the {self.name!r} pass integrates no Laplacian; "
                             f"the integrator is an option of {integrating_passes()}")
        self.renderer = Renderer(self.db, self.device, tile=tile, run_max=run_max,
                                 spreadlet_rotation=spreadlet_rotation, integrator=integrator)
        self.far = None if far_field is None else FarField(far_field, near=self.db)

    def prepare(self, frame):
        motion = frame.motion if needs_motion(self.db.model) else None
        far = None if self.far is None else self.far.prepare(self.camera, frame.depth)
        return np.asarray(frame.rgb), psf_coords(self.camera, frame.depth, self.db, motion), far

    def __call__(self, prepared):
        rgb, coords, far = prepared
        image, t = self.renderer.render(rgb, coords.coords, self.method, angle=coords.angle)
        if far is not None:  # host work: in the call's time, outside device and transfer time
            image = image + self.far.render(rgb, far)
        return image, CallTimes(device_ms=t["kernel_ms"] + t["integrate_device_ms"],
                                transfer_ms=t["upload_ms"] + t["download_ms"] + t["integrate_transfer_ms"],
                                counts={k: int(t[k]) for k in ("pixels", "spreadlets", "dense_pixels")})


@register_pass("spreadlets")
class SpreadletsPass(SpreadletPass):
    summary = "LSR18 Laplacian spreadlets, Poisson integration (--integrator; default exact FFT)"
    method = "spreadlets"
    integrates = True


@register_pass("splat")
class SplatPass(SpreadletPass):
    summary = "dense PSF splatting (LSR18's Splat baseline)"
    method = "splat"
    timing_reference = True


@register_pass("filter")
class FilterPass(SpreadletPass):
    summary = "gathering with each pixel's PSF (LSR18's Filter baseline)"
    method = "filter"

