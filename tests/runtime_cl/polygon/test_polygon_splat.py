"""PolygonSplatter against brute-force splatting of the rasterised polygons (numpy).

Exactness is tested bit for bit: the runtime's fixed-point integers against a plain integer
scatter of the same quantised colours over each pixel's rasterised polygon. Colours are then a
single rounding away; the 4096-pixel-line test bounds that against a float64 reference.
"""
import numpy as np
import pytest
from polygon_reference import shape, splat_fixed, splat_float64

from runtime_cl.errors import InputError
from runtime_cl.polygon.kernel import scale_polygon
from runtime_cl.polygon.splat import ROW, PolygonSplatter

_SPLATTERS = {}


def splatter(name):
    if name not in _SPLATTERS:
        _SPLATTERS[name] = PolygonSplatter(*shape(name))
    return _SPLATTERS[name]


def scene(rng, h, w, c=3, zero=0.3):
    img = rng.random((h, w, c)).astype(np.float32)
    img[rng.random((h, w)) < zero] = 0.0
    return img


CASES = [("octagon", 13, 17, 6.0), ("hexagon", 9, 23, 30.0), ("star", 20, 11, 3.0),
         ("t1hex", 7, 150, 40.0), ("heart12", 40, 70, 9.0)]


@pytest.mark.parametrize("name,h,w,rmax", CASES)
def test_radius_map_is_brute_force_exact(name, h, w, rmax):
    """Random radii up to rmax (kernels larger than the image included; several chunks)."""
    rng = np.random.default_rng(h * w)
    sp = splatter(name)
    img = scene(rng, h, w)
    rad = (rng.random((h, w)) * rmax).astype(np.float32)
    rad[rng.random((h, w)) < 0.1] = 0.0
    out, info = sp.render(img, rad, fixed=True)
    assert out.dtype == np.int64
    ref = splat_fixed(img, rad, sp.polygon, info["exponent"][0])
    np.testing.assert_array_equal(out, ref)
    if name != "star":   # the polygons are scale_polygon's (the star's ties: test_polygon_scale)
        for r in np.unique(rad)[::7]:
            assert np.array_equal(sp.polygon(r), scale_polygon(*shape(name), float(r))[0])


@pytest.mark.parametrize("name,h,w,rmax", CASES)
def test_uniform_radius_is_brute_force_exact(name, h, w, rmax):
    rng = np.random.default_rng(h + w)
    sp = splatter(name)
    img = scene(rng, h, w)
    r = float(np.float32(0.3 + rng.random() * rmax))
    out, info = sp.render(img, r, fixed=True)
    ref = splat_fixed(img, r, sp.polygon, info["exponent"][0], uniform=True)
    np.testing.assert_array_equal(out, ref)
    colours, _ = sp.render(img, r)
    expect = ref * (np.ldexp(1.0, -info["exponent"][0]) / info["area"])
    np.testing.assert_array_equal(colours, expect.astype(np.float32))


def test_uniform_and_map_agree():
    rng = np.random.default_rng(11)
    sp = splatter("octagon")
    img = scene(rng, 30, 90)
    a, _ = sp.render(img, 12.5)
    b, _ = sp.render(img, np.full((30, 90), 12.5, np.float32))
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)


def test_long_lines_stay_within_1e6():
    """4096-pixel rows with radii up to 60: prefix sums 4096 long, no float drift.

    A float32 cumulative sum of the same splatted terms drifts far past the bound (checked)."""
    rng = np.random.default_rng(2)
    sp = splatter("hexagon")
    h, w = 5, 4096
    img = (0.2 + rng.random((h, w, 3))).astype(np.float32)
    rad = (rng.random((h, w)) * 60).astype(np.float32)
    ref = splat_float64(img, rad, sp)
    out, _ = sp.render(img, rad)
    assert np.abs(out / ref - 1).max() < 1e-6
    uni, _ = sp.render(img, 60.0)
    ref = splat_float64(img, np.float32(60.0), sp)
    assert np.abs(uni / ref - 1).max() < 1e-6
    row = np.diff(ref[2, :, 0], prepend=0).astype(np.float32)   # a float32 prefix drifts
    assert np.abs(np.cumsum(row, dtype=np.float32) / ref[2, :, 0] - 1).max() > 1e-6


