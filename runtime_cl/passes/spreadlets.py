"""The passes that render with a spreadlet database: LSR18's spreadlets and its two baselines.

All three draw the same PSFs (the database's), so they differ only by method
(:class:`runtime_cl.spreadlets.renderer.Renderer`). The per-pixel PSF coordinates and angles
come from the camera, the depth and, for motion databases, the motion vectors
(:func:`runtime_cl.coords.maps.psf_coords`).

Depth layers (LSR18 section 6.2): with ``layers > 1`` or ``layered_input`` the pixels are binned
into global layers in signed CoC and composited back to front
(:func:`runtime_cl.layers.composite.render_layers`), every layer's radiance and opacity drawn by
the pass's method (:class:`runtime_cl.spreadlets.layers.SpreadletLayerSplatter`); ``layers = 1``
on the flat image is the plain render, unchanged.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from runtime_cl.coords.maps import needs_motion, psf_coords
from runtime_cl.errors import InputError
from runtime_cl.layers.composite import PixelLayer, check_soft, render_layers
from runtime_cl.integrate import get_integrator
from runtime_cl.masks import nonzero_pixels
from runtime_cl.passes.registry import RuntimePass, integrating_passes, register_pass
from runtime_cl.psf.far_field import FarField
from runtime_cl.spreadlets.layers import SpreadletLayerSplatter
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import DEFAULT_SPREADLET_ROTATION, RUN_MAX
from runtime_cl.timing import CallTimes

__all__ = ["SpreadletPass", "SpreadletsPass", "SplatPass", "FilterPass"]


class SpreadletPass(RuntimePass):
    """A :class:`Renderer` method on a database of any model the runtime has coordinates for.

    Options: ``tile``, ``run_max``, ``spreadlet_rotation`` and, for a pass that integrates a
    Laplacian canvas (``integrates``), ``integrator`` as for :class:`Renderer` (a name from
    :func:`runtime_cl.integrate.integrator_names`; default ``"fft32"``, and none for a database
    of row differences); ``far_field``: a
    ``volume_far`` database whose halos are added to a ``volume`` database's render
    (:class:`runtime_cl.psf.far_field.FarField`); ``layered_input``: render the frame's
    ``layerN.*`` layers in the global depth layers instead of its flat image; ``soft_layers``:
    soft layering width in [0, 1] (:func:`runtime_cl.layers.composite.render_layers`' ``soft``);
    ``hdr_ratio``: as for :class:`Renderer` (None: no dense highlights; ``splatlab bench runtime``
    measures the spreadlets pass without them in the same run).
    """

    method: ClassVar[str]
    database_models = None
    channels = ("R", "G", "B", "Z")
    layered = True
    far_field = True

    def configure(self, *, tile=None, run_max: int = RUN_MAX, spreadlet_rotation: str = DEFAULT_SPREADLET_ROTATION,
                  far_field=None, integrator: str | None = None, layered_input: bool = False,
                  soft_layers: float = 0.0, hdr_ratio="default"):
        if integrator is not None:
            get_integrator(integrator)   # an unknown name is an error for every pass
        if integrator is not None and not self.integrates:
            raise InputError(f"integrator = {integrator!r}: the {self.name!r} pass integrates no Laplacian; "
                             f"the integrator is an option of {integrating_passes()}")
        layered = self.layers > 1 or bool(layered_input)   # layers: integrate where each one lies
        hdr = {} if hdr_ratio == "default" else {"hdr_ratio": hdr_ratio}
        self.renderer = Renderer(self.db, self.device, tile=tile, run_max=run_max,
                                 spreadlet_rotation=spreadlet_rotation, integrator=integrator,
                                 crop_integration=layered, **hdr)
        self.far = None if far_field is None else FarField(far_field, near=self.db)
        self.layered_input = bool(layered_input)
        self.soft_layers = soft_layers
        check_soft(soft_layers)   # a bad width fails before any render

    def prepare(self, frame):
        motion = frame.motion if needs_motion(self.db.model) else None
        far = None if self.far is None else self.far.prepare(self.camera, frame.depth)
        coords = psf_coords(self.camera, frame.depth, self.db, motion)
        bank = None   # the angle bank's choice for this frame (Renderer.grow_bank)
        if self.layers == 1 and not self.layered_input:
            rgb = np.asarray(frame.rgb)
            if coords.angle is not None and self.method == "spreadlets":   # per-pixel work: here
                spread = rgb if coords.gain is None else rgb * coords.gain[..., None]
                bank = self.renderer.grow_bank(np.asarray(spread, np.float32), coords.coords,
                                               np.asarray(coords.angle, np.float32))
            return rgb, coords, far, None, bank
        if any(x is not None for x in (coords.direct, coords.gain, coords.receive)):
            raise InputError(f"a {self.db.model!r} database adds each pixel's unscattered light on its own "
                             "pixel, which depth layers do not composite; render the flat image (layers = 1)")
        if coords.angle is not None and self.method == "spreadlets" and not self.layered_input:
            # one bank for every layer of the frame: the pixels any layer draws (colour or coverage)
            drawn = nonzero_pixels(np.asarray(frame.rgb), frame.coverage() != 0)
            bank = self.renderer.grow_bank(drawn[..., None].astype(np.float32), coords.coords,
                                           np.asarray(coords.angle, np.float32))
        return np.asarray(frame.rgb), coords, far, self._pixel_layers(frame, coords), bank

    def _pixel_layers(self, frame, coords) -> tuple:
        """The input layers with their signed CoCs and PSF coordinates (pixels a layer does not
        hold take the flat frame's depth, so their coordinates stay inside the database)."""
        if not self.layered_input:
            coc = self.camera.coc_radius_px(frame.depth, frame.shape[1]).astype(np.float32)
            return [PixelLayer(frame.rgb, frame.coverage(), coc)], [(coords.coords, coords.angle)]
        if not frame.layers:
            raise InputError("layered_input: the input has no layerN.* layers; render it with layers "
                             "(a scene whose [[shapes]] have a layer key) or splat the flat image")
        if needs_motion(self.db.model):
            raise InputError(f"layered_input: a {self.db.model!r} database needs motion vectors, which "
                             "layerN.* layers do not carry; render the flat image with --layers N")
        pixels, per_layer = [], []
        for i, x in enumerate(frame.layers):
            if x.shape != frame.shape:
                raise InputError(f"layer{i}: {x.shape[0]}x{x.shape[1]} pixels, the image is "
                                 f"{frame.shape[0]}x{frame.shape[1]}; every layerN.* layer must have the "
                                 "image's size")
            rgb, alpha = np.asarray(x.rgb, np.float32), x.coverage()
            live = nonzero_pixels(rgb, alpha > 0)
            depth = np.where(live, x.depth, frame.depth)
            c = psf_coords(self.camera, depth, self.db)
            pixels.append(PixelLayer(rgb, alpha, self.camera.coc_radius_px(depth, frame.shape[1])
                                     .astype(np.float32)))
            per_layer.append((c.coords, c.angle))
        return pixels, per_layer

    def __call__(self, prepared):
        rgb, coords, far, layered, bank = prepared
        if layered is None:
            spread = rgb if coords.gain is None else rgb * coords.gain[..., None]
            image, t = self.renderer.render(spread, coords.coords, self.method, angle=coords.angle,
                                            bank_checked=self.method == "spreadlets", bank_laplacian=bank)
            if coords.receive is not None:
                image = image * coords.receive[..., None]
            if coords.direct is not None:   # the unscattered light, exact per pixel (host work)
                image = image + rgb * coords.direct[..., None]
            device_ms = t["kernel_ms"] + t["integrate_device_ms"]
            transfer_ms = t["upload_ms"] + t["download_ms"] + t["integrate_transfer_ms"]
            counts = {k: int(t[k]) for k in ("pixels", "spreadlets", "dense_pixels", "highlights")}
        else:
            pixels, per_layer = layered
            splatter = SpreadletLayerSplatter(self.renderer, self.method, per_layer,
                                              bank_checked=self.method == "spreadlets" and not self.layered_input,
                                              bank_laplacian=bank)
            image, info = render_layers(splatter, pixels, self.layers, soft=self.soft_layers)
            device_ms, transfer_ms = info["device_ms"], info["transfer_ms"]
            counts = dict(splatter.counts, pixels=int(rgb.shape[0] * rgb.shape[1]),
                          depth_layers=self.layers, used_layers=len(info["layers"]),
                          input_layers=len(pixels))
        if far is not None:  # host work: in the call's time, outside device and transfer time
            image = image + self.far.render(rgb, far)
        return image, CallTimes(device_ms=device_ms, transfer_ms=transfer_ms, counts=counts)


@register_pass("spreadlets")
class SpreadletsPass(SpreadletPass):
    summary = ("spreadlets: row differences summed along rows, or LSR18 Laplacian ones by Poisson integration "
               "(--integrator; default float32 FFT)")
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

