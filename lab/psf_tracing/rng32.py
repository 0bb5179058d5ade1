"""xoroshiro64** (Blackman & Vigna 2018) on Dr.Jit arrays: a random generator in 32-bit lanes.

The tracer's PCG32 (:func:`lab.psf_tracing.tracer.lane_rng`) advances a 64-bit state per number,
which on 16-lane AVX-512 packets takes two registers per value and ~23 instructions per draw. A
photon in fog draws four numbers per collision, so in the Volume model the generator was a fifth
of each collision's work. xoroshiro64** keeps its 64-bit state in two 32-bit words: ~10
instructions per draw, two registers. Its period is 2^64 - 1 and every output bit passes the
authors' tests. (The ``*`` variant saves a multiply, 8 % of the Volume model's time, but its low
bits are weak, and with it a Volume test's PSF anisotropy landed outside its tolerance.)

A generator is seeded from a 64-bit key through splitmix64 (the authors' recommendation), so keys
that differ in one bit start far apart; the tracer's per-ray PCG32 supplies the keys
(:meth:`Xoroshiro64.from_pcg32`), so seeds, cells and launches stay independent as there.
"""
from __future__ import annotations

import drjit as dr
from drjit.llvm import Float, UInt32, UInt64

__all__ = ["Xoroshiro64", "next_reference"]

_MASK32 = 0xFFFFFFFF


def _rotl(x: UInt32, k: int) -> UInt32:
    return (x << k) | (x >> (32 - k))


def _splitmix64(x: UInt64) -> UInt64:
    x = x + 0x9E3779B97F4A7C15
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9
    x = (x ^ (x >> 27)) * 0x94D049BB133111EB
    return x ^ (x >> 31)


class Xoroshiro64:
    """One xoroshiro64** generator per lane (a Dr.Jit struct: loops and branches carry it).

    Parameters
    ----------
    s0, s1 : UInt32, optional
        The state words (not both zero in any lane).
    """

    DRJIT_STRUCT = {"s0": UInt32, "s1": UInt32}

    def __init__(self, s0: UInt32 | None = None, s1: UInt32 | None = None):
        self.s0 = UInt32() if s0 is None else s0
        self.s1 = UInt32() if s1 is None else s1

    @classmethod
    def from_key(cls, key: UInt64) -> "Xoroshiro64":
        """Generators seeded with splitmix64(key), one per entry of ``key``."""
        s = _splitmix64(key)
        s0, s1 = UInt32(s & _MASK32), UInt32(s >> 32)
        return cls(dr.select((s0 == 0) & (s1 == 0), 1, s0), s1)   # the all-zero state is a fixed point

    @classmethod
    def from_pcg32(cls, rng) -> "Xoroshiro64":
        """Generators keyed by the state and stream of a PCG32 (e.g. the tracer's per-ray one)."""
        return cls.from_key(rng.state ^ _splitmix64(rng.inc))

    def next_uint32(self) -> UInt32:
        """The next 32 random bits of every lane (advances the state)."""
        s0, s1 = self.s0, self.s1
        out = _rotl(s0 * 0x9E3779BB, 5) * 5
        s1 = s1 ^ s0
        self.s0 = _rotl(s0, 26) ^ s1 ^ (s1 << 9)
        self.s1 = _rotl(s1, 13)
        return out

    def next_float32(self) -> Float:
        """A uniform float in [0, 1) per lane, on the 2^-24 grid (the top 24 bits)."""
        return Float(self.next_uint32() >> 8) * 2.0 ** -24


def next_reference(s0: int, s1: int) -> tuple[int, int, int]:
    """One step of xoroshiro64** in plain Python (the authors' C code): (output, s0, s1)."""
    def rotl(x, k):
        return ((x << k) | (x >> (32 - k))) & _MASK32
    out = (rotl((s0 * 0x9E3779BB) & _MASK32, 5) * 5) & _MASK32
    s1 ^= s0
    return out, rotl(s0, 26) ^ s1 ^ ((s1 << 9) & _MASK32), rotl(s1, 13)
