"""kernels/psf/psf_space.cl against NestedGrid.index (numpy) on random coordinates.

Every cell boundary lies at an integer grid coordinate g = n s^(1/beta). The kernel decides
floor(g) by comparing s with thresholds (k/n)^beta instead of evaluating pow, so it may differ
from numpy only for points whose g is within rounding of an integer: relative 1e-12 in double
precision (PoCL), 2e-6 in single precision (float32 rounding of s and of the thresholds, ~1e-7,
amplified by 1/beta). Those few points are excluded; all others must match exactly, and so must
the range ends.
"""
import numpy as np
import pytest

from runtime_cl.errors import InputError
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.psf.grid_cl import PsfIndexKernel, check_coords

GRIDS = [
    NestedGrid.for_samples(100, (2.0,), ((0, 30),), ("coc",)),
    NestedGrid.for_samples(20, (1.0,), ((-2, 5),), ("x",)),
    NestedGrid(9, (1.0, 1.0), ((0, 1), (0, 1)), ("a", "b")),
    NestedGrid(40, (2.0, 1.0), ((0, 256), (0, 100)), ("coc", "len")),
    NestedGrid(7, (1.0, 1.0), ((0, 1), (0, 1)), ("a", "b")),  # truncated last level
    NestedGrid(14, (2.5, 1.2, 0.7), ((0, 1), (-1, 1), (0, 3)), ("x", "y", "z")),
    NestedGrid(15, (2.0, 1.0, 1.0), ((0, 30), (0, 50), (0, 72)), ("coc", "len", "angle"), bins=9),
    NestedGrid(10, (1.5, 1.0), ((0, 5), (0, 360)), ("coc", "angle"), bins=24),
]


def near_boundary(grid, x, rel):
    s = grid.normalise(x)
    g = grid.to_grid(s[..., :grid.nested_ns])
    if grid.bins:  # the uniform coordinate's edges are at integer bins * s
        g = np.concatenate([g, s[..., -1:] * grid.bins], axis=-1)
    return np.any(np.abs(g - np.round(g)) <= rel * np.maximum(g, 1.0), axis=-1)


def random_points(grid, rng, n=20000):
    lo = np.array([r[0] for r in grid.ranges])
    hi = np.array([r[1] for r in grid.ranges])
    x = lo + rng.random((n, grid.ns)) * (hi - lo)
    x[: n // 4] = lo + rng.random((n // 4, grid.ns)) ** 4 * (hi - lo)  # crowd the small cells
    x[:8] = lo  # range ends, and mixed ends
    x[8:16] = hi
    x[16:24, 0] = hi[0]
    return x.astype(np.float32)


@pytest.mark.parametrize("fp64", [True, False])
@pytest.mark.parametrize("grid", GRIDS, ids=lambda g: f"n{g.n}-ns{g.ns}-bins{g.bins}")
def test_kernel_matches_numpy(grid, fp64):
    rng = np.random.default_rng(grid.n * 10 + grid.ns)
    x = random_points(grid, rng)
    cells, _ = PsfIndexKernel(grid, fp64=fp64).index(x)
    ref = grid.index(x)
    ok = ~near_boundary(grid, x, 1e-12 if fp64 else 2e-6)
    assert ok.mean() > 0.95  # the exclusion is rare
    np.testing.assert_array_equal(cells[ok], ref[ok])
    np.testing.assert_array_equal(cells[:24], ref[:24])  # range ends are exact
    assert cells.min() >= 0 and cells.max() < grid.size


def test_points_on_cell_boundaries_pick_a_neighbour():
    grid = GRIDS[0]
    g = np.arange(grid.n + 1, dtype=np.float64)
    x = grid.from_grid(g[:, None]).astype(np.float32)
    cells, _ = PsfIndexKernel(grid).index(x)
    ref = grid.index(x)
    # float32 coordinates put the point just either side of the boundary: one cell apart at most
    assert np.all(np.abs(cells.astype(np.int64) - ref) <= 1)


def test_out_of_range_coordinates_are_an_input_error():
    grid = GRIDS[3]
    with pytest.raises(InputError, match=r"\(coc\): 1 pixel\(s\) outside the database range \[0.0, 256.0\]"
                                         r".*max 300"):
        check_coords(grid, np.array([[300.0, 5.0], [1.0, 1.0]], np.float32))
    with pytest.raises(InputError, match=r"\(len\).*nan"):
        check_coords(grid, np.array([[3.0, np.nan]], np.float32))
    with pytest.raises(InputError, match=r"need \(\.\.\., 2\)"):
        check_coords(grid, np.zeros((4, 3), np.float32))
