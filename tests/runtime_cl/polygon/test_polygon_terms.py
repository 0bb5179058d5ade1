"""O(vertices) directional differences (runtime_cl.polygon.terms) against the brute-force rasteriser."""
import numpy as np
import pytest
from polygon_reference import shape

from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import (differenced_kernel, edge_direction, rasterize_polygon,
                                       reconstruct, scale_polygon)
from runtime_cl.polygon.terms import is_simple, polygon_terms, to_differenced_kernel


def dirs_of(w):
    out = []
    for p, q in zip(w, np.roll(w, -1, axis=0)):
        if q[0] != p[0] and edge_direction(*(q - p)) not in out:
            out.append(edge_direction(*(q - p)))
    return out or [(1, 0)]


def same_indicator(a, b):
    """Compare (K, x0, y0) triples on a common frame."""
    (ka, xa, ya), (kb, xb, yb) = a, b
    x0, y0 = min(xa, xb), min(ya, yb)
    x1 = max(xa + ka.shape[1], xb + kb.shape[1])
    y1 = max(ya + ka.shape[0], yb + kb.shape[0])
    fa, fb = np.zeros((y1 - y0, x1 - x0), np.int64), np.zeros((y1 - y0, x1 - x0), np.int64)
    fa[ya - y0:ya - y0 + ka.shape[0], xa - x0:xa - x0 + ka.shape[1]] = ka
    fb[yb - y0:yb - y0 + kb.shape[0], xb - x0:xb - x0 + kb.shape[1]] = kb
    return np.array_equal(fa, fb)


def check(w, dirs):
    t = polygon_terms(w, dirs)
    ref = rasterize_polygon(w)
    assert same_indicator(reconstruct(to_differenced_kernel(t, dirs)), ref), w.tolist()
    assert t.area == ref[0].sum()
    return t


def test_random_polygons_reconstruct_exactly():
    rng = np.random.default_rng(1)
    simple = 0
    for _ in range(600):
        n = rng.integers(3, 9)
        ang = np.sort(rng.random(n)) * 2 * np.pi
        rad = rng.integers(1, 12, n)
        w = np.stack([np.round(rad * np.cos(ang)), np.round(rad * np.sin(ang))], 1).astype(np.int64)
        w = w[np.any(w != np.roll(w, 1, axis=0), axis=1)]
        simple += check(w, dirs_of(w)).simple
    assert simple > 450   # most are simple (the O(n) path); the rest exercise the fallback


@pytest.mark.parametrize("name", ["hexagon", "octagon", "star", "t1hex", "heart12"])
def test_scaled_shapes_reconstruct_and_count(name):
    unit, d = shape(name)
    dirs = list(dict.fromkeys(edge_direction(*e) for e in d if e[0] != 0))
    counts = {}
    for r in list(np.linspace(0, 30, 61)) + [60.0, 137.25]:
        w, _ = scale_polygon(unit, d, r)
        counts[r] = check(w, dirs).nnz
    big = [counts[r] for r in (30.0, 60.0, 137.25)]
    assert len(set(big)) == 1        # constant in r (MHU21): 16 / 12 / 20 / 8 / 32 terms
    w, _ = scale_polygon(unit, d, 60.0)
    assert big[0] == differenced_kernel(w, dirs).nnz   # as few as MHU21's grouping


def test_mhu21_counts():
    for name, nnz in (("t1hex", 8), ("octagon", 12)):
        unit, d = shape(name)
        dirs = list(dict.fromkeys(edge_direction(*e) for e in d if e[0] != 0))
        assert polygon_terms(scale_polygon(unit, d, 100.0)[0], dirs).nnz == nnz


def test_degenerate_and_concave():
    check(np.array([[0, 0]]), [(1, 0)])                          # radius 0: the delta
    check(np.array([[0, 0], [4, 2]]), [(2, 1)])                   # a segment
    check(np.array([[0, 0], [6, 0], [6, 6], [3, 2], [0, 6]]), [(1, 0), (3, -4), (3, 4)])
    assert not is_simple([[0, 0], [4, 0], [0, 3], [4, 3]])        # bow tie
    assert not is_simple([[0, 0], [4, 0], [2, 0]])                # folds back on itself
    assert is_simple([[0, 0], [4, 0], [0, 3]])


def test_missing_direction_is_an_input_error():
    with pytest.raises(InputError, match="directions"):
        polygon_terms([[0, 0], [4, 0], [0, 3]], [(1, 0)])
    with pytest.raises(InputError, match="primitive"):
        polygon_terms([[0, 0], [4, 0], [0, 3]], [(2, 0)])
