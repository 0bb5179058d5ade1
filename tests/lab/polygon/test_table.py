"""MHU21 Table 1: non-zero elements of the Laplacian, dxdy and directional kernel differences."""
import math

import numpy as np
import pytest

from lab.errors import UserError
from lab.polygon.table import (METHODS, PAPER_TABLE1, TABLE1_SHAPES, format_table1,
                               nonzero_counts, table1, table1_polygon)
from runtime_cl.polygon.kernel import scale_polygon


@pytest.fixture(scope="module")
def measured():
    return table1((25, 100))


def test_directional_counts_match_the_paper_and_do_not_grow_with_radius(measured):
    for name in TABLE1_SHAPES:
        assert measured[name]["directional"] == PAPER_TABLE1[name]["directional"]
    assert [measured[n]["directional"][0] for n in TABLE1_SHAPES] == [8, 12, 28, 36]


def test_other_methods_grow_linearly_and_hexagon_matches_the_paper(measured):
    for name in TABLE1_SHAPES:
        for method in ("laplacian", "dxdy"):
            small, large = measured[name][method]
            assert 3.5 < large / small < 4.1                      # O(r): 4x the radius
            # corners rounded one pixel differently from the paper's change the count by a
            # constant, independent of r: at most 16 here (measured 4 .. 16)
            paper = PAPER_TABLE1[name][method]
            assert abs(small - paper[0]) <= 16 and abs(large - paper[1]) <= 16
    assert measured["hexagon"]["dxdy"] == (204, 804)             # 8r + 4, as printed


def test_paper_octagon_reproduces_its_laplacian_and_dxdy_counts():
    # MHU21's octagon rounds the corner offset up: (+-r, +-a), (+-a, +-r), a = ceil(r tan(pi/8))
    for r, (lap, dxdy) in zip((25, 100), [(292, 116), (1140, 468)]):
        a = math.ceil(r * math.tan(math.pi / 8))
        octagon = [(r, -a), (r, a), (a, r), (-a, r), (-r, a), (-r, -a), (-a, -r), (a, -r)]
        assert nonzero_counts(octagon) == {"laplacian": lap, "dxdy": dxdy, "directional": 12}


def test_table_shapes_are_rectified_to_mhu21_directions():
    for name in TABLE1_SHAPES:
        unit, dirs = table1_polygon(name)
        assert np.abs(unit[:, 0]).max() == pytest.approx(1.0)        # radius = half-width
        assert len(unit) == {"hexagon": 6, "octagon": 8, "dodecagon": 12, "hexadecagon": 16}[name]
        assert np.abs(dirs).max() <= 2
    v, _ = scale_polygon(*table1_polygon("hexagon"), 25)
    assert {tuple(p) for p in v} == {(0, 50), (0, -50), (25, 25), (25, -25), (-25, 25), (-25, -25)}


def test_format_lists_measured_and_paper_values(measured):
    text = format_table1(measured)
    assert all(name in text for name in TABLE1_SHAPES) and all(m in text for m in METHODS)
    assert "1604 ( 1608)" in text
    with pytest.raises(UserError, match="Table 1 shape"):
        table1_polygon("heart")
