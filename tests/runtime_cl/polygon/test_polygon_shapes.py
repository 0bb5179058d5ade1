"""The built-in outlines and the rectified unit polygons the runtime ships (no lab needed)."""
import numpy as np
import pytest

from runtime_cl.errors import InputError
from runtime_cl.polygon import shapes
from runtime_cl.polygon.shapes import SHAPES, pentagram, shape, unit_polygon


@pytest.mark.parametrize("name", SHAPES)
def test_shipped_polygons_run_along_their_directions_counter_clockwise(name):
    v, d = unit_polygon(name)
    assert v.dtype == np.float64 and d.dtype == np.int64 and v.shape == d.shape and v.shape[1] == 2
    edge = np.roll(v, -1, axis=0) - v
    assert np.allclose(edge[:, 0] * d[:, 1] - edge[:, 1] * d[:, 0], 0.0, atol=1e-12)
    assert (np.einsum("ij,ij->i", edge, d) > 0).all()
    area = 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    assert area > 0
    # it encloses the outline, whose circumradius is 1 about its centroid
    assert np.linalg.norm(v, axis=1).max() >= 1.0 - 1e-12


def test_pentagram_has_its_tips_on_the_unit_circle_and_one_at_plus_y():
    p = pentagram()
    r = np.linalg.norm(p, axis=1)
    np.testing.assert_allclose(r[::2], 1.0)
    np.testing.assert_allclose(r[1::2], np.sin(np.pi / 10) / np.sin(7 * np.pi / 10))
    np.testing.assert_allclose(p[0], [0.0, 1.0], atol=1e-15)
    np.testing.assert_array_equal(shape("star"), shape("star", 10))
    assert len(pentagram(40)) == 40


def test_bad_names_and_a_foreign_file_are_input_errors(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="choose one of hexagon"):
        unit_polygon("circle")
    foreign = tmp_path / "shapes.json"
    foreign.write_text('{"format": 0}')
    monkeypatch.setattr(shapes, "SHIPPED", foreign)
    shapes._shipped.cache_clear()
    try:
        with pytest.raises(InputError, match="lab.polygon.ship"):
            unit_polygon("hexagon")
    finally:
        monkeypatch.undo()
        shapes._shipped.cache_clear()
    assert unit_polygon("hexagon")[0].shape == (6, 2)
