"""The stochastic input's sample points: one per pixel, stratified across neighbouring pixels.

pbrt-v4's ``ZSobolSampler`` (Ahmed and Wonka's screen-space Sobol, as pbrt uses it): each pixel's
point is the point of an Owen-scrambled Sobol sequence at its Morton index, whose base-4 digits
are randomly permuted per quadtree node. Every aligned 2^j x 2^j block of pixels then holds an
aligned run of 4^j sequence indices, and such a run of the Sobol sequence is a (0, 2j, 2)-net in
its first two dimensions: the lens samples of every 2 x 2, 4 x 4, ... block of pixels cover the
lens square stratum by stratum, and the shutter (the third dimension) likewise. The digit
permutations and the nested (Owen) scrambling leave each pixel's point uniform and keep the
pattern from repeating (a plain Morton order gives every block's top-left pixel the same lens
half; a Sobol net over the pixel positions themselves draws streaks along the rows).
"""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["sample_points"]

_PERMUTATIONS = np.array(list(itertools.permutations(range(4))), np.uint64)   # the 24 orders of a quadtree node
_REVERSED_BYTE = np.array([int(f"{i:08b}"[::-1], 2) for i in range(256)], np.uint32)


def sample_points(rng: np.random.Generator, h: int, w: int) -> tuple:
    """Every pixel's point (see the module docstring), row-major: ``jitter`` (N, 2) float64 sub-pixel
    positions in [0, 1), ``lens`` (N, 2) float32 lens samples in [0, 1) and ``shutter`` (N,)
    float64 shutter fractions in [0, 1)."""
    from scipy.stats import qmc

    levels = max(int(np.ceil(np.log2(max(h, w)))), 0)
    index = _shuffled_morton(h, w, levels, np.uint64(rng.integers(0, 2**63)))
    sobol = qmc.Sobol(5, scramble=False, bits=32).random_base2(2 * levels)[index.astype(np.int64)]
    seeds = rng.integers(0, 2**32, 5, dtype=np.uint64).astype(np.uint32)
    pts = np.stack([_owen((sobol[:, d] * 2.0**32).astype(np.uint64).astype(np.uint32), seeds[d]) for d in range(5)],
                   axis=1) / 2.0**32
    top = np.nextafter(np.float32(1.0), np.float32(0.0))
    return pts[:, 3:5], np.minimum(pts[:, :2].astype(np.float32), top), pts[:, 2]


def _shuffled_morton(h: int, w: int, levels: int, seed: np.uint64) -> np.ndarray:
    """(h * w,) uint64 sequence index of each pixel: its Morton code on a 2^levels square, each
    base-4 digit permuted by one of the 24 orders, chosen by a hash of the digits above it."""
    ys, xs = np.divmod(np.arange(h * w, dtype=np.uint64), np.uint64(w))
    morton = np.zeros(h * w, np.uint64)
    for b in range(levels):
        morton |= ((xs >> np.uint64(b)) & np.uint64(1)) << np.uint64(2 * b)
        morton |= ((ys >> np.uint64(b)) & np.uint64(1)) << np.uint64(2 * b + 1)
    index = np.zeros(h * w, np.uint64)
    with np.errstate(over="ignore"):
        for i in range(levels):
            digit = (morton >> np.uint64(2 * i)) & np.uint64(3)
            node = _mix64(morton >> np.uint64(2 * i + 2) ^ _mix64(np.uint64(i) + seed))
            index |= _PERMUTATIONS[node % np.uint64(24), digit] << np.uint64(2 * i)
    return index


def _mix64(x):
    """SplitMix64's finaliser: a well-spread 64-bit hash."""
    with np.errstate(over="ignore"):
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def _reverse_bits(x: np.ndarray) -> np.ndarray:
    r = _REVERSED_BYTE
    return (r[x & 0xFF] << 24) | (r[(x >> 8) & 0xFF] << 16) | (r[(x >> 16) & 0xFF] << 8) | r[x >> 24]


def _owen(x: np.ndarray, seed: np.uint32) -> np.ndarray:
    """Nested uniform (Owen) scrambling of the 32-bit fractions ``x`` (uint32): Burley's hash
    (JCGT 2020; Laine and Karras's permutation on the bit-reversed value), where each output bit
    depends on the bits above it only, so every elementary interval's points stay in one."""
    x = _reverse_bits(x) + seed
    for k in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x ^= x * np.uint32(k)
    return _reverse_bits(x)
