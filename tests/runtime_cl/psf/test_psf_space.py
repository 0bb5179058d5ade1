"""Property tests of the nested grid (LSR18 section 5.2): forward map vs the list of boxes."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lab.psf_tracing.space import NestedGrid, boxes
from runtime_cl.errors import InputError
from runtime_cl.psf.grid import triangular, triangular_root

GRIDS = [
    NestedGrid(9, (1.0, 1.0), ((0, 1), (0, 1)), ("a", "b")),
    NestedGrid(9, (2.0, 1.0), ((0, 256), (0, 100)), ("coc", "len")),
    NestedGrid(5050, (2.0,), ((0, 256),), ("coc",)),
    NestedGrid(14, (1.5, 1.0, 2.0), ((0, 1), (-1, 1), (0, 3)), ("x", "y", "z")),
    NestedGrid(7, (1.0, 1.0), ((0, 1), (0, 1)), ("a", "b")),  # truncated last level
]


def test_fig5_example_has_28_cells():
    grid = GRIDS[0]
    assert grid.size == 28
    assert grid.levels == 4


def test_triangular_root_exact_at_level_starts():
    l = np.arange(0, 2000)
    assert np.array_equal(triangular_root(triangular(l)), l)
    assert np.array_equal(triangular_root(triangular(l + 1) - 1e-9), l)


@pytest.mark.parametrize("grid", GRIDS, ids=lambda g: f"n{g.n}ns{g.ns}")
def test_centre_of_every_box_maps_to_its_index(grid):
    bs = boxes(grid)
    centres = np.array([b.centre for b in bs])
    assert np.array_equal(grid.index(centres), np.arange(grid.size))
    gcentres = (np.array([b.grid_lo for b in bs]) + np.array([b.grid_hi for b in bs])) / 2
    assert np.array_equal(grid.index_of_grid(gcentres), np.arange(grid.size))


@pytest.mark.parametrize("grid", GRIDS, ids=lambda g: f"n{g.n}ns{g.ns}")
def test_boxes_tile_the_space(grid):
    bs = boxes(grid)
    volume = sum(np.prod(np.subtract(b.grid_hi, b.grid_lo)) for b in bs)
    assert volume == pytest.approx(grid.n ** grid.ns)


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_every_point_maps_to_the_box_containing_it(data):
    grid = data.draw(st.sampled_from(GRIDS))
    # boundaries included: draw integers (cell edges) as well as arbitrary floats
    coord = st.one_of(st.integers(0, grid.n).map(float),
                      st.floats(0, grid.n, allow_nan=False))
    g = np.array([data.draw(coord) for _ in range(grid.ns)])
    i = int(grid.index_of_grid(g))
    b = boxes(grid)[i]
    lo, hi = np.array(b.grid_lo), np.array(b.grid_hi)
    upper_ok = (g < hi) | ((g == hi) & (hi == grid.n))
    assert np.all(g >= lo) and np.all(upper_ok), (g, b)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0, 1), min_size=2, max_size=2))
def test_physical_coordinates_roundtrip(s):
    grid = GRIDS[1]
    x = grid.from_grid(grid.to_grid(np.array(s)))
    lo = np.array([r[0] for r in grid.ranges])
    hi = np.array([r[1] for r in grid.ranges])
    np.testing.assert_allclose(x, lo + np.array(s) ** 1 * (hi - lo), rtol=1e-12, atol=1e-9)


def test_beta_puts_more_cells_at_small_coordinates():
    grid = GRIDS[2]
    his = np.array([b.hi[0] for b in boxes(grid)])
    assert np.sum(his <= 256 / 2) > 0.8 * grid.size  # beta = 2 and linear cell growth


def test_out_of_range_is_a_clear_error():
    with pytest.raises(InputError, match=r"coc = 300.*\[0.0, 256.0\]"):
        GRIDS[2].index(np.array([[300.0]]))
    with pytest.raises(InputError, match="beta"):
        NestedGrid(9, (0.0,), ((0, 1),), ("a",))


def test_for_samples_reaches_the_requested_count():
    for samples, beta in [(100, (2.0,)), (400, (2.0, 1.0)), (4000, (2.5, 1.2))]:
        grid = NestedGrid.for_samples(samples, beta, [(0, 1)] * len(beta), ["x"] * len(beta))
        assert samples <= grid.size < samples * 1.2


BINNED = [
    NestedGrid(9, (2.0, 1.0, 1.0), ((0, 16), (0, 40), (0, 60)), ("coc", "len", "angle"), bins=6),
    NestedGrid(10, (1.5, 1.0), ((0, 5), (0, 360)), ("coc", "angle"), bins=24),
]


@pytest.mark.parametrize("grid", BINNED, ids=lambda g: f"ns{g.ns}bins{g.bins}")
def test_a_binned_grid_repeats_the_nested_cells_per_bin(grid):
    nested = NestedGrid(grid.n, grid.beta[:-1], grid.ranges[:-1], grid.names[:-1])
    bs = boxes(grid)
    assert grid.size == len(bs) == grid.bins * nested.size and grid.nested_size == nested.size
    centres = np.array([b.centre for b in bs])
    assert np.array_equal(grid.index(centres), np.arange(grid.size))
    lo, hi = grid.ranges[-1]
    for b in (0, grid.bins - 1):
        cells = bs[b * nested.size:(b + 1) * nested.size]
        assert [c.lo[:-1] for c in cells] == [c.lo for c in boxes(nested)]
        assert {c.lo[-1] for c in cells} == {lo + (hi - lo) * b / grid.bins}
        assert {c.hi[-1] for c in cells} == {lo + (hi - lo) * (b + 1) / grid.bins}
    assert NestedGrid.from_json(grid.to_json()) == grid


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_every_physical_point_of_a_binned_grid_maps_to_its_box(data):
    grid = data.draw(st.sampled_from(BINNED))
    x = np.array([data.draw(st.floats(lo, hi, allow_nan=False)) for lo, hi in grid.ranges])
    b = boxes(grid)[int(grid.index(x[None])[0])]
    top = np.array([hi for _, hi in grid.ranges])
    # the physical box edges are rounded from grid ones: allow an ulp
    assert np.all(x >= np.array(b.lo) - 1e-12 * top), (x, b)
    assert np.all((x <= np.array(b.hi) + 1e-12 * top)), (x, b)


def test_bad_bins_are_a_clear_error():
    with pytest.raises(InputError, match="bins = -1"):
        NestedGrid(9, (1.0, 1.0), ((0, 1), (0, 1)), ("a", "b"), bins=-1)
    with pytest.raises(InputError, match="beta 1"):
        NestedGrid(9, (1.0, 2.0), ((0, 1), (0, 1)), ("a", "b"), bins=4)
    with pytest.raises(InputError, match="another"):
        NestedGrid(9, (1.0,), ((0, 1),), ("a",), bins=4)
    assert NestedGrid.for_samples(400, (2.0, 1.0, 1.0), [(0, 1)] * 3, ["a", "b", "c"], bins=8).size >= 400
