"""The uniform-radius path (UniformBlur) against brute force, and its host-side pieces.

Bit for bit: the banded one-pass sweep's integer sums against a plain integer scatter of the same
quantised colours (``polygon_reference.splat_fixed``), whatever the number of bands, channels or
the kernel's size relative to the image.
"""
import numpy as np
import pytest
from polygon_reference import SHAPES, shape, splat_fixed

from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import directional_prefix_sum, rasterize_polygon
from runtime_cl.polygon.splat import PolygonSplatter
from runtime_cl.polygon.uniform import column_events, directional_prefix_taps, exponent_bits

_SPLATTERS = {}


def splatter(name):
    if name not in _SPLATTERS:
        _SPLATTERS[name] = PolygonSplatter(*shape(name))
    return _SPLATTERS[name]


def scene(rng, h, w, c):
    img = (rng.random((h, w, c)) - 0.3).astype(np.float32)   # negative colours too
    img[rng.random((h, w)) < 0.3] = 0.0
    return img


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("channels", [1, 2, 4])
def test_every_channel_count_is_brute_force_exact(name, channels):
    rng = np.random.default_rng(channels)
    sp = splatter(name)
    img = scene(rng, 23, 31, channels)
    out, info = sp.render(img, 7.5, fixed=True)
    np.testing.assert_array_equal(out, splat_fixed(img, 7.5, sp.polygon, info["exponent"][0],
                                                   uniform=True))


