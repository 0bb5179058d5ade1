"""The rectified built-in shapes the runtime ships are what the lab's rectification gives today.

The file was written on one CPU; another's libm and SIMD paths round the rectification's
trigonometry differently in the last bit (measured: 1 ulp, 1.1e-16, on an AMD Zen 3 against the
shipping machine), so vertices are compared to 1e-12 of the unit circumradius (10^4 ulps; 1e-9 px
on a 1000-px bokeh, where a change to a shape or to the rectification moves them by pixels), and
edge counts and direction vectors (integers) exactly.
"""
import json

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


VERTEX_ATOL = 1e-12


def test_the_shipped_file_is_what_rectification_gives_now(fresh):
    shipped, now = json.loads(SHIPPED.read_text()), json.loads(fresh)
    stale = f"{SHIPPED} is stale: run `python -m lab.polygon.ship` and commit the file"
    assert {k: v for k, v in shipped.items() if k != "shapes"} == {k: v for k, v in now.items() if k != "shapes"}, stale
    assert list(shipped["shapes"]) == list(now["shapes"]), stale
    for name, entry in now["shapes"].items():
        old = shipped["shapes"][name]
        assert old["edges"] == entry["edges"] and old["directions"] == entry["directions"], (name, stale)
        np.testing.assert_allclose(old["vertices"], entry["vertices"], rtol=0, atol=VERTEX_ATOL, err_msg=stale)


@pytest.mark.parametrize("name", SHAPES)
def test_unit_polygon_is_the_rectified_shape(name):
    want_v, want_d = rectify(shape(name), direction_set(SHIPPED_DIRECTIONS_M), default_edges(name)).unit()
    v, d = unit_polygon(name)
    assert v.dtype == want_v.dtype and d.dtype == want_d.dtype
    np.testing.assert_allclose(v, want_v, rtol=0, atol=VERTEX_ATOL)
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
