"""MHU21's exact polygonal bokeh as a runtime pass: one layer, or global depth layers.

Every pixel spreads over the rasterised polygon at its thin-lens ``|CoC|``
(:class:`runtime_cl.polygon.splat.PolygonSplatter`); no database. With ``layers > 1`` the
pixels are binned into global depth layers and composited (:mod:`runtime_cl.layers.composite`),
from the flat image or, with ``layered_input``, from the frame's ``layerN.*`` layers. The
polygon is drawn upright on both sides of the focus plane: exact for point-symmetric irises.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.layers.composite import PixelLayer, render_layers
from runtime_cl.passes.registry import RuntimePass, register_pass
from runtime_cl.polygon.layers import PolygonLayerSplatter
from runtime_cl.polygon.splat import PolygonSplatter
from runtime_cl.timing import CallTimes

__all__ = ["PolygonPass", "builtin_splatter"]

_BUILTIN: dict = {}


def builtin_splatter(name: str, device=None) -> PolygonSplatter:
    """The splatter of a built-in aperture shape (its shipped rectified polygon), once per process."""
    from runtime_cl.device.opencl import get_device
    from runtime_cl.polygon.shapes import unit_polygon

    device = device or get_device()
    key = (name, id(device))
    if key not in _BUILTIN:
        _BUILTIN[key] = PolygonSplatter(*unit_polygon(name), device=device)
    return _BUILTIN[key]


@register_pass("polygon")
class PolygonPass(RuntimePass):
    """Exact flat polygonal bokeh (MHU21) with optional depth layers (LSR18 section 6).

    Options
    -------
    aperture : str or PolygonSplatter, default "hexagon"
        A built-in shape name (:data:`runtime_cl.polygon.shapes.SHAPES`) or a splatter of a
        rectified polygon (a camera's iris, rectified by ``lab``).
    layered_input : bool, default False
        Splat the frame's ``layers`` (``layerN.*``) instead of its flat image (needs depth layers
        or one global layer holding all of them).
    """

    summary = "exact flat polygonal bokeh (MHU21), optionally in global depth layers"
    database_models = ()
    channels = ("R", "G", "B", "A", "Z")
    layered = True
    draws_aperture = True

    def configure(self, *, aperture="hexagon", layered_input: bool = False):
        self.splatter = (aperture if isinstance(aperture, PolygonSplatter)
                         else builtin_splatter(aperture, self.device))
        self.layered_input = bool(layered_input)

    def _coc(self, depth, width: int) -> np.ndarray:
        return self.camera.coc_radius_px(depth, width).astype(np.float32)

    def prepare(self, frame):
        width = frame.shape[1]
        if self.layers == 1 and not self.layered_input:
            return np.abs(self._coc(frame.depth, width)), np.asarray(frame.rgb)
        source = frame.layers if self.layered_input else (frame,)
        if not source:
            raise InputError("layered_input: the input has no layerN.* layers; render it with layers "
                             "(a scene whose [[shapes]] have a layer key) or splat the flat image")
        return None, [PixelLayer(x.rgb, x.coverage(), self._coc(x.depth, width)) for x in source]

    def __call__(self, prepared):
        radius, image = prepared
        if radius is not None:
            rgb, info = self.splatter.render(image, radius)
            return rgb, CallTimes(info["kernel_ms"], info["transfer_ms"],
                                  {"pixels": int(radius.size), "max_radius_px": float(radius.max())})
        rgb, info = render_layers(PolygonLayerSplatter(self.splatter), image, self.layers)
        radii = [0.0] + [x["max_radius_px"] for x in info["layers"]]
        counts = {"pixels": int(image[0].alpha.size), "max_radius_px": float(max(radii)),
                  "depth_layers": self.layers, "used_layers": len(info["layers"]),
                  "input_layers": len(image)}
        return rgb, CallTimes(info["device_ms"], info["transfer_ms"], counts)
