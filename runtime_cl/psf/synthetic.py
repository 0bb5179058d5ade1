"""A synthetic ``simple_lens`` database of analytic discs, for benchmarks and self-tests.

Each cell's dense PSF is a disc of the cell's CoC radius (:func:`runtime_cl.psf.disc.disc_psf`,
supersampled pixels; radius 0 is a delta). Its spreadlets are the exact 5-point Laplacian of that
crop (every non-zero pixel), or with ``basis="rows"`` its exact backward differences along rows,
so integrating them gives the dense PSF back exactly;
``max_spreadlets`` keeps only the largest-magnitude ones instead (not exact: for throughput
measurements at a chosen spreadlet count). Needs no light tracing, no lab.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.database import DatabaseBuilder, SpreadletDatabase
from runtime_cl.psf.disc import disc_psf
from runtime_cl.psf.grid import NestedGrid


def disc_database(r_max: float, samples: int = 32, beta: float = 2.0, max_spreadlets: int | None = None,
                  fast_track_below: float = 0.0, edge: float = 0.0, basis: str = "laplacian") -> SpreadletDatabase:
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
    edge : float
        Width of the discs' soft rim in pixels (default 0: hard discs); see
        :func:`runtime_cl.psf.disc.disc_psf`.
    basis : {"laplacian", "rows"}
        What the spreadlets hold (:mod:`runtime_cl.psf.database`); default ``"laplacian"``.
    """
    if not (np.isfinite(r_max) and r_max > 0):
        raise InputError(f"r_max = {r_max!r}: must be a finite number of pixels > 0")
    if basis not in ("laplacian", "rows"):
        raise InputError(f"basis = {basis!r}: must be 'laplacian' or 'rows'")
    grid = NestedGrid.for_samples(samples, (beta,), ((0.0, float(r_max)),), ("coc_radius_px",))
    builder = DatabaseBuilder("simple_lens", {"synthetic": "disc", "r_max": float(r_max), "edge": float(edge),
                                              "max_spreadlets": max_spreadlets, "basis": basis}, grid, 1,
                              2 * int(np.ceil(r_max + edge / 2)) + 1)
    for cell in range(grid.size):
        # in 1-D, cell l is the grid interval [T(l), T(l+1)); its radius is taken at the middle
        radius = float(grid.from_grid([cell * (cell + 1) / 2.0 + (cell + 1) / 2.0])[0])
        psf = disc_psf(radius, edge=edge)
        r = psf.shape[0] // 2
        if basis == "rows":   # d(x) = psf(x) - psf(x - 1), one column past each side
            lap = np.diff(np.pad(psf, 1), axis=1, prepend=0.0)
        else:
            lap = laplacian5(np.pad(psf, 1))
        ys, xs = np.nonzero(lap)
        if max_spreadlets is not None and len(ys) > max_spreadlets:
            keep = np.argsort(-np.abs(lap[ys, xs]), kind="stable")[:max_spreadlets]
            ys, xs = ys[keep], xs[keep]
        points = np.stack([xs - (r + 1), ys - (r + 1)], axis=1)
        builder.add(points, lap[ys, xs], psf, fast_track=radius < fast_track_below,
                    stats={"sparsity": len(ys) / psf.size, "ssim": 1.0, "l1": 0.0})
    return builder.build()


def _smooth_noise(rng, height: int, width: int, cells: int) -> np.ndarray:
    """Value noise in [0, 1]: a ``cells``^2 random lattice, bilinearly interpolated to (H, W)."""
    lattice = rng.random((cells + 1, cells + 1))
    y = np.linspace(0.0, cells, height, endpoint=False)[:, None]
    x = np.linspace(0.0, cells, width, endpoint=False)[None, :]
    y0, x0 = y.astype(int), x.astype(int)
    fy, fx = y - y0, x - x0
    return ((1 - fy) * (1 - fx) * lattice[y0, x0] + (1 - fy) * fx * lattice[y0, x0 + 1]
            + fy * (1 - fx) * lattice[y0 + 1, x0] + fy * fx * lattice[y0 + 1, x0 + 1])


