"""Unit polygons and plain numpy references for the polygon-splatting tests.

The built-in shapes are the ones the runtime ships (:func:`runtime_cl.polygon.shapes.unit_polygon`);
two more are written out, ``lab.polygon.rectify.rectify(...).unit()`` results, so these tests need
only the runtime: ``t1hex`` (``lab.polygon.table.table1_polygon("hexagon")``, MHU21's 45-degree
hexagon) and ``heart12`` (the 40-point heart rectified to 12 edges). The star is symmetric:
mirror-image polygons tie in ``scale_polygon``'s cost.
"""
import numpy as np

from runtime_cl.polygon.kernel import rasterize_polygon
from runtime_cl.polygon.shapes import unit_polygon

WRITTEN = {
    "t1hex": ([[1.0, -0.9999999999999998], [1.0, 0.9999999999999997], [1.1102230246251565e-16, 1.9999999999999996],
               [-0.9999999999999998, 0.9999999999999997], [-0.9999999999999998, -1.0],
               [0.0, -1.9999999999999996]],
              [[0, 1], [-1, 1], [-1, -1], [0, -1], [1, -1], [1, 1]]),
    "heart12": ([[0.05925361597064638, 0.8814927680587072], [-2.8627926446415426e-17, 1.0],
                 [-0.05925361597064652, 0.881492768058707], [-0.9004476515825389, 0.0402987324468146],
                 [-0.9004476515825389, -0.3582770014129411], [-0.6324360949929857, -0.6262885580024943],
                 [-0.26717594803707023, -0.6262885580024943], [5.551115123125782e-17, -0.35911260996542393],
                 [0.26717594803707034, -0.6262885580024943], [0.6324360949929855, -0.6262885580024943],
                 [0.9004476515825389, -0.3582770014129409], [0.9004476515825389, 0.04029873244681474]],
                [[-1, 2], [-1, -2], [-1, -1], [0, -1], [1, -1], [1, 0], [1, 1], [1, -1], [1, 0], [1, 1],
                 [0, 1], [-1, 1]]),
}
BUILT_IN = ("hexagon", "octagon", "star")   # shipped with the runtime
SHAPES = (*BUILT_IN, *WRITTEN)


def shape(name):
    """``(unit vertices float64 (n, 2), directions int64 (n, 2))``."""
    if name in BUILT_IN:
        return unit_polygon(name)
    v, d = WRITTEN[name]
    return np.asarray(v, np.float64), np.asarray(d, np.int64)


def footprint(polygon):
    """Pixel offsets ``(dy, dx)`` of the rasterised polygon (brute-force rasteriser)."""
    k, x0, y0 = rasterize_polygon(polygon)
    ys, xs = np.nonzero(k)
    return ys + y0, xs + x0


def splat_fixed(image, radius, polygon_of, exponent, uniform=False):
    """Integer brute-force splat: every pixel adds its quantised colour over its footprint.

    ``polygon_of(r)`` gives the integer polygon at radius ``r``. Quantisation as the runtime
    defines it: ``rint(c * (2^e / area))`` per pixel for a radius map, ``rint(c * 2^e)`` (float32)
    for a uniform radius (whose division by the area comes after the sum).
    """
    h, w, c = image.shape
    r = np.broadcast_to(np.asarray(radius, np.float32), (h, w))
    out = np.zeros((h, w, c), np.int64)
    cache = {}
    for y in range(h):
        for x in range(w):
            key = float(r[y, x])
            if key not in cache:
                cache[key] = footprint(polygon_of(key))
            dy, dx = cache[key]
            if uniform:
                q = np.rint(image[y, x] * np.ldexp(1.0, exponent).astype(np.float32)).astype(np.int64)
            else:
                q = np.rint(image[y, x].astype(np.float64) * (np.ldexp(1.0, exponent) / dy.size))
                q = q.astype(np.int64)
            ty, tx = dy + y, dx + x
            ok = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
            for ch in range(c):
                np.add.at(out[..., ch], (ty[ok], tx[ok]), q[ch])
    return out


def splat_float64(image, radius, splatter):
    """Float64 reference: per polygon of ``splatter``'s table, an FFT correlation of the pixels
    that use it with its rasterised kernel (error ~1e-13 of the largest colour)."""
    from scipy.signal import fftconvolve

    h, w, c = image.shape
    r = np.broadcast_to(np.asarray(radius, np.float32), (h, w))
    splatter.table.ensure(float(r.max()))
    entry = splatter.table.entry(r)
    out = np.zeros((h, w, c))
    for e in np.unique(entry):
        dy, dx = footprint(splatter.table.scale.polygons[e])
        kern = np.zeros((dy.max() - dy.min() + 1, dx.max() - dx.min() + 1))
        kern[dy - dy.min(), dx - dx.min()] = 1.0 / dy.size
        src = np.where((entry == e)[..., None], image.astype(np.float64), 0.0)
        full = fftconvolve(src, kern[..., None], axes=(0, 1))
        oy, ox = -dy.min(), -dx.min()                 # kernel origin inside `kern`
        out += full[oy:oy + h, ox:ox + w]
    return out
