"""Lens-ray tracing through layered images in OpenCL (``kernels/layered/trace.cl``).

:class:`LayerStack` holds the layers as the kernel reads them: inverse depth (``-1`` where a
layer holds nothing) and un-premultiplied colour. :class:`LayerTracer` builds the kernels for one
image size, layer count and ray count, and renders a stack through a thin lens
(:meth:`LayerTracer.render`) or traces explicit rays (:meth:`LayerTracer.trace`, for tests).
The ray model (surfels with a slab of ``thickness_px`` pixels of ray travel, nearest hit over the
layers), the min/max clamping and the walk are described in the kernel file.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from runtime_cl.device.opencl import event_ms, get_device
from runtime_cl.errors import InputError
from runtime_cl.layered.lens_samples import disc_samples
from runtime_cl.layered.nbuffer import BIG, levels_for

__all__ = ["LayerStack", "LayerTracer", "colour_mipmaps", "layer_stack"]

MIPS = 8          # mip levels of cone tracing: windows up to 128 px
CONE_STEPS = 4    # hits a cone may pass through partly (its uncovered fraction goes on)


@dataclass(frozen=True)
class LayerStack:
    """Layers as the tracer reads them.

    Attributes
    ----------
    inv_depth : (L, H, W) float32
        1 / Z in 1/m (0 at infinity), -1 where the layer holds nothing.
    colour : (L, H, W, 4) float32
        Colour of what the pixel holds, not premultiplied (the 4th lane 0).
    """

    inv_depth: np.ndarray
    colour: np.ndarray

    @property
    def shape(self) -> tuple:
        return self.inv_depth.shape[1:]

    @functools.cached_property
    def wmax(self) -> float:
        """The largest inverse depth any layer holds (-BIG when all are empty: no ray can hit)."""
        top = float(self.inv_depth.max())
        return top if top >= 0.0 else -float(BIG)

    def occupancy(self) -> list:
        """Fraction of pixels each layer holds something at."""
        return [float(np.mean(x >= 0)) for x in self.inv_depth]


def layer_stack(layers, opaque: bool = False) -> LayerStack:
    """A :class:`LayerStack` of layers given as ``(rgb, alpha, depth)``, nearest first.

    Parameters
    ----------
    layers : sequence of (rgb (H, W, 3), alpha (H, W), depth (H, W))
        Colour premultiplied by the coverage ``alpha``; planar depth in metres (> 0, ``inf``:
        at infinity). A pixel holds something where ``alpha > 0``, or where it is at infinity
        with a colour (the sky: nothing lies behind it, so it is opaque whatever its alpha).
    opaque : bool, default False
        Every pixel holds something (a flat image: what the pinhole sees, sky included).

    Raises
    ------
    InputError
        No layers, layers of different sizes, non-finite colour, coverage outside [0, 1], or
        depth that is not > 0.
    """
    layers = list(layers)
    if not layers:
        raise InputError("layers: none given; pass at least one (rgb, alpha, depth) layer")
    shapes = [np.shape(d) for _, _, d in layers]
    if len(set(shapes)) != 1:
        raise InputError(f"layers: sizes {shapes} differ; every layer must have the image's size "
                         "(render them with the same resolution)")
    inv, colour = [], []
    for k, (rgb, alpha, depth) in enumerate(layers):
        rgb = np.asarray(rgb, np.float32)
        alpha = np.asarray(alpha, np.float32)
        depth = np.asarray(depth, np.float64)
        if rgb.shape != shapes[0] + (3,) or alpha.shape != shapes[0]:
            raise InputError(f"layer {k}: rgb {rgb.shape} and alpha {alpha.shape} do not match its depth "
                             f"{shapes[0]}; give (H, W, 3) colour and (H, W) coverage")
        if not np.all(np.isfinite(rgb)):
            raise InputError(f"layer {k}: {int((~np.isfinite(rgb)).sum())} non-finite colour value(s); "
                             "fix the renderer's output (NaN or inf radiance)")
        if not (np.all(alpha >= 0) and np.all(alpha <= 1)):
            raise InputError(f"layer {k}: coverage outside [0, 1] (or NaN); premultiply colour by a "
                             "coverage in [0, 1]")
        if not np.all(depth > 0):
            raise InputError(f"layer {k}: depth Z must be > 0 metres (inf at infinity), found "
                             f"{float(depth[~(depth > 0)].flat[0])!r}")
        sky = np.isinf(depth)
        present = np.ones(depth.shape, bool) if opaque else (alpha > 0) | (sky & np.any(rgb != 0, axis=-1))
        cover = np.where(sky | (alpha <= 0), 1.0, alpha) if not opaque else np.ones_like(alpha)
        inv.append(np.where(present, 1.0 / depth, -1.0).astype(np.float32))
        c = np.zeros(shapes[0] + (4,), np.float32)
        c[..., :3] = np.where(present[..., None], rgb / cover[..., None], 0.0)
        colour.append(c)
    return LayerStack(np.ascontiguousarray(inv), np.ascontiguousarray(colour))


def colour_mipmaps(stack: LayerStack, levels: int) -> tuple:
    """Colour + coverage mipmaps of every layer (LES09 4.4), levels stacked: (data, offsets).

    Level 0 holds (colour, 1) where a layer pixel holds something and 0 elsewhere; level l the
    2 x 2 means of level l - 1 (beyond the image: nothing). Coverage at level l is the fraction of
    the window's pixels that hold something, colour the sum over them divided by the window size.

    Returns
    -------
    data : (n, 4) float32
        Every level of every layer, row-major, layer by layer.
    offsets : (L * levels,) int32
        Where level l of layer k starts in ``data``: ``offsets[k * levels + l]``.
    """
    present = (stack.inv_depth >= 0).astype(np.float32)
    level = np.concatenate([stack.colour[..., :3] * present[..., None], present[..., None]], axis=-1)
    parts, offsets, at = [[] for _ in range(len(level))], [], 0
    for lv in range(levels):
        for k in range(len(level)):
            parts[k].append(level[k].reshape(-1, 4))
        if lv + 1 < levels:
            n, h, w = level.shape[:3]
            pad = np.zeros((n, h + h % 2, w + w % 2, 4), np.float32)
            pad[:, :h, :w] = level
            level = 0.25 * (pad[:, 0::2, 0::2] + pad[:, 1::2, 0::2] + pad[:, 0::2, 1::2] + pad[:, 1::2, 1::2])
    for k in range(len(parts)):
        for part in parts[k]:
            offsets.append(at)
            at += len(part)
    data = np.concatenate([p for layer in parts for p in layer]).astype(np.float32)
    return np.ascontiguousarray(data), np.asarray(offsets, np.int32)


class LayerTracer:
    """The layered lens-ray tracer for one image size, layer count and ray count.

    Parameters
    ----------
    shape : (int, int)
        Image height and width in pixels.
    n_layers : int
        Layers traced (>= 1).
    rays : int
        Lens rays per pixel (>= 1); the jittered set has ``2 rays`` Halton points.
    downsample : int, default 4
        Block size of the min/max N-buffer (LES10: 1/4 resolution).
    clamp_iters : int, default 0
        Min/max clamping rounds per layer and ray, after the pixel's (on the foreground scene
        they cost more than they save once the pixel's footprint is clamped).
    pixel_iters : int, default 3
        Min/max clamping rounds per layer for all rays of a pixel at once (LES10: three).
    false_position : int, default 0
        0: walk the clamped segment cell by cell (exact). n > 0: LES09's search, n steps of the
        method of false position on the layer as a continuous height field (approximate).
    cone : bool, default False
        LES09's approximate cone tracing: colour + coverage from a mipmap over the window between
        neighbouring rays, the uncovered part traced on (see the kernel file).
    interpolate_hidden : bool, default True
        Read a surfel hidden behind a nearer layer's pixel (a peeled one) bilinearly at the ray's
        hit point, between the cells of its surface; a surfel the pinhole sees by its cell
        (``surface_colour`` in the kernel file). False: every surfel by its cell.
    cone_scale : float, default 1
        The cone's footprint over the lens samples' spacing (1; other values only to show that 1
        is right, tests).
    device : Device, optional
    """

    KERNEL_FILES = ("layered/trace.cl",)   # a subclass builds its lens's kernels with the search
    STATS_INTS = 2                          # per-pixel ray counts the render kernel writes

    def __init__(self, shape, n_layers: int, rays: int, *, downsample: int = 4, clamp_iters: int = 0,
                 pixel_iters: int = 3, false_position: int = 0, cone: bool = False, cone_scale: float = 1.0,
                 interpolate_hidden: bool = True,
                 device=None):
        import pyopencl as cl

        for name, value, least in (("rays", rays, 1), ("layers", n_layers, 1), ("downsample", downsample, 1),
                                   ("clamp_iters", clamp_iters, 0), ("pixel_iters", pixel_iters, 0),
                                   ("false_position", false_position, 0)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
                raise InputError(f"{name} = {value!r}: must be an integer >= {least}"
                                 + (" (lens rays per pixel, e.g. 100)" if name == "rays" else ""))
        self.cl, self.device = cl, device or get_device()
        self.h, self.w = (int(s) for s in shape)
        self.n_layers, self.rays, self.ds = int(n_layers), int(rays), int(downsample)
        self.h4, self.w4 = -(-self.h // self.ds), -(-self.w // self.ds)
        self.levels = levels_for(self.h4, self.w4)
        opts = [f"-DW={self.w}", f"-DH={self.h}", f"-DNL={self.n_layers}", f"-DNRAYS={self.rays}",
                f"-DNSAMPLES={2 * self.rays}", f"-DDS={self.ds}", f"-DW4={self.w4}", f"-DH4={self.h4}",
                f"-DLEVELS={self.levels}", f"-DCLAMP_ITERS={int(clamp_iters)}",
                f"-DPIXEL_ITERS={int(pixel_iters)}", f"-DINTERPOLATE_HIDDEN={int(bool(interpolate_hidden))}"]
        if false_position:
            opts += ["-DFALSE_POSITION", f"-DFP_ITERS={int(false_position)}"]
        self.cone, self.cone_scale = bool(cone), float(cone_scale)
        self.mips = min(MIPS, 1 + int(math.log2(max(self.h, self.w))))
        if self.cone:
            opts += ["-DCONE", f"-DCONE_STEPS={CONE_STEPS}", f"-DMIPS={self.mips}"]
        nprg, _ = self.device.program("layered/nbuffer.cl", opts[:3] + opts[5:9])   # W H NL DS W4 H4 LEVELS
        self._nbuffer = {k: cl.Kernel(nprg, k) for k in ("nbuffer_base", "nbuffer_level", "nbuffer_range")}
        self.program, self.build = self.device.program(self.KERNEL_FILES, opts + self._lens_options())
        self._render = cl.Kernel(self.program, "render")
        self._trace = cl.Kernel(self.program, "trace_rays")
        self.samples = self._lens_samples()
        mf = cl.mem_flags
        ctx, n = self.device.context, self.h * self.w
        self.buf = {"height": cl.Buffer(ctx, mf.READ_ONLY, 4 * self.n_layers * n),
                    "colour": cl.Buffer(ctx, mf.READ_ONLY, 16 * self.n_layers * n),
                    "nbuf": cl.Buffer(ctx, mf.READ_ONLY, 8 * self.n_layers * self.levels * self.h4 * self.w4),
                    "range": cl.Buffer(ctx, mf.READ_ONLY, 8 * self.n_layers),
                    "samples": cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.samples),
                    "lens_rays": cl.Buffer(ctx, mf.READ_ONLY, 16 * len(self.samples)),
                    "out": cl.Buffer(ctx, mf.WRITE_ONLY, 16 * n),
                    "inv_focus": cl.Buffer(ctx, mf.READ_ONLY, 4 * n),
                    "mip": cl.Buffer(ctx, mf.READ_ONLY, 16 * self.n_layers * (2 * n + 4 * self.mips)
                                     if self.cone else 16),
                    "mip_offset": cl.Buffer(ctx, mf.READ_ONLY, 4 * self.n_layers * self.mips),
                    "stats": cl.Buffer(ctx, mf.WRITE_ONLY, 4 * self.STATS_INTS * n)}
        self._focus_uploaded = None   # the per-pixel 1/F array last uploaded (the same one: no upload)
        self._rays_scale = None       # the CoC scale the lens rays were last uploaded for

    def _lens_options(self) -> list:
        """Build options of the lens (none for the thin lens: its rays are scaled disc samples)."""
        return []

    def _lens_samples(self) -> np.ndarray:
        """The jittered lens sample set: 2 ``rays`` Halton points on the unit disc."""
        return disc_samples(2 * self.rays)

    def _lens_rays(self, coc_scale: float) -> np.ndarray:
        """(2 rays, 4) float32: each lens sample's b = xi S and 1 / b (inf where 0), the kernel's
        float arithmetic done once per render rather than once per ray and layer."""
        b = self.samples * np.float32(coc_scale)
        with np.errstate(divide="ignore"):
            return np.ascontiguousarray(np.concatenate([b, np.float32(1.0) / b], axis=1), np.float32)

    def _upload(self, stack: LayerStack) -> tuple:
        """The uploads and the min/max N-buffer, built on the device; (transfer events, wmax).

        The N-buffer kernels' events are kept in ``self.nbuffer_events`` (kernel time)."""
        if stack.inv_depth.shape != (self.n_layers, self.h, self.w):
            raise InputError(f"layers: {stack.inv_depth.shape} (layers, H, W), this tracer was built for "
                             f"{(self.n_layers, self.h, self.w)}; build a tracer for the input's size")
        q, cl, b, nb = self.device.queue, self.cl, self.buf, self._nbuffer
        events = [cl.enqueue_copy(q, b["height"], stack.inv_depth, is_blocking=False),
                  cl.enqueue_copy(q, b["colour"], stack.colour, is_blocking=False)]
        grid = (-(-self.w4 // 8) * 8, -(-self.h4 // 8) * 8, self.n_layers)
        kernels = [nb["nbuffer_base"](q, grid, (8, 8, 1), b["height"], b["nbuf"], wait_for=events[:1])]
        for lv in range(1, self.levels):
            kernels.append(nb["nbuffer_level"](q, grid, (8, 8, 1), b["nbuf"], np.int32(lv), wait_for=kernels[-1:]))
        kernels.append(nb["nbuffer_range"](q, (self.n_layers,), None, b["nbuf"], b["range"], wait_for=kernels[-1:]))
        self.nbuffer_events = kernels
        return events, stack.wmax

    def _upload_mips(self, stack: LayerStack) -> list:
        """Transfer events of the colour + coverage mipmaps (none without cone tracing)."""
        if not self.cone:
            return []
        mip, offsets = colour_mipmaps(stack, self.mips)
        q, b = self.device.queue, self.buf
        return [self.cl.enqueue_copy(q, b["mip"], mip, is_blocking=False),
                self.cl.enqueue_copy(q, b["mip_offset"], offsets, is_blocking=False)]

    def render(self, stack: LayerStack, coc_scale: float, focus_m: float, thickness_px: float = 1.0,
               seed: int = 0, inv_focus_map=None) -> tuple:
        """Trace ``rays`` lens rays per pixel through ``stack``.

        Parameters
        ----------
        stack : LayerStack
        coc_scale : float
            The lens's CoC radius in pixels per dioptre (``ThinLens.coc_scale_px(W)``).
        focus_m : float
            Focus distance in metres.
        thickness_px : float, default 1
            Slab depth of a surfel in pixels of ray travel (see the kernel file).
        seed : int, default 0
            Seeds the per-pixel offsets into the lens sample set.
        inv_focus_map : (H, W) array, optional
            Per pixel, 1 / the distance in focus (a tilted or expressive focus,
            ``ThinLens.inverse_focus_map``); default 1 / ``focus_m`` everywhere. Uploaded only when it
            is not the array object the last render uploaded (do not change one in place).

        Returns
        -------
        image : (H, W, 3) float32
            Mean colour of the rays that hit a surfel (a pixel none hit: its nearest layer's own
            colour).
        info : dict
            ``kernel_ms``, ``transfer_ms`` (event-profiled) and ray counts: ``rays_hit``,
            ``rays_left_image``, ``rays_missed`` (holes), ``pixels_no_hit``.
        """
        # focus_m = inf (focused at infinity) is exact: the kernel takes 1/focus_m = 0
        if not (math.isfinite(coc_scale) and coc_scale > 0 and focus_m > 0):   # NaN fails "> 0"
            raise InputError(f"coc_scale = {coc_scale!r}, focus_m = {focus_m!r}: need a lens with an "
                             "aperture (> 0) and a focus distance > 0 (inf: focused at infinity)")
        if not (math.isfinite(thickness_px) and thickness_px >= 0):
            raise InputError(f"thickness_px = {thickness_px!r}: the surfel slab depth must be >= 0 pixels")
        events, wmax = self._upload(stack)
        cl, q = self.cl, self.device.queue
        b = self.buf
        key = ("uniform", float(focus_m)) if inv_focus_map is None else inv_focus_map
        last = self._focus_uploaded
        if not (key is last or (isinstance(key, tuple) and isinstance(last, tuple) and key == last)):
            inv_focus = np.full((self.h, self.w), 1.0 / focus_m, np.float32) if inv_focus_map is None else \
                np.ascontiguousarray(inv_focus_map, np.float32)
            if inv_focus.shape != (self.h, self.w) or not np.all(np.isfinite(inv_focus)):
                raise InputError(f"inv_focus_map: shape {inv_focus.shape}, need finite values of shape "
                                 f"{(self.h, self.w)}")
            events.append(cl.enqueue_copy(q, b["inv_focus"], inv_focus, is_blocking=False))
            self._focus_uploaded = key
        if self._rays_scale != float(coc_scale):
            events.append(cl.enqueue_copy(q, b["lens_rays"], self._lens_rays(coc_scale), is_blocking=False))
            self._rays_scale = float(coc_scale)
        events += self._upload_mips(stack)
        gsize = (-(-self.w // 8) * 8, -(-self.h // 8) * 8)
        kernel = self._render(q, gsize, (8, 8), b["height"], b["colour"], b["nbuf"], b["range"], b["lens_rays"],
                              np.float32(coc_scale), b["inv_focus"], np.float32(wmax),
                              np.float32(thickness_px / coc_scale), np.uint32(seed % 2**32), b["mip"],
                              b["mip_offset"], np.float32(self.cone_scale * math.sqrt(math.pi / self.rays)), b["out"],
                              b["stats"])
        out = np.empty((self.h, self.w, 4), np.float32)
        stats = np.empty((self.h, self.w, 2), np.int32)
        down = [cl.enqueue_copy(q, out, b["out"], wait_for=[kernel], is_blocking=False),
                cl.enqueue_copy(q, stats, b["stats"], wait_for=[kernel], is_blocking=False)]
        transfer = event_ms(*events, *down)
        valid = out[..., 3]
        info = {"kernel_ms": event_ms(kernel, *self.nbuffer_events), "transfer_ms": transfer,
                "rays_hit": int(np.maximum(valid, 0).sum()), "rays_left_image": int(stats[..., 0].sum()),
                "rays_missed": int(stats[..., 1].sum()), "pixels_no_hit": int((valid <= 0).sum())}
        return np.ascontiguousarray(out[..., :3]), info

    def trace(self, stack: LayerStack, rays, thickness: float) -> np.ndarray:
        """Trace explicit rays q(w) = a + b w (pixels, w = 1/z) through ``stack``.

        Parameters
        ----------
        rays : (n, 4) float
            ``a.x, a.y, b.x, b.y`` per ray.
        thickness : float
            Slab depth in inverse depth (1/m).

        Returns
        -------
        (n, 4) float32
            Hit inverse depth (-1: none), layer (-1), cell ``y W + x`` (-1), and 1 where part of
            the ray's [0, wmax] lies off the image.
        """
        rays = np.ascontiguousarray(rays, np.float32)
        events, wmax = self._upload(stack)
        cl, q = self.cl, self.device.queue
        n = len(rays)
        rbuf = cl.Buffer(self.device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=rays)
        obuf = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 16 * max(n, 1))
        b = self.buf
        ev = self._trace(q, (-(-n // 64) * 64,), (64,), b["height"], b["nbuf"], b["range"], rbuf, np.int32(n),
                         np.float32(wmax), np.float32(thickness), obuf)
        out = np.empty((n, 4), np.float32)
        cl.enqueue_copy(q, out, obuf, wait_for=[ev, *events, *self.nbuffer_events])
        return out
