"""Unit polygons and plain numpy references for the polygon-splatting tests.

The shapes are ``lab.sparsify.polygon.rectify(shape(name), direction_set(2), n).unit()`` written
out (``t1hex``: ``lab.sparsify.polygon_table.table1_polygon("hexagon")``, MHU21's 45-degree
hexagon; ``heart12``: the 40-point heart rectified to 12 edges), so these tests need only the
runtime. The star is symmetric: mirror-image polygons tie in ``scale_polygon``'s cost.
"""
import numpy as np

from runtime_cl.polygon.kernel import rasterize_polygon

SHAPES = {
    "hexagon": ([[0.8660254037844387, -0.5669872981077806], [0.8660254037844387, 0.5669872981077806],
                 [4.6988171910082003e-17, 1.0], [-0.8660254037844385, 0.5669872981077808],
                 [-0.8660254037844385, -0.5669872981077809], [-1.9794118791938863e-16, -1.0]],
                [[0, 1], [-2, 1], [-2, -1], [0, -1], [2, -1], [2, 1]]),
    "octagon": ([[0.9238795325112867, -0.38268343236508995], [0.9238795325112867, 0.3826834323650898],
                 [0.38268343236508984, 0.9238795325112867], [-0.38268343236508967, 0.9238795325112867],
                 [-0.9238795325112867, 0.3826834323650896], [-0.9238795325112868, -0.38268343236508967],
                 [-0.38268343236508995, -0.9238795325112865], [0.38268343236509006, -0.9238795325112866]],
                [[0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0], [1, 1]]),
    "star": ([[-0.587785252292473, -0.054254269627733394], [-0.587785252292473, -0.8090169943749473],
              [0.0, -0.5151243682287108], [0.587785252292473, -0.8090169943749473],
              [0.587785252292473, -0.05425426962773306], [0.9510565162951534, 0.30901699437494734],
              [0.3454915028125263, 0.30901699437494734], [-7.398176389483337e-18, 0.9999999999999999],
              [-0.34549150281252633, 0.30901699437494723], [-0.9510565162951536, 0.30901699437494723]],
             [[0, -1], [2, 1], [2, -1], [0, 1], [1, 1], [-1, 0], [-1, 2], [-1, -2], [-1, 0], [1, -1]]),
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


def shape(name):
    """``(unit vertices float64 (n, 2), directions int64 (n, 2))``."""
    v, d = SHAPES[name]
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
