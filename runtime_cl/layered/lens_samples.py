"""Lens samples of the layered tracer: a Halton set on the unit disc (LES09 section 4.5).

LES09 jitters lens samples per pixel by an offset into a precomputed sequence: with N rays per
pixel and a set of 2N Halton points, pixel i uses points ``(o_i + j) mod 2N``, j < N, for a
per-pixel offset o_i. Neighbouring pixels so see different but overlapping, well stratified
sample sets, which turns the aliasing of one shared pattern into fine noise.
"""
from __future__ import annotations

import numpy as np

__all__ = ["halton", "disc_samples"]


def halton(n: int, base: int) -> np.ndarray:
    """The first ``n`` points (indices 1..n) of the van der Corput sequence in ``base``, float64."""
    out = np.zeros(n)
    for i in range(n):
        f, k, x = 1.0, i + 1, 0.0
        while k:
            f /= base
            x += f * (k % base)
            k //= base
        out[i] = x
    return out


def disc_samples(n: int) -> np.ndarray:
    """``n`` Halton (2, 3) points mapped to the unit disc by Shirley's concentric map, (n, 2) float32.

    The concentric map keeps the square's stratification, so the points cover the disc evenly
    and their mean distance from the centre is near 2/3 (uniform area density).
    """
    u = 2.0 * np.stack([halton(n, 2), halton(n, 3)], axis=-1) - 1.0
    x, y = u[:, 0], u[:, 1]
    big_x = np.abs(x) > np.abs(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(big_x, x, y)
        phi = np.where(big_x, np.pi / 4 * y / x, np.pi / 2 - np.pi / 4 * x / y)
    phi = np.where((x == 0) & (y == 0), 0.0, phi)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1).astype(np.float32)
