"""Exact polygonal bokeh in time independent of the blur radius (MHU21 section 5.2), in OpenCL.

:class:`PolygonSplatter` blurs an image with a flat polygonal kernel, uniform or with a radius
per pixel (depth of field: ``|CoC|`` from :mod:`runtime_cl.camera.thin_lens`). Pixel ``i`` spreads
``colour_i / area_i`` over the pixels of its rasterised polygon ``K_i``
(:func:`runtime_cl.polygon.kernel.rasterize_polygon` of ``scale_polygon(unit, dirs, r_i)``,
``area_i`` its pixel count), and the result equals that brute-force splat.

Pipeline (``kernels/polygon/splat.cl``)
---------------------------------------
1. Radius -> polygon: :class:`~runtime_cl.polygon.radii.RadiusTable` (exactly
   ``scale_polygon``'s polygon for every float32 radius, see :mod:`runtime_cl.polygon.scale`;
   a bucket index finds a pixel's entry in a step or two). Each entry holds the polygon's
   directional differences (:mod:`runtime_cl.polygon.terms`; a constant number whatever the
   radius: 16 for the built-in hexagon, 12 for the octagon, 8 for MHU21's 45-degree hexagon) and
   its pixel count, exact by Pick's theorem.
2. Splat the terms into one buffer per edge direction (eq. 9). Radius map: one work item per
   tile of pixels; the tiles of one launch lie further apart than any kernel reaches, so adds
   are plain, except the atomic ones near the border where folded terms land.
3. Prefix sum along each direction (eq. 10) in column chunks (every pass streams row
   segments), a carry per line and chunk, then the sum over directions plus carries and the
   vertical prefix sum (eq. 11) in one pass that writes the colour image.

A uniform radius takes another route (:class:`~runtime_cl.polygon.uniform.UniformBlur`): every
pixel shares one kernel, so step 2 is a gather of its terms and steps 2-3 fuse into one walk over
the rows, all channels at once.

Exactness. All sums are integers in wrapping 64-bit arithmetic, so every prefix sum is exact
and no result depends on the order of additions (runs are bit-identical). Radius map: pixel
``i`` splats ``q_i = rint(colour_i 2^e / area_i)`` with ``2^(62 - e)`` above the total
``|colour|`` of the image, so no output can overflow; an output covered by ``n`` kernels is off
by at most ``n 2^-(e+1) <= n N mean|colour| 2^-62`` for ``N`` pixels (4e-8 of the mean colour
for 1920x1080 and n = 1e5) before its rounding to float32. Uniform radius: the exact sum of
``q = rint(colour 2^e)`` over the kernel, divided by its area at the end (see
:func:`~runtime_cl.polygon.uniform.exponent_bits`). Radius 0 returns the image.

Borders. The buffers cover exactly the image, whatever the radius: a term outside is moved
along its direction to where its line enters the image, or into a per-column sum of the rows
above (see the kernel file). Kernels larger than the image are therefore exact, and the
memory and the prefix-sum work do not grow with the radius.

Layers. A :class:`PolygonCanvas` is one accumulation target: several can be filled from the
same splatter (e.g. one per depth layer, each with its own pixels) and resolved separately.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from runtime_cl.device.opencl import event_ms, get_device
from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import edge_direction
from runtime_cl.polygon.radii import MAX_RADIUS, BUCKETS, RadiusTable
from runtime_cl.polygon.scale import ScaleOracle
from runtime_cl.polygon.uniform import UniformBlur, non_finite_error

__all__ = ["PolygonSplatter", "PolygonCanvas", "MAX_RADIUS", "fixed_point_exponents"]

CB, LOCAL = 8, 8   # columns per vertical-sum work item; work-group size of wide launches
ROW = 128          # least width of a splatting tile (its rows are the terms' write streams)
SERIAL = ("splat", "prefix_local", "prefix_carry", "comb_prefix")  # few, long items


def fixed_point_exponents(bound) -> np.ndarray:
    """Per channel the ``e`` with ``bound <= 2^(62 - e)`` (``e = 0`` for a zero bound)."""
    out = [0 if b <= 0 else min(62 - math.frexp(float(b))[1], 1000)
           for b in np.atleast_1d(np.asarray(bound, np.float64))]
    return np.asarray(out, np.int64)


@dataclass
class PolygonCanvas:
    """Fixed-point accumulation buffers of one image (or one depth layer).

    Create with :meth:`PolygonSplatter.canvas`, fill with :meth:`PolygonSplatter.splat` (any
    number of times), turn into colours with :meth:`PolygonSplatter.resolve`. ``bound`` caps
    the total ``|colour|`` splatted into it (``used`` so far) and fixes ``exponent``.
    """

    height: int
    width: int
    channels: int
    bound: float
    exponent: np.ndarray
    bufs: object = field(repr=False)
    comb: object = field(repr=False)
    used: float = 0.0


class PolygonSplatter:
    """Splat and reconstruct flat polygonal kernels exactly (see the module docstring).

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Unit polygon in pixels per unit radius (``y`` down), e.g. ``Rectified.unit()[0]`` from
        ``lab.polygon.rectify.rectify``: circumradius 1, centred on the origin.
    directions : array_like of int, shape (n, 2)
        Edge ``k`` runs from vertex ``k`` to ``k + 1`` along ``+directions[k]`` (small integers).
    device : runtime_cl.device.opencl.Device, optional
        Default: :func:`runtime_cl.device.opencl.get_device`.

    Examples
    --------
    >>> sp = PolygonSplatter(unit_vertices, unit_directions)        # doctest: +SKIP
    >>> blurred, info = sp.render(rgb, 40.0)                       # uniform radius, px
    >>> blurred, info = sp.render(rgb, np.abs(coc_px))             # radius per pixel
    """

    def __init__(self, vertices, directions, device=None):
        import pyopencl as cl

        self.cl = cl
        self.device = device or get_device()
        self.oracle = ScaleOracle(vertices, directions, self.device)
        dirs = [edge_direction(*d) for d in np.asarray(directions, np.int64)]
        self.directions = np.asarray(list(dict.fromkeys(d for d in dirs if d[0] > 0)), np.int32)
        self.amax = int(self.directions[:, 0].max())
        self.bmax = int(np.abs(self.directions[:, 1]).max())
        step = math.lcm(CB, *(int(a) for a in self.directions[:, 0]))
        self.chunk = step * max(1, 64 // step)   # prefix-sum chunk width (multiple of every a, CB)
        self.table = RadiusTable(self.oracle, self.directions, self.upload)
        self._kernels: dict = {}
        self.dirs_buf = self.upload(self.directions)
        self._uniform = UniformBlur(self)

    def kernel_terms(self, radius: float):
        """:class:`~runtime_cl.polygon.terms.PolygonTerms` used at ``radius`` (float32-rounded)."""
        return self.table.at(radius)

    def reach(self, radius: float) -> int:
        """How far from its pixel any kernel up to ``radius`` writes (px): the largest offset of
        their terms (:attr:`RadiusTable.bounds`), + 1."""
        table = self.table.ensure(float(radius))
        return int(np.abs(table.bounds[:int(table.entry(np.float32(radius))) + 1]).max()) + 1

    def polygon(self, radius: float) -> np.ndarray:
        """Integer vertices of the kernel at ``radius``; rasterise them for a reference."""
        return self.table.polygon(radius)

    # ----------------------------------------------------------------- OpenCL plumbing
    def upload(self, array):
        cl = self.cl
        return cl.Buffer(self.device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                         hostbuf=np.ascontiguousarray(array))

    def _kernel(self, channels: int, name: str):
        if (channels, name) not in self._kernels:
            opts = [f"-DNC={channels}", f"-DNDIR={len(self.directions)}", f"-DAMAX={self.amax}",
                    f"-DBMAX={self.bmax}", f"-DCB={CB}", f"-DCHUNK={self.chunk}", f"-DBUCKETS={BUCKETS}"]
            prg, _ = self.device.program(("polygon/entry.cl", "polygon/splat.cl"), opts)
            for n in ("splat", "prefix_local", "prefix_carry", "comb_exit", "comb_prefix", "vsum"):
                self._kernels[(channels, n)] = self.cl.Kernel(prg, n)
        return self._kernels[(channels, name)]

    def _launch(self, channels, name, size, *args):
        """Enqueue with a fixed work-group size (PoCL compiles once per size); kernels with few,
        long work items get groups of 1 so PoCL spreads them over the cores."""
        group = 1 if name in SERIAL else LOCAL
        return self._kernel(channels, name)(self.device.queue, (-(-int(size) // group) * group,),
                                            (group,), *args)

    def alloc(self, nbytes: int, what: str):
        limit = int(self.device.device.max_mem_alloc_size)
        if nbytes > limit:
            raise InputError(f"image: the {what} need {nbytes >> 20} MiB, above the device's "
                             f"{limit >> 20} MiB allocation limit; split the image into tiles or "
                             "use a polygon with fewer edge directions")
        return self.cl.Buffer(self.device.context, self.cl.mem_flags.READ_WRITE, max(nbytes, 8))

    # ----------------------------------------------------------------- validation
    @staticmethod
    def image_array(image) -> np.ndarray:
        """The image as C-contiguous float32 (H, W, C), shape checked (values not)."""
        a = np.asarray(image)
        if a.ndim == 2:
            a = a[..., None]
        if a.ndim != 3 or not 1 <= a.shape[2] <= 4 or 0 in a.shape:
            raise InputError(f"image: shape {np.shape(image)} is not (H, W) or (H, W, C<=4); "
                             "pass an RGB(A) array")
        return np.ascontiguousarray(a, np.float32)

    @classmethod
    def check_image(cls, image) -> np.ndarray:
        """:meth:`_image_array`, and every value finite."""
        a = cls.image_array(image)
        if not (np.isfinite(a.max()) and np.isfinite(a.min())):   # NaN propagates through max
            raise non_finite_error(a)
        return a

    @staticmethod
    def check_radius(radius, shape):
        r = np.asarray(radius)
        if r.ndim != 0 and r.shape != shape:
            raise InputError(f"radius: shape {r.shape} does not match the image's {shape}; pass one "
                             "radius per pixel or a single number")
        r = np.ascontiguousarray(r, np.float32) if r.ndim else np.float32(r)
        lo, hi = float(np.min(r)), float(np.max(r))
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise InputError(f"radius: {int((~np.isfinite(r)).sum())} non-finite value(s) (NaN/inf); "
                             "every pixel needs a radius in pixels (check the depth channel)")
        if lo < 0:
            raise InputError(f"radius: {int((r < 0).sum())} negative value(s), e.g. {lo}; pass |CoC| "
                             "(the kernel is point-symmetric in radius)")
        return r

    # ----------------------------------------------------------------- canvases
    def canvas(self, height: int, width: int, channels: int, bound) -> PolygonCanvas:
        """Zeroed buffers for an ``height x width`` image with ``channels`` channels.

        Parameters
        ----------
        height, width, channels : int
        bound : float
            Largest total ``|colour|`` (all pixels and channels) that will be splatted, e.g.
            ``np.abs(image).sum()``; sets the fixed-point exponent so no output can overflow.
        """
        if not (np.isscalar(bound) and math.isfinite(float(bound)) and float(bound) >= 0):
            raise InputError(f"bound: {bound!r} must be a finite number >= 0 (total |colour|)")
        bound = float(bound)
        nd, plane = len(self.directions), height * width * channels * 8
        bufs = self.alloc(nd * plane, f"{nd} direction buffers")
        comb = self.alloc(self.amax * width * channels * 8, "border sums")
        cl, q = self.cl, self.device.queue
        cl.enqueue_fill_buffer(q, bufs, np.uint64(0), 0, nd * plane)
        cl.enqueue_fill_buffer(q, comb, np.uint64(0), 0, self.amax * width * channels * 8)
        return PolygonCanvas(height, width, channels, bound,
                             np.repeat(fixed_point_exponents(bound), channels), bufs, comb, 0.0)

    def splat(self, canvas: PolygonCanvas, image, radius) -> dict:
        """Add every pixel's kernel to ``canvas`` (pixels with zero colour add nothing).

        Parameters
        ----------
        canvas : PolygonCanvas
        image : array_like, (H, W) or (H, W, C), the canvas's shape
        radius : float or array_like (H, W)
            Kernel radius per pixel in px (rounded to float32), finite and >= 0.

        Returns
        -------
        dict
            ``splat_ms`` (event-profiled) and ``launches``.
        """
        events = self._splat(canvas, self.check_image(image), radius)
        return {"splat_ms": event_ms(*events), "launches": len(events)}

    def _splat(self, canvas, img, radius):
        h, w, c = img.shape
        if (h, w, c) != (canvas.height, canvas.width, canvas.channels):
            raise InputError(f"image: shape {img.shape} does not match the canvas "
                             f"{(canvas.height, canvas.width, canvas.channels)}")
        r = self.check_radius(radius, (h, w))
        r = np.ascontiguousarray(np.broadcast_to(r, (h, w)))
        energy = float(np.abs(img).sum(dtype=np.float64))
        if canvas.used + energy > canvas.bound * (1 + 1e-6):   # 2x headroom below 2^63
            raise InputError(f"image: total |colour| {canvas.used + energy:.6g} exceeds the canvas "
                             f"bound {canvas.bound:.6g}; make the canvas with a larger bound")
        canvas.used = canvas.used + energy
        table = self.table.ensure(float(r.max()))
        span = table.span(float(r.max()))
        # Tiles one launch runs are `period` tiles apart, more than a kernel's span: plain adds
        # cannot race. `splat` uses atomics only where folded terms land (the border zone).
        # Rows of at least ROW pixels: each term's writes stream along them.
        th = max(32, span // 2)
        tw = max(ROW, th)
        px, py = 2 + span // tw, 2 + span // th
        unit = np.ldexp(1.0, canvas.exponent)[None, :] / table.area[:, None]   # 2^e / area
        args = [self.upload(img), self.upload(r), np.int32(w), np.int32(h), table.breaks,
                np.int32(len(table)), table.bucket, table.start, table.packed, self.upload(unit),
                self.dirs_buf, canvas.bufs, canvas.comb, np.int32(tw), np.int32(th), np.int32(px),
                np.int32(py)]
        n_tx, n_ty = -(-w // tw), -(-h // th)
        events = []
        for cy in range(min(py, n_ty)):
            for cx in range(min(px, n_tx)):
                nx, ny = -(-(n_tx - cx) // px), -(-(n_ty - cy) // py)
                events.append(self._launch(c, "splat", nx * ny, *args, np.int32(cx), np.int32(cy),
                                           np.int32(nx)))
        return events

    def resolve(self, canvas: PolygonCanvas, fixed: bool = False):
        """Prefix sums (eq. 10, 11) and conversion of a filled canvas.

        Returns ``(image, info)``: float32 (H, W, C), or with ``fixed=True`` the int64 sums in
        units of ``2^-canvas.exponent``; ``info`` holds event-profiled ``prefix_ms``, ``sum_ms``
        and ``download_ms``. The canvas is consumed (its buffers hold prefix sums afterwards).
        """
        out, events, ev, down = self._resolve(canvas, fixed)
        return out, {"prefix_ms": event_ms(*events), "sum_ms": event_ms(ev), "download_ms": event_ms(down)}

    def _resolve(self, canvas, fixed):
        h, w, c = canvas.height, canvas.width, canvas.channels
        carry, events = self._prefix_sums(c, canvas.bufs, w, h)
        for k, (a, b) in enumerate(self.directions):
            if b < 0:   # lines leaving the image upwards continue as combs
                events.append(self._launch(c, "comb_exit", w, canvas.bufs, np.int64(k * w * h * c),
                                           np.int32(w), np.int32(h), np.int32(a), np.int32(b), carry,
                                           np.int64(k * self._carry_plane(w, h, c)), canvas.comb))
        pairs = self.amax * (self.amax + 1) // 2
        events.append(self._launch(c, "comb_prefix", pairs * c, canvas.comb, np.int32(w)))
        out, ev, down = self._sum(c, canvas.bufs, w, h, carry, canvas.comb,
                                  np.ldexp(1.0, -canvas.exponent), fixed)
        return out, events, ev, down

    def _carry_plane(self, bw: int, bh: int, c: int) -> int:
        """ulongs of one direction's carry table (``prefix_carry``: rows padded by CPAD)."""
        return -(-bw // self.chunk) * self.amax * (bh + 2 * self.bmax * self.chunk) * c

    def _prefix_sums(self, c, bufs, bw, bh):
        """Chunked directional prefix sums of every direction (eq. 10); (carries, events)."""
        cplane, plane = self._carry_plane(bw, bh, c), bw * bh * c
        carry = self.alloc(len(self.directions) * cplane * 8, "prefix carries")
        events = []
        for k, (a, b) in enumerate(self.directions):
            events.append(self._launch(c, "prefix_local", -(-bw // self.chunk), bufs,
                                       np.int64(k * plane), np.int32(bw), np.int32(bh), np.int32(a),
                                       np.int32(b)))
            events.append(self._launch(c, "prefix_carry", 1, bufs, np.int64(k * plane), np.int32(bw),
                                       np.int32(bh), np.int32(a), np.int32(b), carry,
                                       np.int64(k * cplane)))
        return carry, events

    def _sum(self, c, bufs, w, h, carry, comb, factor, fixed):
        out = np.empty((h, w, c), np.int64 if fixed else np.float32)
        dev = self.alloc(out.nbytes, "output image")
        ev = self._launch(c, "vsum", -(-w // CB), bufs, self.dirs_buf, np.int32(w), np.int32(h), carry,
                          comb, self.upload(np.asarray(factor, np.float64)), dev, dev,
                          np.int32(1 if fixed else 0))
        down = self.cl.enqueue_copy(self.device.queue, out, dev)
        return out, ev, down

    # ----------------------------------------------------------------- one-call rendering
    def render(self, image, radius, fixed: bool = False):
        """Blur ``image`` by the polygon at ``radius``: one call for a whole image.

        Parameters
        ----------
        image : array_like, (H, W) or (H, W, C) with C <= 4
            Linear colours, finite.
        radius : float or array_like (H, W)
            Kernel radius in px (a number: uniform blur, gathered; a map: depth of field),
            finite and >= 0, rounded to float32. Radius 0 is the identity.
        fixed : bool, default False
            Return the exact integer sums instead of colours (tests): units ``2^-e`` for a map,
            ``2^-e / area`` for a number, with ``e = info["exponent"]``.

        Returns
        -------
        blurred : ndarray, float32 (or int64), the shape of ``image``
        info : dict
            Event-profiled kernel times (``*_ms``, ``kernel_ms``), the event-profiled download
            ``transfer_ms`` (inputs are copied by the host), ``wall_ms`` (this call),
            ``exponent``, ``area`` (uniform).
        """
        start = time.perf_counter()
        img = self.image_array(image)
        h, w, c = img.shape
        r = self.check_radius(radius, (h, w))
        download_ms = 0.0   # the uniform blur writes the host's array in place (zero copy)
        if r.ndim == 0 and r == 0 and not fixed:
            img = self.check_image(img)
            out, info = img.copy(), {"exponent": np.zeros(c, np.int64), "area": 1}   # the delta
        elif r.ndim == 0:
            out, info = self._uniform.render(img, float(r), fixed)   # checks the values itself
        else:
            img = self.check_image(img)
            canvas = self.canvas(h, w, c, float(np.abs(img).sum(dtype=np.float64)))
            splat = self._splat(canvas, img, r)
            out, events, ev, down = self._resolve(canvas, fixed)
            info = {"splat_ms": event_ms(*splat), "prefix_ms": event_ms(*events), "sum_ms": event_ms(ev),
                    "exponent": canvas.exponent}
            download_ms = event_ms(down)
        info["kernel_ms"] = sum(v for k, v in info.items() if k.endswith("_ms"))
        info["transfer_ms"] = download_ms
        info["wall_ms"] = (time.perf_counter() - start) * 1e3
        return (out if np.ndim(image) == 3 else out[..., 0]), info
