"""Small random volume and volume_far databases for the runtime's medium tests."""
import numpy as np

from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.psf.grid import NestedGrid

STATS = {"sparsity": 0.5, "ssim": 0.9, "l1": 0.01}
FINGERPRINT = {"medium": {"sigma_t": 0.25, "albedo": [0.9, 0.9, 0.8], "g": 0.6}, "fov_x_deg": 40.0}


def far_database(rng, scale=4, radius=6, model="volume_far", hole=5, samples=4, psf_resolution=None):
    """A database of ``model`` over distances 1-3 m, random dense PSFs of ``2 radius + 1`` px (a
    ``volume`` one whose ``psf_resolution`` keeps the window a ``hole`` px far field completes)."""
    grid = NestedGrid.for_samples(samples, (1.0,), [(1.0, 3.0)], ["distance_m"])
    params = {"config": {"pixel_scale": scale, "hole_half_px": hole}, "fingerprint": FINGERPRINT}
    b = DatabaseBuilder(model, params, grid, 3, psf_resolution or 2 * radius + 1)
    for _ in range(grid.size):
        dense = rng.random((2 * radius + 1, 2 * radius + 1, 3)).astype(np.float32)
        b.add(np.zeros((0, 2), int), np.zeros((0, 3)), dense, fast_track=True, stats=STATS)
    return b.build()