@pytest.mark.parametrize("name", ["hexagon", "heart12"])
def test_regions_start_from_the_exact_state(name):
    """Regions of one or a few rows under a kernel ~25 rows tall, most of them owned by no
    worker and taken, whole or in halves: each start-up computes the state of the row above
    it, so every split gives the same integers."""
    rng = np.random.default_rng(3)
    sp = splatter(name)
    img = scene(rng, 17, 40, 3)
    ref = splat_fixed(img, 12.0, sp.polygon, sp.render(img, 12.0, fixed=True)[1]["exponent"][0],
                      uniform=True)
    uniform = sp._uniform
    try:
        uniform.min_take = 0
        for sub, regions in ((1, 1), (1, 5), (2, 17), (3, 4), (16, 1)):
            uniform.sub_rows, uniform.regions = sub, regions
            for _ in range(3):   # the split points depend on the workers' timing
                out, info = sp.render(img, 12.0, fixed=True)
                np.testing.assert_array_equal(out, ref)
                assert info["starts"] >= min(regions, -(-17 // sub))   # one per region at least
    finally:
        uniform.sub_rows, uniform.regions, uniform.min_take = 16, 1, None


def test_workers_share_one_region_exactly():
    """One region of 40 sub-bands: with taking never worth a start-up one worker sweeps it all;
    otherwise a worker, whenever it has nothing left, takes the bottom half of the largest
    region, down to single sub-bands. Every split gives the same integers."""
    sp = PolygonSplatter(*shape("hexagon"))
    img = scene(np.random.default_rng(8), 160, 64, 3)
    uniform = sp._uniform
    uniform.sub_rows, uniform.min_take = 4, 10 ** 6
    alone, info = sp.render(img, 10.0, fixed=True)
    assert info["starts"] == 1
    np.testing.assert_array_equal(alone, splat_fixed(img, 10.0, sp.polygon, info["exponent"][0],
                                                     uniform=True))
    uniform.min_take = 0
    for _ in range(5):
        shared, info = sp.render(img, 10.0, fixed=True)
        np.testing.assert_array_equal(shared, alone)
        assert 1 <= info["starts"] <= 40


@pytest.mark.parametrize("ch", [1, 2, 4])
def test_every_step_width_is_brute_force_exact(ch):
    """The vectors per step (-DCH, picked by the device's vector width) change no sum."""
    sp = PolygonSplatter(*shape("hexagon"))
    sp._uniform.ch = ch
    img = scene(np.random.default_rng(ch), 37, 53, 3)   # 159 lanes: a partial last step
    out, info = sp.render(img, 9.0, fixed=True)
    np.testing.assert_array_equal(out, splat_fixed(img, 9.0, sp.polygon, info["exponent"][0],
                                                   uniform=True))


def test_streamed_output_is_the_cached_one(monkeypatch):
    """Large outputs are stored non-temporally into a cache-line aligned array: same colours."""
    import runtime_cl.polygon.uniform as pu

    sp = PolygonSplatter(*shape("hexagon"))
    img = scene(np.random.default_rng(5), 1100, 1000, 3)     # 13 MB of output: streamed
    streamed, _ = sp.render(img, 20.0)
    assert streamed.nbytes >= pu.STREAM_BYTES and streamed.ctypes.data % 64 == 0
    monkeypatch.setattr(pu, "STREAM_BYTES", 1 << 40)
    cached, _ = sp.render(img, 20.0)
    np.testing.assert_array_equal(streamed, cached)
    assert streamed.shape == img.shape and streamed.flags.writeable and streamed.flags.c_contiguous


def test_kernel_larger_than_the_image():
    rng = np.random.default_rng(5)
    sp = splatter("octagon")
    img = scene(rng, 6, 9, 3)
    out, info = sp.render(img, 40.0, fixed=True)
    np.testing.assert_array_equal(out, splat_fixed(img, 40.0, sp.polygon, info["exponent"][0],
                                                   uniform=True))


def test_non_finite_colours_are_refused():
    sp = splatter("hexagon")
    for bad in (np.nan, np.inf, -np.inf):
        img = np.ones((5, 37, 3), np.float32)
        img[4, 36, 2] = bad                       # the last lane of the last row
        with pytest.raises(InputError, match="image: 1 non-finite"):
            sp.render(img, 4.0)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_prefix_taps_and_column_events_rebuild_the_kernel(name):
    """Per direction the prefix of its terms (the ring's start taps), summed and summed down the
    columns, is the rasterised polygon; so is, per column, the sum of its events at or below
    each row (the column sums' start)."""
    sp = splatter(name)
    for r in (3.0, 17.5):
        t = sp.kernel_terms(r)
        k, x0, y0 = rasterize_polygon(sp.polygon(r))
        pad = 4
        total = np.zeros((k.shape[0] + 2 * pad, k.shape[1] + 2 * pad), np.int64)
        for d in range(len(sp.directions)):
            on = t.direction == d
            p = directional_prefix_taps(t.dx[on], t.dy[on], t.value[on], sp.directions[d])
            np.add.at(total, (p[:, 1] - y0 + pad, p[:, 0] - x0 + pad), p[:, 2])
        np.testing.assert_array_equal(directional_prefix_sum(total, (0, 1))[pad:-pad, pad:-pad], k)
        ev = column_events(sp.polygon(r))
        assert np.all(np.diff(ev[:, 0]) >= 0) and set(ev[:, 2]) == {-1, 1}
        got = np.zeros((k.shape[0] + 1, k.shape[1]), np.int64)   # row 0: above the kernel
        np.add.at(got, (ev[:, 0] - y0 + 1, ev[:, 1] - x0), ev[:, 2])
        np.testing.assert_array_equal(np.cumsum(got[::-1], axis=0)[::-1][1:], k)


def test_prefix_taps_need_lines_that_sum_to_zero():
    with pytest.raises(RuntimeError, match="sum to 1"):
        directional_prefix_taps([0, 2], [0, 2], [1, 0], (1, 1))


@pytest.mark.parametrize("peak", [0.0, 1e-40, 1e-3, 0.7, 1.0, 1.2, 3e4, -5.0, 3e38])
def test_exponent_keeps_the_gathered_sums_in_int32(peak):
    """The device picks the exponent from the rows' peaks (subnormal, negative and the largest
    floats too): every direction's gathered sum stays in int32, with at most two bits idle."""
    sp = splatter("hexagon")
    t = sp.kernel_terms(6.0)
    s = max(int(np.abs(t.value[t.direction == k]).sum()) for k in np.unique(t.direction))
    assert exponent_bits(t) == (s - 1).bit_length()
    img = np.zeros((9, 20, 3), np.float32)
    img[7, 13, 1] = peak                      # one pixel of the last rows
    img[2, 3, 0] = np.float32(peak) / 3
    out, info = sp.render(img, 6.0, fixed=True)
    e = int(info["exponent"][0])
    if peak == 0:
        assert e == 0 and not out.any()
        return
    q = np.rint(np.float64(np.float32(peak)) * 2.0 ** e)
    assert s * abs(q) < 2 ** 31
    # at most two bits idle, but for the cap (2^126 is the largest float power of two)
    assert e == 126 or s * abs(float(np.float32(peak))) * 2.0 ** e > 2 ** 28
    assert (e == 126) == (abs(peak) < 1e-30)
    np.testing.assert_array_equal(out, splat_fixed(img, 6.0, sp.polygon, e, uniform=True))


def test_quantisation_rounds_ties_to_even():
    """Colours that scale to k + 1/2 round as numpy's rint does (ties to even, up to |k| = 2^22);
    those that scale to integers at 2^23 and above stay as they are."""
    sp = splatter("hexagon")
    img = np.zeros((6, 40, 3), np.float32)
    img[0, 0, 0] = 1.0                                   # fixes the exponent
    e = int(sp.render(img, 3.0, fixed=True)[1]["exponent"][0])
    k = np.concatenate([np.arange(-6, 6), [2 ** 22 + 1, -(2 ** 22) - 2]]).astype(np.float64)
    img[3, 5:5 + k.size, 1] = ((k + 0.5) * 2.0 ** -e).astype(np.float32)
    img[5, :7, 2] = (np.arange(1, 8) * 2.0 ** (23 - e)).astype(np.float32)   # 2^23 and above
    assert np.all(np.modf(img.astype(np.float64) * 2.0 ** e)[0][3, 5:5 + k.size, 1] != 0)
    out, info = sp.render(img, 3.0, fixed=True)
    assert info["exponent"][0] == e
    np.testing.assert_array_equal(out, splat_fixed(img, 3.0, sp.polygon, e, uniform=True))
