"""The PSF light tracer (LSR18 sections 5.3, 5.4): rays from a point light through the optics,
histogrammed into an R x R PSF image, with pre-filtering over a cell of the PSF space.

A model supplies a per-ray Dr.Jit function ``rays(coords, rng) -> RayHits``: ``coords`` holds one
Float array per PSF-space dimension (each ray its own PSF coordinate), ``rng`` the ray's PCG32 for
its remaining random numbers; it returns where each ray lands relative to the PSF centre in image
pixels (column right, row down), whether it got through (vignetting = inactive), its channel and,
optionally, an integer multiplicity (a ray standing for several equal hits, e.g. a photon that
crosses the camera sphere of the Volume model more than once).

Pre-filtering: every ray draws its PSF coordinate uniformly from the cell's box, so the PSF
stored for a cell is the average of all PSFs the runtime maps to that cell (LSR18's box filter).

Binning is by pixel area: the pixel at offset k covers [k - 1/2, k + 1/2) on each axis and the
centre pixel is (R//2, R//2), so a hit at the exact centre is counted once in the centre pixel and
an in-focus point is an exact delta. Counts are integers (UInt32 per launch, int64 in total) and
are normalised in float64: the result is exact up to the final float32 rounding.

Reproducible: the same seed, stream (cell) and ``rays_per_launch`` give bitwise the same PSF.
All scalars enter the kernels through ``dr.opaque`` so a new cell, seed or lens reuses the
compiled kernel instead of recompiling.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Sequence

import drjit as dr
import numpy as np
from drjit.llvm import Array2f, Bool, Float, Float64, Int32, PCG32, UInt32, UInt64

from lab.errors import UserError
from lab.llvm_check import problem as llvm_problem

__all__ = ["RayHits", "TraceResult", "trace_psf", "lane_rng", "DEFAULT_RAYS_PER_LAUNCH",
           "MAX_RAYS_PER_LAUNCH"]

DEFAULT_RAYS_PER_LAUNCH = 2 ** 22  # ~100 MB of per-ray temporaries in a fused kernel: bounded
MAX_RAYS_PER_LAUNCH = 2 ** 30      # per-launch counts are UInt32; keep far from overflow
_MASK64 = (1 << 64) - 1


@dataclass
class RayHits:
    """Per-ray result of a model's ray function (Dr.Jit arrays of one launch).

    Attributes
    ----------
    offset : Array2f
        Landing point relative to the PSF centre in image pixels (column right, row down).
    active : Bool or None
        False for rays blocked on the way (vignetting); None means all got through.
    channel : UInt32 or None
        Colour channel of each ray, in [0, channels); None for monochrome models.
    weight : UInt32 or None
        Integer multiplicity of each active ray's hit (counts add ``weight``, not 1); None means 1.
        Keep weights small: per-launch bin totals are UInt32.
    """

    offset: Array2f
    active: Bool | None = None
    channel: UInt32 | None = None
    weight: UInt32 | None = None


RayFunction = Callable[[list, PCG32], RayHits]


@dataclass(frozen=True)
class TraceResult:
    """A traced PSF and its statistics.

    Attributes
    ----------
    psf : ndarray (R, R, C) float32
        Each channel sums to 1 over the image (rows = y downward, centre at (R//2, R//2)).
    counts : ndarray (R, R, C) int64
        Rays per pixel and channel.
    n_rays : int
        Rays traced.
    n_outside : int
        Rays that got through the optics but landed outside the R x R image (0 for valid configs),
        counted with their weights.
    n_blocked : int
        Rays blocked inside the optics (vignetting), each counted once.
    seconds : float
        Wall time of the launches, synchronised.
    sq_weights : ndarray (C,) float64 or None
        Per channel, the sum of the squared weights of the rays counted in the image (None for a
        model without weights: each ray weighs 1). With weights w, a channel's histogram has the
        noise of (sum w)^2 / sum w^2 equal-weight rays (:attr:`effective_rays`).
    """

    psf: np.ndarray
    counts: np.ndarray
    n_rays: int
    n_outside: int
    n_blocked: int
    seconds: float
    sq_weights: np.ndarray | None = None

    @property
    def effective_rays(self) -> np.ndarray:
        """Per channel: the number of equal-weight rays whose histogram is as noisy as this one's,
        (sum w)^2 / sum w^2 over the rays in the image (the landed count when every weight is 1)."""
        landed = self.counts.sum(axis=(0, 1)).astype(np.float64)
        return landed if self.sq_weights is None else landed * landed / self.sq_weights

    @property
    def mrays_per_second(self) -> float:
        return self.n_rays / self.seconds / 1e6 if self.seconds > 0 else float("inf")


def _splitmix64(x: int) -> int:
    x = (x + 0x9E3779B97F4A7C15) & _MASK64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK64
    return x ^ (x >> 31)


def _splitmix64_dr(x: UInt64) -> UInt64:
    """splitmix64 finaliser on Dr.Jit arrays (wrapping 64-bit arithmetic), same as :func:`_splitmix64`."""
    x = x + 0x9E3779B97F4A7C15
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9
    x = (x ^ (x >> 27)) * 0x94D049BB133111EB
    return x ^ (x >> 31)


def _launch_seeds(seed: int, stream: int, launch: int) -> tuple[int, int]:
    """Two well-mixed 64-bit words per (seed, stream, launch): the bases of the lanes' PCG32
    states and increments, so cells and launches draw independent numbers."""
    base = _splitmix64(_splitmix64(_splitmix64(seed & _MASK64) ^ (stream & _MASK64)) ^ launch)
    return base, _splitmix64(base ^ 0x5851F42D4C957F2D)


_LLVM_OK = False


def _require_llvm() -> None:
    """Fail with the install command (not an abort deep in Dr.Jit) when libLLVM is unusable."""
    global _LLVM_OK
    if not _LLVM_OK:
        msg = llvm_problem()
        if msg:
            raise UserError(msg)
        _LLVM_OK = True


def _check_int(name: str, value, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo \
            or (hi is not None and value > hi):
        bound = f"an integer >= {lo}" + (f" and <= {hi}" if hi is not None else "")
        raise UserError(f"{name} = {value!r}: must be {bound}")
    return int(value)


def lane_rng(n: int, seed: int, stream: int = 0, launch: int = 0) -> PCG32:
    """``n`` independent PCG32 generators, one per lane, as the tracer seeds them.

    Every lane's state and increment is hashed: PCG32(n, s, q) alone seeds lane i with s + i and
    q + i, whose first outputs form a lattice across lanes (correlated, not independent rays).
    ``seed``, ``stream`` (e.g. a cell) and ``launch`` select independent sequences.
    """
    state, seq = _launch_seeds(seed, stream, launch)
    lane = dr.arange(UInt64, n)
    return PCG32(n, _splitmix64_dr(lane + dr.opaque(UInt64, state)),
                 _splitmix64_dr(lane + dr.opaque(UInt64, seq)))


def _launch(rays: RayFunction, lo, width, resolution: int, channels: int, n: int,
            rng: PCG32) -> np.ndarray:
    """Trace ``n`` rays; return UInt32 counts of length R*R*C + 2 (outside, then blocked), and
    per channel the sum of the squared weights of the rays counted in the image (None without
    weights)."""
    coords = [dr.opaque(Float, a) + dr.opaque(Float, w) * rng.next_float32() for a, w in zip(lo, width)]
    hits = rays(coords, rng)
    c = resolution // 2
    # Pixel offset k covers [k - 1/2, k + 1/2): round, then compare in float (NaN -> outside).
    k = dr.floor(hits.offset + 0.5)
    first, end = dr.opaque(Float, -c), dr.opaque(Float, resolution - c)
    inside = (k.x >= first) & (k.x < end) & (k.y >= first) & (k.y < end)
    col = UInt32(Int32(dr.select(inside, k.x, 0.0)) + dr.opaque(Int32, c))
    row = UInt32(Int32(dr.select(inside, k.y, 0.0)) + dr.opaque(Int32, c))
    r = dr.opaque(UInt32, resolution)
    index = (row * r + col) * channels
    if hits.channel is not None:
        index += hits.channel
    outside_bin = dr.opaque(UInt32, resolution * resolution * channels)
    index = dr.select(inside, index, outside_bin)
    target = dr.zeros(UInt32, resolution * resolution * channels + 2)
    value = UInt32(1)
    if hits.active is not None:
        index = dr.select(hits.active, index, outside_bin + 1)
    if hits.weight is not None:
        value = hits.weight if hits.active is None else dr.select(hits.active, hits.weight, 1)
    # Expand: per-thread copies of the histogram, so a delta PSF (all rays in one pixel) does
    # not serialise on one atomic.
    dr.scatter_reduce(dr.ReduceOp.Add, target, value, index, mode=dr.ReduceMode.Expand)
    if hits.weight is None:
        return target.numpy(), None
    # squared weights of the rays in the image, per channel (Float64: w^2 sums overflow UInt32)
    w = Float64(hits.weight)
    sq = dr.zeros(Float64, channels + 1)
    landed = index < outside_bin
    ch = UInt32(0) if hits.channel is None else hits.channel
    dr.scatter_reduce(dr.ReduceOp.Add, sq, w * w, dr.select(landed, ch, channels), mode=dr.ReduceMode.Expand)
    return target.numpy(), sq.numpy()[:channels]


def trace_psf(rays: RayFunction, lo: Sequence[float], hi: Sequence[float], resolution: int,
              n_rays: int, seed: int = 0, *, channels: int = 1, stream: int = 0,
              rays_per_launch: int = DEFAULT_RAYS_PER_LAUNCH) -> TraceResult:
    """Light-trace one PSF, pre-filtered over the PSF-space box [lo, hi].

    Parameters
    ----------
    rays : callable
        The model's per-ray function ``rays(coords, rng) -> RayHits`` (see module docstring).
    lo, hi : sequence of float
        The box in physical PSF coordinates (one entry per dimension, lo <= hi); each ray draws
        its coordinate uniformly from it. lo == hi traces the single PSF at lo.
    resolution : int
        R: the PSF image is R x R pixels (>= 1).
    n_rays : int
        Rays to trace (>= 1).
    seed : int, default 0
        Random seed (>= 0); with ``stream`` and ``rays_per_launch`` it fixes the result bitwise.
    channels : int, default 1
        C, the number of colour channels.
    stream : int, default 0
        Independent random stream, e.g. the cell index, so cells do not share random numbers.
    rays_per_launch : int, default 2**22
        Rays per kernel launch; memory is bounded by this, not by ``n_rays``.

    Returns
    -------
    TraceResult
        The normalised PSF (R, R, C) float32, integer counts and ray statistics.
    """
    _require_llvm()
    resolution = _check_int("psf resolution", resolution, 1)
    n_rays = _check_int("n_rays", n_rays, 1)
    seed = _check_int("seed", seed, 0)
    channels = _check_int("channels", channels, 1)
    stream = _check_int("stream", stream, 0)
    rays_per_launch = _check_int("rays_per_launch", rays_per_launch, 1, MAX_RAYS_PER_LAUNCH)
    lo, hi = [float(v) for v in lo], [float(v) for v in hi]
    if len(lo) != len(hi) or not all(np.isfinite(lo + hi)) or any(b < a for a, b in zip(lo, hi)):
        raise UserError(f"PSF box lo = {lo}, hi = {hi}: needs finite bounds with lo <= hi per dimension")
    width = [b - a for a, b in zip(lo, hi)]

    total = np.zeros(resolution * resolution * channels + 2, dtype=np.int64)
    sq_weights = None
    start = time.perf_counter()
    for launch, first in enumerate(range(0, n_rays, rays_per_launch)):
        n = min(rays_per_launch, n_rays - first)
        counts, sq = _launch(rays, lo, width, resolution, channels, n, lane_rng(n, seed, stream, launch))
        total += counts
        if sq is not None:
            sq_weights = sq if sq_weights is None else sq_weights + sq
    dr.sync_thread()
    seconds = time.perf_counter() - start

    counts = total[:-2].reshape(resolution, resolution, channels)
    n_outside, n_blocked = int(total[-2]), int(total[-1])
    landed = counts.sum(axis=(0, 1))
    if np.any(landed == 0):
        empty = [int(c) for c in np.flatnonzero(landed == 0)]
        raise UserError(f"no ray reached the PSF image in channel(s) {empty} ({n_rays} rays, "
                        f"{n_outside} outside): enlarge the PSF resolution or check the optics")
    psf = (counts / landed.astype(np.float64)).astype(np.float32)
    return TraceResult(psf, counts, n_rays, n_outside, n_blocked, seconds, sq_weights)
