"""Occlusion for the normalised stochastic reconstruction: re-centred samples in global depth
layers (LSR18 6.2, "Layering Details"), each normalised on its own and composited front to back.

Splatting every re-centred sample with its full PSF ignores what lies in front of it: a blurred
background sample that landed behind an in-focus object (it was seen past the object's edge
through part of the lens) spreads its disc over the object too, and dividing by the summed
density blends that in (a halo of background over the object's outline). Binned into layers of
signed CoC (constant parallax, :func:`runtime_cl.layers.composite.layer_edges`), each layer l has
its splatted colour ``C_l`` and sample density ``D_l``. The nearest layer is seen by every lens
ray that meets it, so its expected density is its coverage of the lens: an in-focus object has
``D = 1`` exactly, however much lies behind it. So, front to back:

    N_l = C_l / D_l (push-pull filled, :func:`runtime_cl.stochastic.fill.normalise`)
    a_l = min(1, D_l / min(1, S_l)),   S_l = D_l + D_{l+1} + ...   (the last layer: a = 1)
    out = sum_l T_l a_l N_l,           T_0 = 1,  T_{l+1} = T_l (1 - a_l)

Where the layers from l back hold at least one sample's worth (``S_l >= 1``) the opacity is
the layer's own density (the occluder hides what the splats behind it spill over it); where
they hold less, samples are missing at random and the layer's share of what is there,
``D_l / S_l``, is the steadier estimate (with nothing behind it a blurred foreground stays
opaque through its own density's noise). One layer is the plain normalised reconstruction.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.layers.composite import PixelLayer, layer_edges
from runtime_cl.stochastic.fill import normalise

__all__ = ["check_layers", "composite", "layer_bins"]


def check_layers(depth_layers) -> int:
    if isinstance(depth_layers, bool) or not isinstance(depth_layers, (int, np.integer)) or not 1 <= depth_layers <= 16:
        raise InputError(f"depth_layers = {depth_layers!r}: give an integer in [1, 16] (global depth layers of the "
                         "re-centred samples; 1: no occlusion)")
    return int(depth_layers)


def layer_bins(cocs: list, counts: list, n_layers: int) -> list:
    """The depth layer (0 nearest) of every entry of every slot, -1 where the entry is empty.

    Parameters
    ----------
    cocs : list of (H, W)
        Signed CoC in pixels of each slot's entries.
    counts : list of (H, W, K)
        Samples in each entry (0 in every channel: empty; K > 1: per colour channel, as a thick
        lens re-centres them).
    n_layers : int
        Equal steps of signed CoC over the non-empty entries.
    """
    held = [np.max(n, axis=-1) > 0 for n in counts]
    pixels = [PixelLayer(np.zeros(c.shape + (1,), np.float32), m.astype(np.float32), np.asarray(c))
              for c, m in zip(cocs, held)]
    edges = layer_edges(pixels, n_layers)
    return [np.where(m, np.searchsorted(edges[1:-1], np.asarray(c, np.float64), side="right"), -1)
            for c, m in zip(cocs, held)]


def _box3(a: np.ndarray) -> np.ndarray:
    """3 x 3 mean (edges repeated): the opacity from a density steadier than one pixel's."""
    p = np.pad(a, ((1, 1), (1, 1)) + ((0, 0),) * (a.ndim - 2), mode="edge")
    h, w = a.shape[:2]
    return sum(p[i:i + h, j:j + w] for i in range(3) for j in range(3)) / 9.0


def composite(colours: list, densities: list, min_density: float, fill: bool = True) -> np.ndarray:
    """Composite per-layer splatted colours (H, W, C) and densities (H, W, 1), nearest first
    (module docstring); ``fill`` False divides by at least ``min_density`` instead of filling."""
    out = np.zeros(np.shape(colours[0]), np.float64)
    through = np.ones(np.shape(densities[0]), np.float64)
    smooth = [_box3(np.maximum(np.asarray(d, np.float64), 0.0)) for d in densities]
    behind = np.cumsum(smooth[::-1], axis=0)[::-1]
    for index, (c, d) in enumerate(zip(colours, densities)):
        d = np.maximum(np.asarray(d, np.float64), 0.0)
        n = normalise(c, d, min_density) if fill else np.asarray(c) / np.maximum(d, min_density)
        if index == len(colours) - 1:
            alpha = np.ones_like(d)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                alpha = np.where(smooth[index] > 0, np.minimum(1.0, smooth[index] / np.minimum(1.0, behind[index])), 0.0)
        out += through * alpha * n
        through = through * (1.0 - alpha)
    return out.astype(np.float32)
