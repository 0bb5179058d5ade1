"""HDR highlights in the spreadlet method: splat them dense, outside the Laplacian canvas.

The spreadlet method sums every pixel's Laplacian into one float32 canvas and integrates it. A
highlight's spreadlets (c v, c = 1e4) are rounded to float32 (the products, the canvas adds and
the stored values' own float32 sum, which is not exactly the 0 of a compact PSF), relative
errors of 2^-24 that the Poisson solve does not keep local: a net error q of a Laplacian
becomes a far field ~ q ln(r) / 2 pi over the whole canvas. Measured (tests/runtime_cl/
test_hard_cases_passes.py, a 1e4 highlight on 1e-4, 45 px disc): 4.5e-5 of drift 6 px beyond
the disc, 45 % of the dim pixels' value; a float64 canvas of the same float32 spreadlets still
leaves 5.7e-6 (the values' sum, -5.6e-9 per unit colour), so more canvas precision alone
cannot reach 1 %.

A dense PSF is added where it lands and nowhere else, so a pixel more than :data:`HDR_RATIO`
times brighter than the image's typical (median lit) pixel is taken out of the spreadlet splat
and splatted with its dense PSF (as LSR18's fast track, section 6.4), on the bounding box of such
pixels only. The drift left is that of the pixels below the ratio: about 0.1 * 2^-24 c per unit
of their colour c (measured above: 4.5e-5 / 1e4 = 0.075 2^-24), so below 2^20 times the typical
level it stays under 1 % of the typical pixel. An image without such pixels takes the plain
path unchanged (bit for bit); the check costs a maximum and the median of a sample.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.device.opencl import event_ms

__all__ = ["HDR_RATIO", "bright_pixels", "splat_highlights"]

# Colour over typical level above which a pixel's spreadlets would drift the image by more than
# ~1 % of the typical pixel (0.1 * 2^-24 * 2^20 = 0.6 %; see the module docstring).
HDR_RATIO = 2.0 ** 20
# Stride of the sample whose median is the typical level (1/49 of the pixels, a few ms at 4K).
_SAMPLE = 7


def bright_pixels(colour: np.ndarray, ratio: float = HDR_RATIO):
    """(H, W) bool of the pixels above ``ratio`` (default :data:`HDR_RATIO`) times the typical
    level, or None.

    ``colour`` is (H, W, C) float32; a pixel's level is its largest channel, the typical level
    the median of the lit (> 0) pixels of a strided sample (of all pixels if that holds none).
    """
    top = float(colour.max())
    if top <= 0.0:
        return None
    sample = colour[::_SAMPLE, ::_SAMPLE].max(axis=2)
    lit = sample[sample > 0]
    if lit.size == 0:
        whole = colour.max(axis=2)
        lit = whole[whole > 0]
    limit = ratio * float(np.median(lit))
    if top <= limit:
        return None
    return colour.max(axis=2) > limit


def splat_highlights(renderer, image: np.ndarray, colour: np.ndarray, coords: np.ndarray, angle,
                     bright: np.ndarray) -> dict:
    """Add the dense splat of the ``bright`` pixels of ``colour`` to ``image`` (H, W, OC), in place.

    Renders the bounding box of the bright pixels (others zeroed) with the renderer's Splat
    kernel and adds its whole padded canvas, cropped to the image. Returns the times and counts
    to add to the render's (``splat_ms``, ``merge_ms``, ``upload_ms``, ``download_ms``,
    ``dense_pixels``, ``tiles``).
    """
    import pyopencl as cl

    h, w, ch = colour.shape
    rows, cols = np.flatnonzero(bright.any(axis=1)), np.flatnonzero(bright.any(axis=0))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    box = np.where(bright[y0:y1, x0:x1, None], colour[y0:y1, x0:x1], np.float32(0))
    parts = [np.ascontiguousarray(box, np.float32), np.ascontiguousarray(coords[y0:y1, x0:x1], np.float32)]
    rotate = angle is not None and not renderer.rotation_invariant
    if rotate:
        parts.append(np.ascontiguousarray(angle[y0:y1, x0:x1], np.float32))
    wrapper = renderer._wrapper("splat", ch, rotate)
    ctx, q = renderer.device.context, renderer.device.queue
    bufs = [cl.Buffer(ctx, cl.mem_flags.READ_ONLY, a.nbytes) for a in parts]
    ups = [cl.enqueue_copy(q, b, a, is_blocking=False) for b, a in zip(bufs, parts)]
    upload_ms = event_ms(*ups)
    out = wrapper.run(bufs[0], bufs[1], y1 - y0, x1 - x0, renderer.tile, bufs[2] if rotate else None)
    p, canvas = out.pad, out.canvas[0]
    # canvas pixel (cy, cx) is image pixel (y0 + cy - p, x0 + cx - p)
    ty0, tx0 = max(y0 - p, 0), max(x0 - p, 0)
    ty1, tx1 = min(y0 - p + canvas.shape[0], h), min(x0 - p + canvas.shape[1], w)
    image[ty0:ty1, tx0:tx1] += canvas[ty0 - y0 + p:ty1 - y0 + p, tx0 - x0 + p:tx1 - x0 + p]
    return dict(splat_ms=out.splat_ms, merge_ms=out.merge_ms, upload_ms=upload_ms,
                       download_ms=out.download_ms, dense_pixels=out.dense_pixels, tiles=out.tiles)
