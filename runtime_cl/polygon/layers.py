"""Exact polygons as the splatter of generic depth layers (:mod:`runtime_cl.layers.composite`).

A layer is splatted on its window -- the box of its pixels widened by the largest polygon's
reach -- not on the whole frame: the canvas's prefix sums cost its area, and a depth layer's
pixels fill a band of the frame. Every pixel's terms land inside the window and the sums are
exact integers, so the window holds the very values of a full-frame canvas (a test checks).
"""
from __future__ import annotations

import numpy as np

from runtime_cl.masks import box_shape, grow_box, inner_box, nonzero_box, on_box, union_box
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
        window = self._window(parts, shape)
        if window is None:   # nothing to splat
            return np.zeros((1, 1, c1), np.float32), (slice(0, 1), slice(0, 1)), {"device_ms": 0.0, "transfer_ms": 0.0}
        size = box_shape(window)
        # the canvas's fixed-point scale from the total |colour| (the parts hold all of it)
        canvas = sp.canvas(*size, c1, sum(float(np.abs(p.image).sum(dtype=np.float64)) for p in parts))
        device_ms = 0.0
        whole = (slice(0, size[0]), slice(0, size[1]))
        for part in parts:
            at = inner_box(part.box, window)
            radius = np.abs(on_box(part.coc, at, whole))
            device_ms += sp.splat(canvas, on_box(part.image, at, whole), radius)["splat_ms"]
        resolved, info = sp.resolve(canvas)
        times = {"device_ms": device_ms + info["prefix_ms"] + info["sum_ms"],
                 "transfer_ms": info["download_ms"]}
        return resolved, window, times

    def _window(self, parts: list, shape: tuple) -> tuple | None:
        """The parts' boxes widened by the reach of the largest polygon they draw
        (:meth:`PolygonSplatter.reach`), clipped to the frame; None if no part has a non-zero
        pixel."""
        drawn = [p.box for p in parts if nonzero_box(p.image) is not None]
        if not drawn:
            return None
        r_max = max(float(np.abs(p.coc).max()) for p in parts)
        return grow_box(union_box(*drawn), self.splatter.reach(r_max), shape)

    def blur(self, image, radius_px: float) -> tuple:
        out, info = self.splatter.render(image, radius_px)
        return out, {"device_ms": info["kernel_ms"], "transfer_ms": info["transfer_ms"]}

    def blur_reach(self, radius_px: float) -> int:
        return self.splatter.reach(radius_px)
