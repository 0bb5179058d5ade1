"""A spreadlet database's methods as the splatter of generic depth layers (LSR18 section 6.2).

:func:`runtime_cl.layers.composite.render_layers` bins the pixels into global layers and
composites them; this splats one layer with a :class:`~runtime_cl.spreadlets.renderer.Renderer`
method (spreadlets, Splat or Filter): the layer's premultiplied radiance and its opacity
(coverage) as one 4-channel image, splatted and integrated with every pixel's own database PSF
(the coordinates and angle its input layer's depth gives), so colour and opacity spread alike.
The opacity rides in the 4th lane of the kernels' float4 pixels, which RGB leaves empty: it adds
no splatting work, only a fourth channel to merge, download and integrate.

The uniform blurs of the re-weighting (the hidden coverage in front of a layer, the layer's own
sites) use the exact 16-gon of the built-in ``hexadecagon`` at the layer's mean CoC radius
(:class:`runtime_cl.polygon.splat.PolygonSplatter`, prefix sums on the device): a disc to within
its rasterisation, at a fraction of a database render's cost. They only estimate how much of a
layer's footprint nearer layers hid, so the aperture's exact shape matters little there.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.masks import grow_box, inner_box, nonzero_box, on_box, union_box

__all__ = ["SpreadletLayerSplatter"]

BLUR_SHAPE = "hexadecagon"


class SpreadletLayerSplatter:
    """A :class:`~runtime_cl.layers.composite.LayerSplatter` made of a spreadlet :class:`Renderer`.

    Parameters
    ----------
    renderer : Renderer
        The database's renderer.
    method : {"spreadlets", "splat", "filter"}
        The renderer's method every layer is drawn with.
    coords : list of (coords, angle)
        Per input layer (the ``sources`` index of :meth:`splat_layer`): PSF coordinates (H, W, ns)
        and angles (H, W) or None, as :func:`runtime_cl.coords.maps.psf_coords` gives them.
    bank_checked : bool
        The caller grew the renderer's angle bank for every pixel any layer draws
        (:meth:`~runtime_cl.spreadlets.renderer.Renderer.grow_bank`, as the spreadlet passes do
        once per frame); default False: each layer's render checks it. ``bank_laplacian``: the
        choice that returned (the bank the layers draw from).
    """

    def __init__(self, renderer, method: str, coords: list, bank_checked: bool = False,
                 bank_laplacian: bool | None = None):
        from runtime_cl.passes.polygon import builtin_splatter

        self.renderer, self.method, self.coords = renderer, method, list(coords)
        self.device = renderer.device
        self.bank_checked, self.bank_laplacian = bool(bank_checked), bank_laplacian
        self.blur_splatter = builtin_splatter(BLUR_SHAPE, renderer.device)
        self.counts = {"spreadlets": 0, "dense_pixels": 0, "highlights": 0}
        # how far a pixel's splat can land from it, turned or not (+1: the bilinear share)
        self.reach = int(renderer.db.rotated_pad) + 1

    def _render(self, part, shape) -> tuple:
        """``part`` (a :class:`~runtime_cl.layers.composite.LayerPart`) rendered on its window:
        the box of its non-zero pixels widened by how far their splats reach. Returns the image,
        the window (None: nothing to splat) and the times."""
        coords, angle = self.coords[part.source]
        tight = nonzero_box(part.image)
        if tight is None:
            return None, None, {"device_ms": 0.0, "transfer_ms": 0.0}
        # the part's non-zero pixels in a zero image of its window (the renderer's input)
        drawn = tuple(slice(b.start + t.start, b.start + t.stop) for b, t in zip(part.box, tight))
        window = grow_box(drawn, self.reach, shape)
        image = on_box(part.image[tight], drawn, window)
        crop, t = self.renderer.render(image, coords[window], self.method,
                                       angle=None if angle is None else angle[window],
                                       bank_checked=self.bank_checked, bank_laplacian=self.bank_laplacian)
        self.counts["spreadlets"] += int(t["spreadlets"])
        self.counts["dense_pixels"] += int(t["dense_pixels"])
        self.counts["highlights"] += int(t["highlights"])
        return crop, window, {"device_ms": t["kernel_ms"] + t["integrate_device_ms"],
                              "transfer_ms": t["upload_ms"] + t["download_ms"] + t["integrate_transfer_ms"]}

    def splat_layer(self, parts: list, shape: tuple) -> tuple:
        c1 = parts[0].image.shape[2]
        if c1 != 4:
            raise InputError(f"images: {c1 - 1} colour channel(s); the spreadlet layers draw RGB and "
                             "opacity as one 4-channel image (give the layers RGB radiance)")
        rendered = []
        times = {"device_ms": 0.0, "transfer_ms": 0.0}
        for part in parts:
            if part.source >= len(self.coords):
                raise InputError(f"sources: input layer {part.source}, but coordinates were given for "
                                 f"{len(self.coords)} layer(s)")
            crop, window, t = self._render(part, shape)
            if crop is not None:
                rendered.append((crop, window))
            times["device_ms"] += t["device_ms"]
            times["transfer_ms"] += t["transfer_ms"]
        if not rendered:
            return np.zeros((1, 1, c1), np.float32), (slice(0, 1), slice(0, 1)), times
        box = union_box(*[window for _, window in rendered])
        # the renderer's image is a fresh array: on its own it is the sum (no zeros + add)
        out = on_box(*rendered[0], box)
        for crop, window in rendered[1:]:
            out[inner_box(window, box)] += crop
        return out, box, times

    def blur(self, image, radius_px: float) -> tuple:
        out, info = self.blur_splatter.render(image, float(radius_px))
        return out, {"device_ms": info["kernel_ms"], "transfer_ms": info["transfer_ms"]}

    def blur_reach(self, radius_px: float) -> int:
        return self.blur_splatter.reach(radius_px)