def test_radius_zero_is_the_identity():
    rng = np.random.default_rng(4)
    sp = splatter("hexagon")
    img = scene(rng, 16, 80)
    out, _ = sp.render(img, 0.0)
    np.testing.assert_array_equal(out, img)
    out, info = sp.render(img, np.zeros((16, 80), np.float32))
    np.testing.assert_array_equal(out, img)   # exact for colours >= 2^(23 - e)
    assert info["exponent"][0] > 40


def test_kernel_larger_than_image_conserves_energy():
    """A pixel's whole kernel lands outside except its own row: still exactly its share."""
    sp = splatter("octagon")
    img = np.zeros((3, 5, 1), np.float32)
    img[1, 2] = 1.0
    out, info = sp.render(img, np.full((3, 5), 50.0, np.float32), fixed=True)
    area = sp.kernel_terms(50.0).area
    q = np.rint(np.ldexp(1.0, info["exponent"][0]) / area)
    np.testing.assert_array_equal(out, np.full((3, 5, 1), q, np.int64))


def test_layers_add_up_and_runs_are_deterministic():
    """Two canvases' worth of pixels splatted into one canvas equal one splat of all of them."""
    rng = np.random.default_rng(8)
    sp = splatter("octagon")
    img = scene(rng, 24, 100)
    rad = (rng.random((24, 100)) * 20).astype(np.float32)
    mask = rng.random((24, 100)) < 0.5
    whole, info = sp.render(img, rad, fixed=True)
    canvas = sp.canvas(24, 100, 3, float(np.abs(img).sum(dtype=np.float64)))
    sp.splat(canvas, np.where(mask[..., None], img, 0), rad)
    sp.splat(canvas, np.where(mask[..., None], 0, img), rad)
    parts, _ = sp.resolve(canvas, fixed=True)
    np.testing.assert_array_equal(parts, whole)
    again, _ = sp.render(img, rad, fixed=True)
    np.testing.assert_array_equal(again, whole)
    small = sp.canvas(24, 100, 3, 1.0)
    with pytest.raises(InputError, match="bound"):
        sp.splat(small, img, rad)


def test_bad_input_names_the_argument():
    sp = splatter("octagon")
    img = np.ones((4, 6, 3), np.float32)
    rad = np.ones((4, 6), np.float32)
    for bad, match in ((np.nan, "radius.*non-finite"), (-1.0, "radius.*negative"),
                       (np.ones((3, 6)), "radius: shape"), (1e6, r"radius.*\[0, 2048\]")):
        with pytest.raises(InputError, match=match):
            sp.render(img, bad if np.ndim(bad) else np.full((4, 6), bad, np.float32))
    nan_map = rad.copy()
    nan_map[2, 3] = np.nan
    with pytest.raises(InputError, match="1 non-finite"):
        sp.render(img, nan_map)
    bad_img = img.copy()
    bad_img[0, 0, 1] = np.inf
    with pytest.raises(InputError, match="image"):
        sp.render(bad_img, rad)
    with pytest.raises(InputError, match="image: shape"):
        sp.render(np.ones((4, 6, 7), np.float32), 1.0)


def test_radius_map_tiles_in_parallel_are_brute_force_exact():
    """A wide image: launches of several tiles each (plain adds in the tiles, atomics where
    folded terms land), still the brute-force integers, run after run."""
    rng = np.random.default_rng(12)
    sp = splatter("heart12")
    h, w = 14, 600
    img = scene(rng, h, w)
    rad = (rng.random((h, w)) * 30).astype(np.float32)
    span = sp.table.ensure(30.0).span(float(rad.max()))
    assert -(-w // ROW) > 2 * (2 + span // ROW)              # > 2 tiles per launch
    out, info = sp.render(img, rad, fixed=True)
    np.testing.assert_array_equal(out, splat_fixed(img, rad, sp.polygon, info["exponent"][0]))
    np.testing.assert_array_equal(sp.render(img, rad, fixed=True)[0], out)
