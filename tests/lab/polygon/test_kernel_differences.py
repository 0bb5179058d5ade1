"""Directional kernel differences (runtime_cl.polygon.kernel) against brute-force rasterisation."""
import math

import numpy as np
import pytest
import shapely
from scipy.signal import convolve2d

from lab.polygon.rectify import direction_set, rectify
from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import (differenced_kernel, directional_prefix_sum,
                                       rasterize_polygon, reconstruct, scale_polygon)
from runtime_cl.polygon.shapes import SHAPES, shape

T = math.tan(math.pi / 8)
OCTAGON = np.array([(1, -T), (1, T), (T, 1), (-T, 1), (-1, T), (-1, -T), (-T, -1), (T, -1)])
OCTAGON_DIRS = np.array([(0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0), (1, 1)])


def random_polygon(rng, n, radius, simple=True):
    """Integer polygon: star-shaped about the origin (simple) or in random order (not)."""
    ang = rng.uniform(0, 2 * np.pi, n)
    ang = np.sort(ang) if simple else ang
    rad = rng.uniform(0.2, 1.0, n) * radius
    return np.round(np.c_[rad * np.cos(ang), rad * np.sin(ang)]).astype(np.int64)


def embedded(k, x0, y0, canvas, cx, cy):
    """``k`` (origin x0, y0) placed on a zero array shaped like ``canvas`` (origin cx, cy)."""
    out = np.zeros_like(canvas)
    assert x0 >= cx and y0 >= cy
    out[y0 - cy:y0 - cy + k.shape[0], x0 - cx:x0 - cx + k.shape[1]] = k
    return out


def assert_reconstructs(v, directions=None):
    kern = differenced_kernel(v, directions)
    rec, rx, ry = reconstruct(kern)
    k, x0, y0 = rasterize_polygon(v)
    np.testing.assert_array_equal(rec, embedded(k, x0, y0, rec, rx, ry))
    return kern


