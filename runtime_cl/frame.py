"""What a runtime pass renders: labelled pixels in memory (the EXR contract's channels)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["Frame"]


@dataclass(frozen=True)
class Frame:
    """Labelled pixels: ``R, G, B, A, Z`` and the optional channels a pass may read.

    Parameters
    ----------
    rgb : array_like, (H, W, C), C = 1 or 3
        Linear radiance (premultiplied by ``alpha``).
    depth : array_like, (H, W)
        Camera-space planar depth Z in metres (> 0; ``inf`` for the background).
    alpha : array_like, (H, W), optional
        Coverage in [0, 1]; default 1 everywhere.
    motion : array_like, (H, W, 2), optional
        ``motion.X, motion.Y``: pixels over the shutter, X right, Y up.
    layers : sequence of Frame, optional
        ``layerN.*`` of a layered input, nearest first, each with rgb, alpha and depth.
    guard_px : int, default 0
        Guard band (LSR18 "Boundary"): the pixels are the frame plus this margin on every side,
        so blur from outside the frame comes in; :func:`runtime_cl.passes.run_pass` renders them
        all and crops the margin off the result.
    samples : array_like, (H, W, 3) or (H, W, 5), optional
        ``lens.U, lens.V, time`` of a stochastic (1-spp) input (:mod:`runtime_cl.stochastic`), and
        optionally ``subpixel.X, subpixel.Y``.
    channel_depth : array_like, (H, W, C), optional
        ``Z.R, Z.G, Z.B`` of a stochastic input through a thick lens: the depth each colour
        channel's ray hit (:func:`runtime_cl.stochastic.channel_depths`); default ``depth`` for all.
    """

    rgb: np.ndarray
    depth: np.ndarray
    alpha: np.ndarray | None = None
    motion: np.ndarray | None = None
    layers: tuple = ()
    guard_px: int = 0
    samples: np.ndarray | None = None
    channel_depth: np.ndarray | None = None

    def __post_init__(self):
        rgb, depth = np.asarray(self.rgb), np.asarray(self.depth)
        if depth.ndim != 2 or rgb.ndim != 3 or rgb.shape[:2] != depth.shape:
            raise InputError(f"rgb {rgb.shape} and depth {depth.shape}: need (H, W, C) colour and "
                             "(H, W) depth of the same image")
        h, w = depth.shape
        if self.alpha is not None and np.shape(self.alpha) != (h, w):
            raise InputError(f"alpha: shape {np.shape(self.alpha)}, need (H, W) = {(h, w)}")
        if self.motion is not None and np.shape(self.motion) != (h, w, 2):
            raise InputError(f"motion: shape {np.shape(self.motion)}, need (H, W, 2) = {(h, w, 2)} "
                             "(motion.X, motion.Y in pixels, Y up)")
        if self.samples is not None and np.shape(self.samples) not in ((h, w, 3), (h, w, 5)):
            raise InputError(f"samples: shape {np.shape(self.samples)}, need (H, W, 3) = {(h, w, 3)} "
                             "(lens.U, lens.V, time) or (H, W, 5) (and subpixel.X, subpixel.Y)")
        if self.channel_depth is not None and np.shape(self.channel_depth) != rgb.shape:
            raise InputError(f"channel_depth: shape {np.shape(self.channel_depth)}, need one depth per colour "
                             f"channel, (H, W, C) = {rgb.shape} (Z.R, Z.G, Z.B)")
        object.__setattr__(self, "layers", tuple(self.layers))
        g = self.guard_px
        if isinstance(g, bool) or not isinstance(g, (int, np.integer)) or g < 0 or (g and 2 * g >= min(h, w)):
            raise InputError(f"guard_px = {g!r}: the guard band must be an integer >= 0 narrower than half "
                             f"the image ({h}x{w} pixels, frame and band), or 0 for no band")

    @property
    def shape(self) -> tuple:
        return np.shape(self.depth)

    def crop(self, image: np.ndarray) -> np.ndarray:
        """``image`` (H, W, ...) of these pixels without the guard band: the frame."""
        g = self.guard_px
        return image if g == 0 else np.ascontiguousarray(image[g:image.shape[0] - g, g:image.shape[1] - g])

    def coverage(self) -> np.ndarray:
        """``alpha``, or 1 everywhere when the frame has none."""
        return np.ones(self.shape, np.float32) if self.alpha is None else np.asarray(self.alpha, np.float32)
