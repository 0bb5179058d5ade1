"""The rectified built-in shapes the runtime ships are what the lab's rectification gives today."""
import numpy as np
import pytest

import lab.polygon.rectify
from lab.polygon.rectify import direction_set, rectify
from lab.polygon.ship import shipped_text, write_shipped
from lab.polygon_aperture import default_edges, polygon_aperture
from runtime_cl.polygon.shapes import SHAPES, SHIPPED, SHIPPED_DIRECTIONS_M, shape, unit_polygon


@pytest.fixture(scope="module")
def fresh():
    return shipped_text()


def test_the_shipped_file_is_what_rectification_gives_now(fresh):
    assert SHIPPED.read_text() == fresh, (
        f"{SHIPPED} is stale: run `python -m lab.polygon.ship` and commit the file")


@pytest.mark.parametrize("name", SHAPES)
def test_unit_polygon_is_the_rectified_shape_bit_for_bit(name):
    want_v, want_d = rectify(shape(name), direction_set(SHIPPED_DIRECTIONS_M), default_edges(name)).unit()
    v, d = unit_polygon(name)
    assert v.dtype == want_v.dtype and d.dtype == want_d.dtype
    np.testing.assert_array_equal(v, want_v)
    np.testing.assert_array_equal(d, want_d)


def test_write_is_atomic_and_complete(tmp_path, fresh):
    out = write_shipped(tmp_path / "shapes.json")
    assert out.read_text() == fresh
    assert [p.name for p in tmp_path.iterdir()] == ["shapes.json"]


def test_polygon_aperture_loads_the_shipped_polygon_and_rectifies_otherwise(monkeypatch):
    calls = []
    real = lab.polygon.rectify.rectify
    monkeypatch.setattr(lab.polygon.rectify, "rectify", lambda *a: calls.append(a) or real(*a))
    shipped = polygon_aperture("heart")
    assert calls == [] and shipped.edges == 16
    other = polygon_aperture("heart", edges=12)
    assert len(calls) == 1 and other.edges == 12