def test_rasteriser_counts_lattice_points_by_picks_theorem():
    rng = np.random.default_rng(0)
    for _ in range(50):
        v = random_polygon(rng, int(rng.integers(3, 12)), 30)
        e = np.roll(v, -1, axis=0) - v
        if (np.abs(e).sum(1) == 0).any() or not shapely.Polygon(v).is_valid:
            continue
        area2 = abs(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        if area2 == 0:
            continue
        boundary = np.gcd(np.abs(e[:, 0]), np.abs(e[:, 1])).sum()
        # Pick: A = I + B/2 - 1, so the closed polygon holds I + B = A + B/2 + 1 points
        assert rasterize_polygon(v)[0].sum() * 2 == area2 + boundary + 2


def test_rasteriser_ties_on_edges_are_inside():
    k, x0, y0 = rasterize_polygon([(0, 0), (4, 0), (4, 2), (0, 2)])
    assert (x0, y0) == (0, 0) and k.shape == (3, 5) and k.all()
    tri, _, _ = rasterize_polygon([(0, 0), (2, 2), (0, 2)])       # the diagonal's points belong
    np.testing.assert_array_equal(tri, [[1, 0, 0], [1, 1, 0], [1, 1, 1]])


@pytest.mark.parametrize("simple", [True, False])
def test_reconstruction_is_exact_for_random_polygons(simple):
    rng = np.random.default_rng(1 if simple else 2)
    for _ in range(150):
        n, radius = int(rng.integers(3, 10)), float(rng.uniform(1, 25))
        assert_reconstructs(random_polygon(rng, n, radius, simple))


def test_octagon_terms_are_constant_in_radius_and_two_per_run():
    counts = {}
    for r in (8, 25, 60, 100, 200):
        v, d = scale_polygon(OCTAGON, OCTAGON_DIRS, r)
        counts[r] = assert_reconstructs(v).nnz
    assert set(counts.values()) == {12}                   # 2 horizontal + 4 diagonal edges, 2 each


@pytest.mark.parametrize("name", SHAPES)
def test_rectified_shapes_have_two_terms_per_column_of_run_at_every_large_radius(name):
    unit, dirs = rectify(shape(name), direction_set(2), 16).unit()
    for r in (40, 90, 150):
        v, d = scale_polygon(unit, dirs, r)
        assert len(v) == len(unit)                        # no edge vanished at this radius
        assert assert_reconstructs(v, dirs).nnz == 2 * np.abs(d[:, 0]).sum()


def test_terms_per_edge_grow_with_the_run_of_the_direction():
    # edge runs 3 (direction (3, 2)), 1 (horizontal) and 0 (vertical): 2 * 3 + 2 * 1 terms
    kern = assert_reconstructs([(0, 0), (30, 20), (30, 0)])
    assert kern.nnz == 8
    assert sorted(map(tuple, kern.directions)) == [(1, 0), (3, 2)]
    assert set(np.abs(kern.value)) <= {1, 2}


def test_radius_zero_is_the_identity():
    v, d = scale_polygon(OCTAGON, OCTAGON_DIRS, 0)
    np.testing.assert_array_equal(v, [[0, 0]])
    assert d.shape == (0, 2)
    rec, x0, y0 = reconstruct(differenced_kernel(v, [(1, 0), (1, 1)]))
    assert rec[-y0, -x0] == 1 and rec.sum() == 1


def splat_reference(image, kern, pad):
    """What the runtime does: splat the terms into padded buffers, prefix sums, crop."""
    h, w = image.shape
    total = np.zeros((h + 2 * pad, w + 2 * pad))
    ys, xs = np.nonzero(image)
    for k, d in enumerate(kern.directions):
        dx, dy, val = kern.terms(k)
        buf = np.zeros_like(total)
        for y, x in zip(ys, xs):
            np.add.at(buf, (y + pad + dy, x + pad + dx), image[y, x] * val)
        total += directional_prefix_sum(buf, d)
    return directional_prefix_sum(total, (0, 1))[pad:pad + h, pad:pad + w]


@pytest.mark.parametrize("radius", [0, 3, 20])
def test_splatting_equals_convolution_even_when_the_kernel_exceeds_the_image(radius):
    rng = np.random.default_rng(3)
    image = rng.integers(0, 5, (9, 12)).astype(float)
    v, _ = scale_polygon(OCTAGON, OCTAGON_DIRS, radius)
    kern = differenced_kernel(v, [(1, 0), (1, 1), (1, -1)])
    k, x0, y0 = rasterize_polygon(v)
    full = convolve2d(image, k)                        # full[y - y0 + ...]: offset by (y0, x0)
    want = full[-y0:-y0 + image.shape[0], -x0:-x0 + image.shape[1]]
    bx0, bx1, by0, by1 = kern.bounds
    pad = max(abs(bx0), bx1, abs(by0), by1) + 1
    np.testing.assert_array_equal(splat_reference(image, kern, pad), want)


def test_scale_polygon_keeps_directions_and_symmetry():
    for r in (1, 2, 7, 25, 100):
        v, d = scale_polygon(OCTAGON, OCTAGON_DIRS, r)
        edges = np.roll(v, -1, axis=0) - v
        g = np.gcd(edges[:, 0], edges[:, 1])[:, None]
        np.testing.assert_array_equal(edges // g, d)
        assert {tuple(x) for x in d} <= {tuple(x) for x in OCTAGON_DIRS}
        assert {tuple(p) for p in v} == {tuple(-p) for p in v}          # point symmetric
        if r >= 7:
            assert len(v) == 8
            assert np.abs(v).max() == r and np.abs(np.sort(np.abs(v[:, 1]))[0] - r * T) <= 0.5


def test_prefix_sum_inverts_the_directional_difference():
    rng = np.random.default_rng(4)
    for d in [(1, 0), (1, 1), (2, -1), (3, 2), (0, 1)]:
        k = np.pad(rng.integers(-3, 4, (12, 15)), 4)
        diff = k.copy()
        a, b = d
        shifted = np.zeros_like(k)
        h, w = k.shape
        shifted[max(b, 0):h + min(b, 0), a:] = k[max(-b, 0):h - max(b, 0), :w - a]
        diff = k - shifted
        np.testing.assert_array_equal(directional_prefix_sum(diff, d), k)


def test_bad_input_names_the_argument():
    with pytest.raises(InputError, match="vertices"):
        differenced_kernel([(0, 0), (1.5, 0), (0, 2)])
    with pytest.raises(InputError, match="directions"):
        differenced_kernel([(0, 0), (4, 2), (0, 2)], [(1, 0)])
    with pytest.raises(InputError, match="radius"):
        scale_polygon(OCTAGON, OCTAGON_DIRS, -1)
    with pytest.raises(InputError, match="radius"):
        scale_polygon(OCTAGON, OCTAGON_DIRS, float("nan"))
    with pytest.raises(InputError, match="directions"):
        scale_polygon(OCTAGON, np.roll(OCTAGON_DIRS, 1, axis=0), 10)
    with pytest.raises(InputError, match="direction"):
        directional_prefix_sum(np.zeros((3, 3)), (-1, 1))
    assert issubclass(InputError, ValueError)
