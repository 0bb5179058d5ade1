"""The methods MHU21 Fig. 11 compares against, on the same radius table and fixed point.

:class:`BaselineSplatter` splats, per pixel, the rasterised polygon of :class:`PolygonSplatter`
itself (``dense``: brute force, O(r^2) terms), its 5-point Laplacian (``laplacian``: LSR18's
spreadlets for a flat kernel, O(r) terms, integrated by the exact FFT Poisson solve of
:mod:`runtime_cl.integrate.poisson`) or its ``dx dy`` difference (``dxdy``: KTB09, O(r) terms, a row
then a column prefix sum). ``dense`` and ``dxdy`` use the same quantisation as the radius-map
path of :class:`~runtime_cl.polygon.splat.PolygonSplatter`, so their integer outputs must be
identical to it; ``laplacian`` ends in float64 FFTs (error ~1e-7 of the largest colour).
For benchmarks; the canvas is padded by the largest kernel (no border folding).
"""
from __future__ import annotations

import time

import numpy as np

from runtime_cl.device.opencl import event_ms
from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import fft_friendly, laplacian5, poisson_integrate
from runtime_cl.polygon.kernel import rasterize_polygon
from runtime_cl.polygon.radii import BUCKETS
from runtime_cl.polygon.splat import PolygonSplatter, fixed_point_exponents

__all__ = ["BaselineSplatter", "METHODS"]

CB = 8


class _Dense:
    """Brute force: every pixel of the rasterised polygon, summed by columns at the end."""

    fft_canvas = False
    row_prefix = False

    @staticmethod
    def kernel(k, x0, y0):
        return k, x0, y0


class _DxDy(_Dense):
    """KTB09: the polygon's dx dy difference, integrated by rows then columns."""

    row_prefix = True

    @staticmethod
    def kernel(k, x0, y0):
        p = np.pad(k, ((1, 1), (1, 1)))
        return p[1:, 1:] - p[1:, :-1] - p[:-1, 1:] + p[:-1, :-1], x0, y0


class _Laplacian:
    """LSR18 spreadlets of the polygon: its 5-point Laplacian, integrated by the FFT solve."""

    fft_canvas = True

    @staticmethod
    def kernel(k, x0, y0):
        return laplacian5(np.pad(k, 1).astype(np.int64)), x0 - 1, y0 - 1


# The baselines by name: how each turns a polygon into sparse terms and the canvas back into colours.
METHODS = {"dense": _Dense, "laplacian": _Laplacian, "dxdy": _DxDy}


def _terms(polygon, method: str) -> np.ndarray:
    """(dx, dy, value) rows of one entry's sparse kernel."""
    f, ox, oy = METHODS[method].kernel(*rasterize_polygon(polygon))
    ys, xs = np.nonzero(f)
    return np.stack([xs + ox, ys + oy, f[ys, xs]], 1).astype(np.int32)


