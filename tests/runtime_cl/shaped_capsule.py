"""Brute-force pixel probabilities of a moving point seen through a shaped aperture: the aperture
(turned by 180 degrees in front of the focal plane) scaled to the CoC radius and swept along the
motion, integrated over a sub-pixel grid and the shutter (``aperture``: anything with a numpy
``contains(x, y)`` at unit circumradius, e.g. :mod:`lab.optics.aperture`). The reference for the Combined model's
shaped apertures, independent of Dr.Jit, the PSF space and the runtime's turns."""
from __future__ import annotations

import math

import numpy as np


def shaped_capsule_psf(aperture, coc_px: float, length_px: float, direction_deg: float, size: int,
                       supersample: int = 8, nodes: int = 64) -> np.ndarray:
    """(size, size) float64 summing to 1, centred at pixel size // 2, rows down. ``coc_px`` < 0 is
    a point in front of the focal plane (the aperture upside down), > 0 one behind it."""
    sub = (np.arange(supersample) + 0.5) / supersample - 0.5
    g = (np.arange(size)[:, None] + sub[None, :]).reshape(-1) - size // 2
    x, y = g[None, :], -g[:, None]                 # image x right, y up
    a = math.radians(direction_deg)
    sign = -1.0 if coc_px < 0 else 1.0
    acc = np.zeros((size * supersample, size * supersample))
    for t in (np.arange(nodes) + 0.5) / nodes - 0.5:
        px, py = x - t * length_px * math.cos(a), y - t * length_px * math.sin(a)
        acc += aperture.contains(sign * px / abs(coc_px), sign * py / abs(coc_px))
    out = acc.reshape(size, supersample, size, supersample).mean(axis=(1, 3))
    return out / out.sum()
