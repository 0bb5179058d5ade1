"""A synthetic ``simple_lens`` database of analytic discs, for benchmarks and self-tests.

Each cell's dense PSF is a disc of the cell's CoC radius (pixel coverage estimated on a
``supersample``^2 sub-grid, normalised to sum 1; radius 0 is a delta). Its spreadlets are the
exact 5-point Laplacian of that crop (every non-zero pixel), so integrating them gives the dense
PSF back exactly; ``max_spreadlets`` keeps only the largest-magnitude ones instead (not exact:
for throughput measurements at a chosen spreadlet count). Needs no light tracing, no lab.
"""
from __future__ import annotations

import numpy as np

from .database import DatabaseBuilder, SpreadletDatabase
from .errors import InputError
from .integrate import laplacian5
from .psf_space import NestedGrid


def disc_psf(radius: float, supersample: int = 4) -> np.ndarray:
    """Disc of ``radius`` pixels on a (2R+1)^2 crop, R = ceil(radius), summing to 1 (1x1 if <= 0.5)."""
    if radius <= 0.5:  # inside one pixel: a delta
        return np.ones((1, 1))
    big = int(np.ceil(radius))
    sub = (np.arange(supersample) + 0.5) / supersample - 0.5
    c = np.arange(-big, big + 1)
    y = (c[:, None] + sub[None, :]).reshape(-1)
    inside = (y[:, None] ** 2 + y[None, :] ** 2) <= radius ** 2
    cover = inside.reshape(2 * big + 1, supersample, 2 * big + 1, supersample).mean(axis=(1, 3))
    return cover / cover.sum()


def disc_database(r_max: float, samples: int = 32, beta: float = 2.0, max_spreadlets: int | None = None,
                  fast_track_below: float = 0.0) -> SpreadletDatabase:
    """Build the synthetic disc database.

    Parameters
    ----------
    r_max : float
        Largest CoC radius in pixels (the PSF-space range is [0, r_max]).
    samples : int
        At least this many cells (default 32).
    beta : float
        Power remapping exponent (default 2).
    max_spreadlets : int, optional
        Keep at most this many spreadlets per cell (largest |value| first); default: all.
    fast_track_below : float
        Fast-track the cells whose CoC radius is below this (default 0: none).
    """
    if not (np.isfinite(r_max) and r_max > 0):
        raise InputError(f"r_max = {r_max!r}: must be a finite number of pixels > 0")
    grid = NestedGrid.for_samples(samples, (beta,), ((0.0, float(r_max)),), ("coc_radius_px",))
    builder = DatabaseBuilder("simple_lens", {"synthetic": "disc", "r_max": float(r_max),
                                              "max_spreadlets": max_spreadlets}, grid, 1,
                              2 * int(np.ceil(r_max)) + 1)
    for cell in range(grid.size):
        # in 1-D, cell l is the grid interval [T(l), T(l+1)); its radius is taken at the middle
        radius = float(grid.from_grid([cell * (cell + 1) / 2.0 + (cell + 1) / 2.0])[0])
        psf = disc_psf(radius)
        r = psf.shape[0] // 2
        lap = laplacian5(np.pad(psf, 1))
        ys, xs = np.nonzero(lap)
        if max_spreadlets is not None and len(ys) > max_spreadlets:
            keep = np.argsort(-np.abs(lap[ys, xs]), kind="stable")[:max_spreadlets]
            ys, xs = ys[keep], xs[keep]
        points = np.stack([xs - (r + 1), ys - (r + 1)], axis=1)
        builder.add(points, lap[ys, xs], psf, fast_track=radius < fast_track_below,
                    stats={"sparsity": len(ys) / psf.size, "ssim": 1.0, "l1": 0.0})
    return builder.build()
