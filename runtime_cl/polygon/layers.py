"""Exact polygons as the splatter of generic depth layers (:mod:`runtime_cl.layers.composite`)."""
from __future__ import annotations

import numpy as np

from runtime_cl.layers.composite import frame_image
from runtime_cl.polygon.splat import PolygonSplatter

__all__ = ["PolygonLayerSplatter"]


class PolygonLayerSplatter:
    """A :class:`~runtime_cl.layers.composite.LayerSplatter` made of a :class:`PolygonSplatter`:
    every pixel splats the polygon at ``|coc|`` (the upright iris on both sides of the focus
    plane), the layer's images into one fixed-point canvas."""

    def __init__(self, splatter: PolygonSplatter):
        self.splatter, self.device = splatter, splatter.device

    def splat_layer(self, parts: list, shape: tuple) -> tuple:
        sp = self.splatter
        c1 = parts[0].image.shape[2]
        # the canvas's fixed-point scale from the total |colour| (the parts hold all of it)
        canvas = sp.canvas(*shape, c1, sum(float(np.abs(p.image).sum(dtype=np.float64)) for p in parts))
        device_ms = 0.0
        for part in parts:
            image, coc = frame_image(part, shape)
            device_ms += sp.splat(canvas, image, np.abs(coc))["splat_ms"]
        resolved, info = sp.resolve(canvas)
        times = {"device_ms": device_ms + info["prefix_ms"] + info["sum_ms"],
                 "transfer_ms": info["download_ms"]}
        return resolved, (slice(0, shape[0]), slice(0, shape[1])), times

    def blur(self, image, radius_px: float) -> tuple:
        out, info = self.splatter.render(image, radius_px)
        return out, {"device_ms": info["kernel_ms"], "transfer_ms": info["transfer_ms"]}

    def blur_reach(self, radius_px: float) -> int:
        return int(np.abs(self.splatter.polygon(float(radius_px))).max()) + 1