def defocus_scene(height: int, width: int, r_max: float, channels: int = 3, seed: int = 0):
    """Colour and CoC radii laid out like a shallow depth-of-field photograph, for benchmarks.

    A background fills the frame with CoC radii from 0.55 ``r_max`` (bottom) to 0.9 ``r_max``
    (top), varied by +-0.05 ``r_max`` of smooth noise; a mid-ground block at ~0.3 ``r_max``
    covers ~8 % of the pixels; in-focus subjects (CoC < 1 px) cover ~15 %; a few bright small
    lights sit on the background. Every pixel has a non-zero colour (nothing is culled).

    Parameters
    ----------
    height, width : int
        Image size in pixels.
    r_max : float
        The database's largest CoC radius in pixels; every radius is <= r_max.
    channels : int
        Colour channels, 1 or 3 (default 3).
    seed : int
        Seeds the texture and the lights.

    Returns
    -------
    colour : ndarray, float32, (H, W, channels)
        Linear radiance in [0.05, 1], lights 20.
    coc : ndarray, float32, (H, W, 1)
        CoC radius in pixels, the ``simple_lens`` PSF coordinate.
    """
    if not (np.isfinite(r_max) and r_max > 0):
        raise InputError(f"r_max = {r_max!r}: must be a finite number of pixels > 0")
    if channels not in (1, 3):
        raise InputError(f"channels = {channels}: must be 1 or 3")
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:height, 0:width]
    v, u = yy / max(height - 1, 1), xx / max(width - 1, 1)
    coc = r_max * (0.9 - 0.35 * v + 0.1 * (_smooth_noise(rng, height, width, 4) - 0.5))
    mid = (np.abs(u - 0.78) < 0.14) & (np.abs(v - 0.62) < 0.14)
    coc[mid] = r_max * (0.3 + 0.02 * np.sin(6 * u[mid]))
    subject = ((u - 0.4) / 0.17) ** 2 + ((v - 0.6) / 0.25) ** 2 < 1.0
    coc[subject] = 0.9 * np.abs(v[subject] - 0.6) / 0.25  # focused on the subject's middle
    colour = 0.05 + 0.95 * np.stack([_smooth_noise(rng, height, width, 24) for _ in range(channels)], -1)
    background = ~(mid | subject)
    lights = rng.random((height, width)) < 2e-4
    colour[lights & background] = 20.0
    return colour.astype(np.float32), np.clip(coc, 0.0, r_max).astype(np.float32)[..., None]


def psf_sum_image(size: int, seed: int = 0, discs: int | None = None, channels: int = 3) -> np.ndarray:
    """A sparse random sum of PSF-like discs that is zero near its border, for integrator tests.

    Discs of log-uniform radii from 1 px to ``size`` / 12, each with a linear soft rim 1 to 8 px
    wide (sharp bokeh to blurred blobs) and exponential intensities per channel, placed at
    random inside a zero border of ``size`` / 12 + 8 px: such an image is recovered from its
    5-point Laplacian by the exact Poisson solve (:mod:`runtime_cl.integrate`).

    Parameters
    ----------
    size : int
        The canvas is ``size`` x ``size`` (>= 32).
    seed : int
        Seeds radii, rims, places and intensities.
    discs : int, optional
        Number of discs (default ``max(8, size // 16)``).
    channels : int
        Colour channels (default 3).

    Returns
    -------
    ndarray, float32, (size, size, channels)
    """
    if size < 32:
        raise InputError(f"size = {size}: need a canvas of at least 32 px")
    rng = np.random.default_rng(seed)
    discs = discs or max(8, size // 16)
    r_max = size / 12
    border = int(r_max) + 8
    image = np.zeros((size, size, channels), np.float32)
    for _ in range(discs):
        r = float(np.exp(rng.uniform(0.0, np.log(r_max))))
        rim = float(rng.uniform(1.0, 8.0))
        cx, cy = rng.uniform(border + r, size - border - r, 2)
        x0, y0 = int(cx - r - rim) - 1, int(cy - r - rim) - 1
        x1, y1 = int(cx + r + rim) + 2, int(cy + r + rim) + 2
        yy, xx = np.mgrid[y0:y1, x0:x1] + 0.5
        disc = np.clip((r + rim / 2 - np.hypot(xx - cx, yy - cy)) / rim, 0.0, 1.0)
        image[y0:y1, x0:x1] += (disc[..., None] * rng.exponential(1.0, channels)).astype(np.float32)
    return image
