"""scale_polygon's DP in OpenCL (ScaleOracle) and the radius table (ScaleTable) against numpy."""
import numpy as np
import pytest
from polygon_reference import shape

from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import scale_polygon
from runtime_cl.polygon.scale import ScaleOracle, ScaleTable, TOLERANCE, _f32_next


def cost(unit, w, r):
    return float(((w - r * unit) ** 2).sum())


@pytest.mark.parametrize("name", ["hexagon", "octagon", "star", "heart12"])
def test_oracle_is_scale_polygon(name):
    unit, d = shape(name)
    oracle = ScaleOracle(unit, d)
    rng = np.random.default_rng(7)
    radii = np.concatenate([rng.random(150) * 60, [0.0, 0.5, 1.0, 2.5, 100.0]])
    raw = oracle.raw(radii)
    for r, w in zip(radii, raw):
        want = scale_polygon(unit, d, float(r))[0]
        got = oracle(float(r))[0]
        assert np.array_equal(got, want), (name, r)
        assert got.shape[0] <= len(unit)
        assert cost(unit, w, r) >= 0


@pytest.mark.parametrize("name", ["hexagon", "octagon", "t1hex", "heart12"])
def test_table_matches_scale_polygon_everywhere_probed(name):
    """Well-conditioned shapes: random float32 radii and both sides of every switch."""
    unit, d = shape(name)
    oracle = ScaleOracle(unit, d)
    table = ScaleTable.build(oracle, 40.0)
    assert table.breaks[0] == 0 and np.all(np.diff(table.breaks) > 0)
    rng = np.random.default_rng(3)
    radii = np.concatenate([np.float32(rng.random(300) * 40), table.breaks[1:],
                            _f32_next(table.breaks[1:], -1)]).astype(np.float32)
    for r, w in zip(radii, oracle.raw(radii.astype(np.float64))):
        assert np.array_equal(table.polygon(r), scale_polygon(unit, d, float(r))[0]), (name, r)


def test_star_ties_are_optimal():
    """The star's mirror-image polygons tie; the table keeps one of the optima."""
    unit, d = shape("star")
    oracle = ScaleOracle(unit, d)
    table = ScaleTable.build(oracle, 20.0)
    radii = np.float32(np.random.default_rng(5).random(300) * 20)
    raw = oracle.raw(radii.astype(np.float64))
    mismatch = 0
    for r, w in zip(radii, raw):
        entry = table.raw[table.index(r)]
        assert cost(unit, entry, float(r)) <= cost(unit, w, float(r)) + 10 * TOLERANCE
        mismatch += not np.array_equal(table.polygon(r), scale_polygon(unit, d, float(r))[0])
    assert mismatch < len(radii) // 4


def test_bad_input():
    unit, d = shape("octagon")
    with pytest.raises(InputError, match="directions"):
        ScaleOracle(unit, d[::-1])
    with pytest.raises(InputError, match="max_radius"):
        ScaleTable.build(ScaleOracle(unit, d), float("nan"))
