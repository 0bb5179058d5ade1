"""Min/max N-buffers of inverse depth over down-sampled layers (LES10 section 3, Decoret 2005).

Level 0 holds, per ``ds x ds`` block of a layer, the least and the greatest inverse depth of the
pixels that hold something (empty blocks: ``(+BIG, -BIG)``). Level i holds the min/max of level 0
over the ``2^i x 2^i`` square of blocks starting at each block (cut at the grid's edge). Any
rectangle of blocks is then covered by four overlapping squares of one level: four look-ups give
a conservative min/max of the layer under a ray segment's footprint. LES10 keeps the N-buffer on
a down-sampled layer (a quarter of the memory and construction per factor 2) because the
segments it clamps are much larger than a block.
"""
from __future__ import annotations

import numpy as np

__all__ = ["BIG", "levels_for", "minmax_nbuffer"]

BIG = np.float32(1e30)


def levels_for(h4: int, w4: int) -> int:
    """Levels so that the top square covers the whole down-sampled grid."""
    return max(1, int(np.ceil(np.log2(max(h4, w4, 1)))) + 1)


def minmax_nbuffer(inv_depth: np.ndarray, ds: int) -> np.ndarray:
    """The N-buffers of layers of inverse depth.

    Parameters
    ----------
    inv_depth : (L, H, W) float32
        1 / Z per layer pixel, 0 at infinity, negative where the layer holds nothing.
    ds : int
        Down-sampling factor (block size in pixels, >= 1).

    Returns
    -------
    (L, LEVELS, ceil(H / ds), ceil(W / ds), 2) float32
        ``[..., 0]`` the minimum, ``[..., 1]`` the maximum inverse depth (empty: +BIG, -BIG).
    """
    n, h, w = inv_depth.shape
    h4, w4 = -(-h // ds), -(-w // ds)
    pad = np.full((n, h4 * ds, w4 * ds), -1.0, np.float32)
    pad[:, :h, :w] = inv_depth
    blocks = pad.reshape(n, h4, ds, w4, ds)
    empty = blocks < 0
    lo = np.where(empty, BIG, blocks).min(axis=(2, 4))
    hi = np.where(empty, -BIG, blocks).max(axis=(2, 4))
    levels = levels_for(h4, w4)
    out = np.empty((n, levels, h4, w4, 2), np.float32)
    out[:, 0, ..., 0], out[:, 0, ..., 1] = lo, hi
    for lv in range(1, levels):
        half = 1 << (lv - 1)
        prev_lo, prev_hi = out[:, lv - 1, ..., 0], out[:, lv - 1, ..., 1]
        lo, hi = prev_lo.copy(), prev_hi.copy()
        for dy, dx in ((0, half), (half, 0), (half, half)):
            if dy < h4 and dx < w4:
                lo[:, :h4 - dy, :w4 - dx] = np.minimum(lo[:, :h4 - dy, :w4 - dx], prev_lo[:, dy:, dx:])
                hi[:, :h4 - dy, :w4 - dx] = np.maximum(hi[:, :h4 - dy, :w4 - dx], prev_hi[:, dy:, dx:])
        out[:, lv, ..., 0], out[:, lv, ..., 1] = lo, hi
    return out
