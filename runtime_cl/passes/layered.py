"""Layered lens-ray tracing (LES09, LES10) as a runtime pass: N lens rays per pixel.

Each output pixel traces ``rays`` lens rays of the header's lens -- a thin lens, or a thick lens
through its surfaces with per-channel indices (:mod:`runtime_cl.layered.lenses`) -- through the
frame's layers, nearest first, as surfel height fields (:mod:`runtime_cl.layered.tracer`):
min/max clamping with N-buffers over down-sampled layers, empty layers culled, an exact walk of
what is left; jittered Halton lens samples with per-pixel offsets. Rays that leave the image or
find nothing are dropped from the pixel's mean (LES09 4.3). No database.

A tilted or expressive focus (``ThinLens.inverse_focus_map``) gives each pixel its own 1/F.
With ``layered_input`` the frame's ``layerN.*`` layers are traced (e.g. LES10's umbra-peeled
layers from ``lab.reference.peel``), else the flat image as one opaque layer: lens rays then see
only what the pinhole saw.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.layered.lenses import check_lens, tracer_for
from runtime_cl.layered.tracer import layer_stack
from runtime_cl.passes.registry import RuntimePass, register_pass
from runtime_cl.timing import CallTimes

__all__ = ["LayeredPass"]


@register_pass("layered")
class LayeredPass(RuntimePass):
    """Lens rays through layered images (LES09 section 4.3, LES10 section 3), thin or thick lens.

    Options
    -------
    rays : int, default 32
        Lens rays per pixel (>= 1).
    layered_input : bool, default False
        Trace the frame's ``layers`` (``layerN.*``) instead of its flat image.
    max_layers : int, optional
        Trace only the nearest this many input layers (default: all; ``splatlab render --method
        layered --layers N`` sets it; the pass's ``layers`` argument, when > 1, too).
    thickness_px : float, default 1
        Depth of a surfel's slab in pixels of ray travel: neighbours of a continuous surface
        whose CoCs differ by less leave no gap; a silhouette blocks rays at most this far behind it.
    downsample : int, default 4
        Block size of the min/max N-buffer (LES10's quarter resolution).
    pixel_iters : int, default 3
        Min/max clamping rounds per layer for all rays of a pixel at once (LES10: three).
    clamp_iters : int, default 0
        Further min/max clamping rounds per ray.
    false_position : int, default 0
        0: the exact walk; n > 0: LES09's false-position search with n steps (approximate).
    cone : bool, default False
        LES09's approximate cone tracing with colour + coverage mipmaps (fewer rays, less grain), thin
        or thick lens (a cone sized by its neighbouring lens samples' rays).
    seed : int, default 0
        Seeds the per-pixel offsets into the jittered lens sample set.
    interpolate_hidden : bool, default True
        Read what lies behind a nearer layer's pixel (a peeled surfel) bilinearly at each ray's
        hit point, between the cells of its surface, and what the pinhole sees by its cell (sharp,
        as the input). False: every surfel by its cell. Lens rays reach peeled surfels at sub-pixel
        offsets past a defocused occluder; read by cell they passed the peeled layers' grain
        (fewer samples than the input) to the image unfiltered.
    """

    summary = "lens rays through layered height fields (LES09/LES10), thin or thick lens; --rays N"
    database_models = ()
    channels = ("R", "G", "B", "A", "Z")
    layered = True

    def configure(self, *, rays: int = 32, layered_input: bool = False, max_layers: int | None = None,
                  thickness_px: float = 1.0, downsample: int = 4, clamp_iters: int = 0, pixel_iters: int = 3,
                  false_position: int = 0, cone: bool = False, seed: int = 0, interpolate_hidden: bool = True):
        if isinstance(rays, bool) or not isinstance(rays, (int, np.integer)) or rays < 1:
            raise InputError(f"rays = {rays!r}: the number of lens rays per pixel must be an integer >= 1, "
                             "e.g. --rays 100")
        if max_layers is not None and (isinstance(max_layers, bool) or not isinstance(max_layers, (int, np.integer))
                                       or max_layers < 1):
            raise InputError(f"max_layers = {max_layers!r}: trace at least 1 layer, or leave it unset for all")
        if not (isinstance(thickness_px, (int, float)) and np.isfinite(thickness_px) and thickness_px >= 0):
            raise InputError(f"thickness_px = {thickness_px!r}: the surfel slab depth must be >= 0 pixels")
        check_lens(self.camera)
        if self.layers > 1 and max_layers is None:
            max_layers = self.layers
        if max_layers is not None and not layered_input:
            raise InputError(f"layers = {max_layers}: the flat image is one layer; give a layered input "
                             "(layerN.* channels, layered_input) to trace several")
        self.rays, self.layered_input, self.max_layers = int(rays), bool(layered_input), max_layers
        self.thickness_px, self.downsample = float(thickness_px), downsample
        self.clamp_iters, self.pixel_iters, self.false_position = clamp_iters, pixel_iters, false_position
        self.cone = bool(cone)
        self.seed = int(seed)
        if not isinstance(interpolate_hidden, (bool, np.bool_)):
            raise InputError(f"interpolate_hidden = {interpolate_hidden!r}: give true or false (read peeled "
                             "surfels bilinearly, or by cell)")
        self.interpolate_hidden = bool(interpolate_hidden)
        self._tracers: dict = {}

    def _layers(self, frame) -> list:
        if not self.layered_input:
            return [(np.asarray(frame.rgb)[..., :3], frame.coverage(), frame.depth)]
        if not frame.layers:
            raise InputError("layered_input: the input has no layerN.* layers; peel them (a scene with "
                             "[render] peel_layers) or trace the flat image")
        shapes = [x.shape for x in frame.layers]
        if any(s != frame.shape for s in shapes):
            raise InputError(f"layers: sizes {shapes} differ from the image's {frame.shape}; every layerN.* "
                             "must have the image's size")
        chosen = frame.layers[:self.max_layers] if self.max_layers else frame.layers
        return [(np.asarray(x.rgb)[..., :3], x.coverage(), x.depth) for x in chosen]

    def prepare(self, frame):
        if np.shape(frame.rgb)[-1] != 3:
            raise InputError(f"rgb: {np.shape(frame.rgb)[-1]} channel(s); the layered pass renders RGB")
        stack = layer_stack(self._layers(frame), opaque=not self.layered_input)
        key = (stack.inv_depth.shape, id(self.device))
        if key not in self._tracers:
            self._tracers[key] = tracer_for(self.camera, stack.shape, len(stack.inv_depth), self.rays,
                                            downsample=self.downsample, clamp_iters=self.clamp_iters,
                                            pixel_iters=self.pixel_iters, false_position=self.false_position,
                                            cone=self.cone, interpolate_hidden=self.interpolate_hidden,
                                            device=self.device)
        return self._tracers[key], stack

    def __call__(self, prepared):
        tracer, stack = prepared
        image, info = tracer.render(stack, self.thickness_px, self.seed)
        counts = {"pixels": int(image.shape[0] * image.shape[1]), "rays": self.rays,
                  "input_layers": int(len(stack.inv_depth)), "occupancy": stack.occupancy(),
                  **{k: v for k, v in info.items() if not k.endswith("_ms")}}
        return image, CallTimes(info["kernel_ms"], info["transfer_ms"], counts)
