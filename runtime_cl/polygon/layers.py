"""Exact polygons as the splatter of generic depth layers (:mod:`runtime_cl.layers.composite`)."""
from __future__ import annotations

import numpy as np

from runtime_cl.polygon.splat import PolygonSplatter

__all__ = ["PolygonLayerSplatter"]


class PolygonLayerSplatter:
    """A :class:`~runtime_cl.layers.composite.LayerSplatter` made of a :class:`PolygonSplatter`:
    every pixel splats the polygon at ``|coc|`` (the upright iris on both sides of the focus
    plane), the layer's images into one fixed-point canvas."""

    def __init__(self, splatter: PolygonSplatter):
        self.splatter = splatter

    def splat_layer(self, images: list, cocs: list, sources: list = ()) -> tuple:
        sp = self.splatter
        h, w, c = images[0].shape
        canvas = sp.canvas(h, w, c, sum(float(np.abs(im).sum(dtype=np.float64)) for im in images))
        device_ms = sum(sp.splat(canvas, im, np.abs(k))["splat_ms"] for im, k in zip(images, cocs))
        resolved, info = sp.resolve(canvas)
        times = {"device_ms": device_ms + info["prefix_ms"] + info["sum_ms"],
                 "transfer_ms": info["download_ms"]}
        return resolved, times

    def blur(self, image, radius_px: float) -> tuple:
        out, info = self.splatter.render(image, radius_px)
        return out, {"device_ms": info["kernel_ms"], "transfer_ms": info["transfer_ms"]}
