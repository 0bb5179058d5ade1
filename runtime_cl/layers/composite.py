"""Occlusion for any splatting pass: global depth layers (LSR18 section 6, "Layering Details").

Splatting adds every pixel's PSF linearly, so a blurred background bleeds over an in-focus
object in front of it and a blurred foreground shows nothing of what lies behind it (MHU21
section 7 names occlusion as their limitation). As LSR18 do, the pixels are binned into global
depth layers, each layer is splatted on its own, and the layers are composited. What splats a
layer is a :class:`LayerSplatter`: any pass that can splat a masked image with per-pixel PSFs
and blur one channel uniformly (exact polygons: :class:`runtime_cl.polygon.layers.
PolygonLayerSplatter`).

Binning. Layers are bins of equal width in the signed circle of confusion (``coc``, pixels:
negative in front of the focus plane), which is affine in inverse depth: constant parallax
[Lee et al. 2009]. The bins span the ``coc`` range of the live pixels (a pixel with zero colour
and zero alpha is culled); layer 0 is the nearest. An empty layer costs nothing.

Per layer. Every pixel of the layer splats its premultiplied radiance and its coverage (alpha)
as one 4-channel image with the PSF of its signed CoC (polygons: the polygon at ``|coc|``,
exact fixed point); the resolved layer is ``(C, A)``. Within a layer, splats add (LSR18:
"splatting performs linear addition within a layer").

Re-weighting. Where a single image is the input, a layer has holes wherever nearer pixels hid
it; blurred, the hole darkens the layer around the nearer object's outline. Lee et al. [2008]
normalise a layer by its accumulated splat weight; that would also harden the layer's genuine
soft edges, so here the weight is that of the sites that *could* hold the layer: ``k = 1 - H``
with ``H`` the coverage of the nearer layers' pixels blurred by the layer's radius ``rho`` (the
coverage-weighted mean ``|coc|`` of its pixels; one bin spans a narrow range). The layer is
scaled by ``g = 1 / min(1, max(k, A, MIN_KNOWN))``: a hole is filled by the layer's own colours,
full coverage is never exceeded, where less than ``MIN_KNOWN`` of the footprint is known the
fill fades out smoothly, and a layer with nothing in front of it (or with its hidden part
supplied, as in layered input) is left unchanged, ``g = 1``. What no splat of the layer
reaches stays unknown (transparent): a single image cannot show what a wide foreground hides.

Opacity. Discrete PSFs change shape in steps as the radius grows (MHU21's integer polygons,
a database's grid cells), so where neighbouring pixels of one surface use different PSFs their
splats do not sum to 1 (rings of ``A`` a little below or above 1); through such a ring the (often far brighter) layers behind
would shine. A layer therefore hides what is behind it by at least ``E / k``, its own pixels'
coverage blurred by the single radius ``rho`` (no steps) relative to the known sites:
``alpha = min(1, max(g A, E / max(k, MIN_KNOWN)))``.

Compositing. Back to front with "over" on premultiplied colours:
``out = g C + (1 - alpha) out``, with the re-weighting, in one device pass over the box of what
the layer drew (:mod:`runtime_cl.layers.over`; outside it the layer changes nothing). With one
layer the result is the layer's plain splat; a layer with no live pixels changes nothing.

Soft layering (``soft`` > 0, LSR18 section 6.2). A pixel whose CoC lies within ``soft / 2`` of a
bin's width from an edge between two layers is drawn into both, its colour and coverage split
linearly (weights summing to 1), so a surface spanning an edge does not break into two hard
pieces; ``soft = 0`` is the hard binning above, ``soft <= 1`` keeps each pixel in at most two layers.

Layered input (LDI-like: e.g. a foreground layer with alpha and the background rendered without
the foreground, or LES10's peeled layers) is a list of :class:`PixelLayer`; all their pixels go
into the same global layers. Where two input pixels at one image position fall into the same
depth layer, the farther (larger signed CoC; equal: the later input layer) is hidden by the
nearer's coverage, as a single image would hide it: splats within a layer add, so without this a
surface and what lies just behind it would both be drawn, too bright. So the order of the input
layers does not matter.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.layers.over import over_kernel
from runtime_cl.masks import box_shape, grow_box, inner_box, nonzero_box, nonzero_pixels, on_box, union_box

__all__ = ["LayerPart", "LayerSplatter", "PixelLayer", "check_soft", "layer_edges", "render_layers"]

# Least known fraction a hole fill trusts: with less known around it fades out instead of
# blowing up a few stray splats (a hard cut-off would draw its outline through the layers in front).
MIN_KNOWN = 0.1


class LayerSplatter(Protocol):
    """What :func:`render_layers` needs of a pass: splat one layer, blur one channel.

    Both return their image and the OpenCL times ``{"device_ms": ..., "transfer_ms": ...}``.
    """

    def splat_layer(self, parts: list, shape: tuple) -> tuple:
        """Splat and resolve a depth layer of an (H, W) frame (``shape``), given as its
        :class:`LayerPart` s (one per input layer it draws from), all into one canvas; each pixel
        with the PSF of its signed CoC. Returns ``(resolved, box, times)``: the premultiplied
        ``(rgb, alpha)`` on ``box``, the (rows, cols) slices of the frame outside which the layer
        drew nothing (float32, the box's (h, w, C + 1))."""

    def blur(self, image, radius_px: float) -> tuple:
        """``image`` (H, W, K) float32 blurred by the PSF of CoC radius ``radius_px`` everywhere."""

    def blur_reach(self, radius_px: float) -> int:
        """How far from a pixel :meth:`blur` at ``radius_px`` spreads it (px)."""

    device: object   # the OpenCL device (runtime_cl.device.opencl.Device) the layers composite on


@dataclass(frozen=True)
class LayerPart:
    """One input layer's share of a depth layer, on the box of its non-zero pixels.

    ``box``: (rows, cols) slices of the frame; ``image``: premultiplied colour and coverage
    (h, w, C + 1) on the box, zero outside the layer; ``coc``: signed CoC (h, w), px, 0 outside
    the layer; ``source``: the index of the input layer (a splatter whose PSFs depend on more
    than the CoC looks its coordinates up by it).
    """

    box: tuple
    image: np.ndarray
    coc: np.ndarray
    source: int


@dataclass(frozen=True)
class PixelLayer:
    """One image of labelled pixels: a single input image or one layer of a layered input.

    Parameters
    ----------
    rgb : array_like, (H, W, C) with C <= 3
        Linear radiance premultiplied by ``alpha`` (the OpenEXR convention). A pixel with zero
        alpha and non-zero colour adds light without hiding anything (e.g. the sky).
    alpha : array_like, (H, W)
        Coverage in [0, 1].
    coc : array_like, (H, W)
        Signed circle-of-confusion radius in pixels (:meth:`runtime_cl.camera.thin_lens.ThinLens.
        coc_radius_px`); its magnitude is the polygon's radius.
    """

    rgb: np.ndarray
    alpha: np.ndarray
    coc: np.ndarray


def _check_layers(layers) -> list[PixelLayer]:
    if isinstance(layers, PixelLayer):
        layers = [layers]
    layers = list(layers)
    if not layers or not all(isinstance(x, PixelLayer) for x in layers):
        raise InputError("layers: pass a PixelLayer or a non-empty list of them (one per input layer)")
    out = []
    for i, layer in enumerate(layers):
        rgb = np.asarray(layer.rgb, np.float32)
        rgb = rgb[..., None] if rgb.ndim == 2 else rgb
        alpha, coc = np.asarray(layer.alpha, np.float32), np.asarray(layer.coc, np.float32)
        shape = out[0].alpha.shape if out else alpha.shape
        if rgb.ndim != 3 or not 1 <= rgb.shape[2] <= 3 or rgb.shape[:2] != shape or \
                alpha.shape != shape or coc.shape != shape or (out and rgb.shape != out[0].rgb.shape):
            raise InputError(f"layers[{i}]: rgb {rgb.shape}, alpha {alpha.shape}, coc {coc.shape} must be "
                             f"(H, W, C<=3), (H, W), (H, W) and the same for every layer "
                             f"(layers[0] is {out[0].rgb.shape if out else 'this one'})")
        for name, a in (("rgb", rgb), ("alpha", alpha), ("coc", coc)):
            if not np.isfinite(a).all():
                raise InputError(f"layers[{i}].{name}: {int((~np.isfinite(a)).sum())} non-finite value(s); "
                                 "every pixel needs finite colour, coverage and CoC (culled pixels: "
                                 "alpha 0, colour 0, any finite CoC)")
        if alpha.size and not (alpha.min() >= 0 and alpha.max() <= 1):
            raise InputError(f"layers[{i}].alpha: values in [{alpha.min():g}, {alpha.max():g}]; coverage "
                             "must lie in [0, 1]")
        out.append(PixelLayer(rgb, alpha, coc))
    return out


def _check_count(n_layers) -> int:
    if isinstance(n_layers, bool) or not isinstance(n_layers, (int, np.integer)) or n_layers < 1:
        raise InputError(f"n_layers = {n_layers!r}: the number of depth layers must be an integer >= 1 "
                         "(1 splats everything into one layer, without occlusion)")
    return int(n_layers)


def _live(layer: PixelLayer) -> np.ndarray:
    return nonzero_pixels(layer.rgb, layer.alpha > 0)


def layer_edges(layers, n_layers: int) -> np.ndarray:
    """Bin edges of ``n_layers`` depth layers in signed CoC (pixels), nearest first.

    Parameters
    ----------
    layers : PixelLayer or list of PixelLayer
    n_layers : int
        At least 1.

    Returns
    -------
    ndarray, float64, (n_layers + 1,)
        Equal steps from the smallest to the largest ``coc`` of the live pixels (all zero when
        none is live). Layer ``i`` holds ``edges[i] <= coc < edges[i + 1]``, the last one also
        its upper edge.
    """
    layers = _check_layers(layers)
    return _edges(layers, _check_count(n_layers), [_live(x) for x in layers])


def _edges(layers: list[PixelLayer], n: int, lives: list) -> np.ndarray:
    live = np.concatenate([x.coc[m].ravel() for x, m in zip(layers, lives)])
    lo, hi = (float(live.min()), float(live.max())) if live.size else (0.0, 0.0)
    return np.linspace(lo, hi, n + 1)


def _bins(layer: PixelLayer, edges: np.ndarray, live: np.ndarray) -> np.ndarray:
    """Depth layer of every pixel, -1 for culled ones (``live``: :func:`_live`)."""
    index = np.searchsorted(edges[1:-1], layer.coc.astype(np.float64), side="right")
    return np.where(live, index, -1)


def check_soft(soft) -> float:
    if isinstance(soft, bool) or not isinstance(soft, (int, float, np.floating, np.integer)) \
            or not 0 <= soft <= 1:
        raise InputError(f"soft = {soft!r}: the soft-layering width must be a number in [0, 1] (a "
                         "fraction of one layer's CoC span; 0: hard layers)")
    return float(soft)


def _weights(layer: PixelLayer, edges: np.ndarray, soft: float, live: np.ndarray) -> np.ndarray:
    """(n, H, W) float32 share of every pixel in every depth layer (the module docstring's soft
    layering); 0 for culled pixels (``live``: :func:`_live`). ``soft = 0``: 0/1, the hard bins of
    :func:`_bins`."""
    n = len(edges) - 1
    if soft == 0 or n == 1 or edges[-1] == edges[0]:   # one CoC everywhere: no edge to soften
        bins = _bins(layer, edges, live)
        return np.stack([bins == i for i in range(n)]).astype(np.float32)
    t = (layer.coc.astype(np.float64) - edges[0]) / (edges[1] - edges[0])   # position in bins
    # share above edge k (at t = k): 0 below k - soft/2, 1 above k + soft/2, linear between
    above = [np.ones_like(t)] + [np.clip((t - k) / soft + 0.5, 0.0, 1.0) for k in range(1, n)] + \
        [np.zeros_like(t)]
    return np.stack([(above[i] - above[i + 1]) * live for i in range(n)]).astype(np.float32)


def _hide_within_layers(layers: list[PixelLayer], weights: list) -> list:
    """Each input pixel's share of every depth layer times the transmittance of the input pixels in
    front of it at its image position within that layer (the module docstring's layered input)."""
    if len(layers) == 1:
        return weights
    out = []
    for j, (x, wt) in enumerate(zip(layers, weights)):
        through = np.ones_like(wt)
        for i, (y, wi) in enumerate(zip(layers, weights)):
            if i != j:
                nearer = (y.coc < x.coc) | ((y.coc == x.coc) & (i < j))
                through *= 1.0 - np.where(nearer, y.alpha, 0.0) * wi
        out.append((wt * through).astype(np.float32))
    return out


def render_layers(splatter: LayerSplatter, layers, n_layers: int, soft: float = 0.0):
    """Depth of field with occlusion: splat global depth layers and composite them.

    Parameters
    ----------
    splatter : LayerSplatter
        Splats one layer at a time (e.g. :class:`runtime_cl.polygon.layers.PolygonLayerSplatter`).
    layers : PixelLayer or list of PixelLayer
        The input: one image, or the layers of a layered image (any order).
    n_layers : int
        Global depth layers (>= 1), in equal steps of signed CoC.
    soft : float, default 0
        Soft layering: the width, as a fraction of one layer's CoC span (in [0, 1]), around each
        edge between layers over which a pixel is drawn into both, weighted (0: hard layers).

    Returns
    -------
    image : ndarray, float32, (H, W, C)
        Premultiplied radiance (C as the input's ``rgb``).
    info : dict
        ``edges`` (signed CoC, px), ``layers`` (per non-empty layer: ``index``, ``pixels``,
        ``radius_px`` (rho), ``max_radius_px``, ``device_ms``, ``transfer_ms``,
        ``coverage_gain``: the layer's total coverage after the re-weighting over before, 1
        without holes), ``device_ms`` and ``transfer_ms`` (event-profiled, all layers) and
        ``wall_ms`` (the whole call).
    """
    start = time.perf_counter()
    layers = _check_layers(layers)
    lives = [_live(x) for x in layers]
    edges = _edges(layers, _check_count(n_layers), lives)
    weights = _hide_within_layers(layers, [_weights(x, edges, check_soft(soft), m) for x, m in zip(layers, lives)])
    h, w, c = layers[0].rgb.shape
    front = [_running_sums(wt) for wt in weights]   # each pixel's share of the layers 0 .. i
    out = np.zeros((h, w, c), np.float32)
    over = over_kernel(splatter.device, c)
    per_layer = []
    for index in range(len(edges) - 2, -1, -1):                     # back to front
        members = [wt[index] for wt in weights]
        if not any(m.any() for m in members):
            continue
        resolved, drawn, sites, stats = _splat_layer(splatter, layers, members)
        reach = int(splatter.blur_reach(stats["radius_px"]))
        behind = bool(per_layer)   # something lies behind: the own sites' bound applies
        # outside the box of what the layer drew (its splats, its own sites' blur) "over" leaves
        # out as it is: it is composited on that box alone, and the blurs are made on the box
        # widened by their reach (the same values as blurring the whole frame)
        box = union_box(drawn, grow_box(union_box(*[b for b, _ in sites]), reach, (h, w)) if behind else None)
        region = grow_box(box, reach, (h, w))
        planes = []
        if index:
            nearer = sum(x.alpha[region] * f[index - 1][region] for x, f in zip(layers, front))
            if np.any(nearer > 0):
                planes.append(np.minimum(nearer, 1.0))
        has_hidden = bool(planes)
        if behind:
            own = np.zeros(box_shape(region), np.float32)
            for b, alpha in sites:
                own[inner_box(b, region)] += alpha
            planes.append(np.minimum(own, 1.0))
        blurred = None
        if planes:   # the nearer layers' coverage and the layer's own sites: one blur of both
            blurred, times = splatter.blur(np.stack(planes, axis=2).astype(np.float32), stats["radius_px"])
            _add(stats, times)
        covered, total, ms = over(out, np.ascontiguousarray(on_box(resolved, drawn, box)), box,
                                  blurred, region, has_hidden, behind, MIN_KNOWN)
        stats["device_ms"] += ms
        per_layer.append(dict(stats, index=index, coverage_gain=covered / max(total, 1e-30)))
    info = {"edges": edges.tolist(), "layers": per_layer[::-1],
            "device_ms": sum(x["device_ms"] for x in per_layer),
            "transfer_ms": sum(x["transfer_ms"] for x in per_layer),
            "wall_ms": (time.perf_counter() - start) * 1e3}
    return out.astype(np.float32), info


def _running_sums(weights: np.ndarray) -> list:
    """``np.cumsum(weights, axis=0)`` as a list of planes, the same sums in the same order (a
    slice at a time: 14x faster than numpy's strided cumsum of (n, H, W) float32)."""
    out = [weights[0]]
    for plane in weights[1:]:
        out.append(out[-1] + plane)
    return out


def _add(stats: dict, times: dict) -> None:
    stats["device_ms"] += times["device_ms"]
    stats["transfer_ms"] += times["transfer_ms"]


def _splat_layer(splatter: LayerSplatter, layers, members):
    """One depth layer: resolved premultiplied colour and coverage (on its box), that box, the
    coverage of its sites (a (box, coverage) pair per input layer) and stats (``pixels``, ``radius_px`` rho, ``max_radius_px``,
    times). The layer's images are made on the box of each input layer's non-zero share."""
    c = layers[0].rgb.shape[2]
    h, w = members[0].shape
    parts, radii, shares = [], [], []
    for i, (x, m) in enumerate(zip(layers, members)):
        b = nonzero_box(m)
        if b is None:
            continue
        share = m[b]
        image = np.empty(share.shape + (c + 1,), np.float32)
        np.multiply(x.rgb[b], share[..., None], out=image[..., :c])
        np.multiply(x.alpha[b], share, out=image[..., c])
        coc = np.where(share > 0, x.coc[b], np.float32(0.0))
        parts.append(LayerPart(b, image, coc, i))
        radii.append(np.abs(coc))
        shares.append((image[..., c], share))
    resolved, box, times = splatter.splat_layer(parts, (h, w))
    sites = [(part.box, alpha) for part, (alpha, _) in zip(parts, shares)]
    # rho weighs radii by coverage; a layer of pure light (zero alpha, e.g. the sky) by pixel
    covered = any(alpha.any() for alpha, _ in shares)
    weights = [alpha if covered else m for alpha, m in shares]
    rho = sum(float((wt * r).sum()) for wt, r in zip(weights, radii)) / sum(float(wt.sum()) for wt in weights)
    stats = {"pixels": int(sum((m > 0).sum() for _, m in shares)), "radius_px": rho,
             "max_radius_px": float(max(r.max() for r in radii)), "device_ms": times["device_ms"],
             "transfer_ms": times["transfer_ms"]}
    return resolved, box, sites, stats