class BaselineSplatter:
    """Brute-force, Laplacian or dx dy splatting of ``splatter``'s polygons (see module doc).

    Parameters
    ----------
    splatter : PolygonSplatter
        Supplies the device, the radius table and the kernels' pixel counts.
    method : {"dense", "laplacian", "dxdy"}
    """

    def __init__(self, splatter: PolygonSplatter, method: str):
        if method not in METHODS:
            raise InputError(f"method: {method!r} is not one of {list(METHODS)}")
        self.sp, self.method, self.kind = splatter, method, METHODS[method]
        self._entries = -1
        self._kernels = {}

    def _table(self, last: int):
        if last <= self._entries:
            return
        table = self.sp.table
        terms = [_terms(p, self.method) for p in table.scale.polygons[: last + 1]]
        self.nnz = np.array([len(t) for t in terms])
        packed = np.concatenate([np.insert(t, 0, 0, axis=1) for t in terms])   # (0, dx, dy, v)
        self.extent = int(max(np.abs(t[:, :2]).max() for t in terms if len(t)))
        self._start = self.sp.upload(np.concatenate([[0], np.cumsum(self.nnz)]).astype(np.int32))
        self._packed = self.sp.upload(np.ascontiguousarray(packed, np.int32))
        self._entries = last

    def _kernel(self, c: int, name: str):
        if (c, name) not in self._kernels:
            prg, _ = self.sp.device.program(("polygon/entry.cl", "polygon/baselines.cl"),
                                            [f"-DNC={c}", f"-DBUCKETS={BUCKETS}", f"-DCB={CB}"])
            for n in ("scatter", "row_prefix", "column_out"):
                self._kernels[(c, n)] = self.sp.cl.Kernel(prg, n)
        return self._kernels[(c, name)]

    def render(self, image, radius, fixed: bool = False):
        """Blur with a radius map (as :meth:`PolygonSplatter.render`); ``(image, info)``.

        ``fixed`` (dense, dxdy): the int64 sums, units ``2^-info["exponent"]``.
        """
        sp, cl, queue = self.sp, self.sp.cl, self.sp.device.queue
        img = sp.check_image(image)
        h, w, c = img.shape
        r = np.ascontiguousarray(np.broadcast_to(sp.check_radius(radius, (h, w)), (h, w)))
        start = time.perf_counter()
        table = sp.table.ensure(float(r.max()))
        self._table(int(table.entry(r.max())))
        pad = self.extent + 2
        ch, cw = h + 2 * pad, w + 2 * pad
        if self.kind.fft_canvas:
            ch, cw = fft_friendly(ch), fft_friendly(cw)
        canvas = sp.alloc(ch * cw * c * 8, "padded canvas")
        cl.enqueue_fill_buffer(queue, canvas, np.uint64(0), 0, ch * cw * c * 8)
        e = np.repeat(fixed_point_exponents(float(np.abs(img).sum(dtype=np.float64))), c)
        unit = np.ldexp(1.0, e)[None, :] / table.area[:, None]
        span = 2 * self.extent + 1
        tile = max(32, span // 2)
        period = 2 + span // tile
        args = [sp.upload(img), sp.upload(r), np.int32(w), np.int32(h), table.breaks,
                np.int32(len(table)), table.bucket, self._start, self._packed, sp.upload(unit),
                canvas, np.int32(cw), np.int32(pad), np.int32(tile), np.int32(period)]
        n_tx, n_ty = -(-w // tile), -(-h // tile)
        k = self._kernel(c, "scatter")
        events = []
        for cy in range(min(period, n_ty)):
            for cx in range(min(period, n_tx)):
                nx, ny = -(-(n_tx - cx) // period), -(-(n_ty - cy) // period)
                events.append(k(queue, (nx * ny,), (1,), *args, np.int32(cx), np.int32(cy), np.int32(nx)))
        info = {"splat_ms": event_ms(*events), "terms_per_pixel": float(self.nnz[table.entry(r)].mean()),
                "exponent": e}
        if self.kind.fft_canvas:
            host = np.empty((ch, cw, c), np.int64)
            cl.enqueue_copy(queue, host, canvas)
            t = time.perf_counter()
            out = poisson_integrate(host.astype(np.float64) * np.ldexp(1.0, -e))[pad:pad + h, pad:pad + w]
            info["integrate_ms"] = (time.perf_counter() - t) * 1e3
        else:
            dxdy = self.kind.row_prefix
            ev = []
            if dxdy:
                ev.append(self._kernel(c, "row_prefix")(queue, (ch,), (1,), canvas, np.int32(cw)))
            out = np.empty((h, w, c), np.int64 if fixed else np.float32)
            dev = sp.alloc(out.nbytes, "output image")
            ev.append(self._kernel(c, "column_out")(
                queue, (-(-w // CB),), (1,), canvas, np.int32(cw), np.int32(pad), np.int32(w), np.int32(h),
                np.int32(1 if dxdy else 0), sp.upload(np.ldexp(1.0, -e)), dev, dev, np.int32(1 if fixed else 0)))
            cl.enqueue_copy(queue, out, dev)
            info["prefix_ms"] = event_ms(*ev)
        info["kernel_ms"] = sum(v for k, v in info.items() if k.endswith("_ms"))
        info["wall_ms"] = (time.perf_counter() - start) * 1e3
        return out, info
