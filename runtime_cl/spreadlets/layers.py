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
from runtime_cl.masks import nonzero_box

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
        self.bank_checked, self.bank_laplacian = bool(bank_checked), bank_laplacian
        self.blur_splatter = builtin_splatter(BLUR_SHAPE, renderer.device)
        self.counts = {"spreadlets": 0, "dense_pixels": 0, "highlights": 0}
        # how far a pixel's splat can land from it, turned or not (+1: the bilinear share)
        self.reach = int(renderer.db.rotated_pad) + 1

    def _render(self, image, source: int) -> tuple:
        coords, angle = self.coords[source]
        window = nonzero_box(image, self.reach)
        if window is None:   # nothing to splat
            return np.zeros(image.shape[:2] + (max(image.shape[2], self.renderer.db.channels),), np.float32), \
                {"device_ms": 0.0, "transfer_ms": 0.0}
        crop, t = self.renderer.render(image[window], coords[window], self.method,
                                       angle=None if angle is None else angle[window],
                                       bank_checked=self.bank_checked, bank_laplacian=self.bank_laplacian)
        # the layer's pixels and every splat they reach, placed in a zero frame (pages outside the
        # window are not touched here)
        out = np.zeros(image.shape[:2] + crop.shape[2:], np.float32)
        out[window] = crop
        self.counts["spreadlets"] += int(t["spreadlets"])
        self.counts["dense_pixels"] += int(t["dense_pixels"])
        self.counts["highlights"] += int(t["highlights"])
        return out, {"device_ms": t["kernel_ms"] + t["integrate_device_ms"],
                     "transfer_ms": t["upload_ms"] + t["download_ms"] + t["integrate_transfer_ms"]}

    def splat_layer(self, images: list, cocs: list, sources: list) -> tuple:
        h, w, c1 = images[0].shape
        if c1 != 4:
            raise InputError(f"images: {c1 - 1} colour channel(s); the spreadlet layers draw RGB and "
                             "opacity as one 4-channel image (give the layers RGB radiance)")
        out = None
        times = {"device_ms": 0.0, "transfer_ms": 0.0}
        for image, source in zip(images, sources):
            if source >= len(self.coords):
                raise InputError(f"sources: input layer {source}, but coordinates were given for "
                                 f"{len(self.coords)} layer(s)")
            rendered, t = self._render(image, source)
            # the renderer's image is a fresh array: the first is the sum so far (no zeros + add)
            out = rendered if out is None else np.add(out, rendered, out=out)
            times["device_ms"] += t["device_ms"]
            times["transfer_ms"] += t["transfer_ms"]
        return (np.zeros((h, w, c1), np.float32) if out is None else out), times

    def blur(self, image, radius_px: float) -> tuple:
        out, info = self.blur_splatter.render(image, float(radius_px))
        return out, {"device_ms": info["kernel_ms"], "transfer_ms": info["transfer_ms"]}
