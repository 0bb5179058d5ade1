"""An analytic capsule PSF (a disc swept along a segment: LSR18's Combined model) and a small
``combined`` database of it whose spreadlets are its exact 5-point Laplacian, for rotation tests."""
from __future__ import annotations

import numpy as np

from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.grid import NestedGrid

STATS = {"sparsity": 0.5, "ssim": 1.0, "l1": 0.0}


def capsule_psf(radius: float, length: float, edge: float = 1.5, supersample: int = 4,
                skew: float = 0.0) -> np.ndarray:
    """Points within ``radius`` of the segment from (-length/2, 0) to (length/2, 0) (image +x), a
    rim falling off linearly over ``edge`` pixels, pixel coverage on a ``supersample``^2 sub-grid;
    (2R+1)^2 crop, sums to 1. ``skew`` > 0 brightens the +x end and the upper side (rows above the
    centre) so that every turn and flip of the PSF differs."""
    big = int(np.ceil(radius + length / 2 + edge / 2))
    sub = (np.arange(supersample) + 0.5) / supersample - 0.5
    c = (np.arange(-big, big + 1)[:, None] + sub[None, :]).reshape(-1)
    y, x = c[:, None], c[None, :]
    dist = np.hypot(np.maximum(np.abs(x) - length / 2, 0.0), y)
    inside = np.clip((radius - dist) / edge + 0.5, 0.0, 1.0) * (1.0 + skew * (x - 0.5 * y) / big)
    cover = inside.reshape(2 * big + 1, supersample, 2 * big + 1, supersample).mean(axis=(1, 3))
    return cover / cover.sum()


def capsule_database(radius: float = 4.0, length: float = 10.0, max_coc: float = 8.0, max_motion: float = 16.0,
                     samples: int = 6, fast: bool = False, direction_deg: float = 0.0, skew: float = 0.0):
    """A ``combined`` database (coordinates |CoC| px, motion px) whose every cell holds the same
    capsule (:func:`capsule_psf`), traced along ``direction_deg`` (recorded like the lab does, with
    its symmetries)."""
    grid = NestedGrid.for_samples(samples, (2.0, 1.0), ((0.0, max_coc), (0.0, max_motion)),
                                  ("coc_radius_px", "motion_px"))
    params = {"config": {"max_coc_px": max_coc, "max_motion_px": max_motion, "motion_direction_deg": direction_deg},
              "symmetries": ["motion_direction", "coc_sign"]}
    psf = capsule_psf(radius, length, skew=skew)
    r = psf.shape[0] // 2
    lap = laplacian5(np.pad(psf, 1))
    ys, xs = np.nonzero(lap)
    b = DatabaseBuilder("combined", params, grid, 1, 2 * r + 1)
    for _ in range(grid.size):
        b.add(np.stack([xs - r - 1, ys - r - 1], 1), lap[ys, xs], psf, fast_track=fast, stats=STATS)
    return b.build()
