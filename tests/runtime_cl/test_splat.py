"""Splatting kernels against plain numpy scatters/gathers on small random databases and images.

Tolerances: the kernels sum float32 products in their own order (per band, then bands in a
fixed order); the references sum in float64. Each output is a sum of at most a few thousand
terms of magnitude <= max|term|, so the float32 error is below ~1e-6 of the sum of |terms|;
we allow 1e-5 of the largest |value| (plus a tiny absolute floor for values that cancel to 0).
"""
import numpy as np
import pytest
from cl_reference import (filter_image, laplacian_database, random_database, spreadlet_canvases,
                          splat_image)

from runtime_cl.device_db import DeviceDatabase
from runtime_cl.render import Renderer
from runtime_cl.splat import BandSplatter, canvas_shape


def scene(rng, db, h, w, cc, zero_fraction=0.2):
    colour = rng.random((h, w, cc)).astype(np.float32)
    colour[rng.random((h, w)) < zero_fraction] = 0.0  # empty pixels are skipped
    lo, hi = db.grid.ranges[0]
    coords = (lo + rng.random((h, w, 1)) * (hi - lo)).astype(np.float32)
    return colour, coords


def close(a, b, scale=None):
    scale = scale if scale is not None else max(np.abs(b).max(), 1e-30)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * scale + 1e-30)


@pytest.mark.parametrize("db_channels,cc", [(1, 1), (1, 3), (3, 1), (3, 3)])
def test_spreadlet_canvases_match_numpy(db_channels, cc):
    rng = np.random.default_rng(10 * db_channels + cc)
    db = random_database(rng, channels=db_channels, fast=0.4)
    assert db.fast_track.any() and not db.fast_track.all()
    colour, coords = scene(rng, db, 23, 31, cc)
    splatter = BandSplatter(DeviceDatabase(db), cc, dense_all=False)
    ddb = splatter.ddb
    import pyopencl as cl

    ctx = ddb.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    out = splatter.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), 23, 31,
                       bands=3)
    hc, wc = canvas_shape(23, 31, db.pad)
    lap, dense = spreadlet_canvases(db, colour, coords, (hc, wc))
    assert out.canvas.shape == (2, hc, wc, max(cc, db_channels))
    close(out.canvas[0], lap)
    close(out.canvas[1], dense)
    # the counts are what the reference splatted
    cell = db.grid.index(coords.astype(np.float64))[np.any(colour != 0, axis=-1)]
    sizes = np.diff(db.C)[cell]
    fast = db.fast_track[cell]
    assert out.spreadlets == sizes[~fast].sum()
    assert out.dense_pixels == ((2 * db.dense_radius[cell[fast]].astype(int) + 1) ** 2).sum()


@pytest.mark.parametrize("bands", [1, 2, 5, 23])
def test_band_count_does_not_change_the_result(bands):
    rng = np.random.default_rng(5)
    db = random_database(rng, r_max=9, fast=0.0)
    colour, coords = scene(rng, db, 23, 17, 1)
    renderer = Renderer(db, bands=bands)
    image, t = renderer.render(colour, coords, "splat")
    assert t["bands"] == bands
    close(image, splat_image(db, colour, coords))
    again, _ = renderer.render(colour, coords, "splat")
    assert np.array_equal(image, again)  # deterministic: bit for bit


@pytest.mark.parametrize("db_channels,cc", [(1, 3), (3, 3), (3, 1)])
def test_splat_and_filter_baselines_match_numpy(db_channels, cc):
    rng = np.random.default_rng(7 + db_channels + cc)
    db = random_database(rng, channels=db_channels)
    colour, coords = scene(rng, db, 19, 26, cc)
    renderer = Renderer(db)
    image, t = renderer.render(colour, coords, "splat")
    close(image, splat_image(db, colour, coords))
    image, t = renderer.render(colour, coords, "filter")
    close(image, filter_image(db, colour, coords))
    cell = db.grid.index(coords.astype(np.float64))
    assert t["dense_pixels"] <= ((2 * db.dense_radius[cell].astype(int) + 1) ** 2).sum()


@pytest.mark.parametrize("fast", [0.0, 0.5])
def test_integrated_laplacian_splat_equals_dense_splat(fast):
    rng = np.random.default_rng(11)
    db = laplacian_database(rng, channels=1, r_max=7, fast=fast)
    colour, coords = scene(rng, db, 40, 33, 3)
    renderer = Renderer(db)
    ours, t = renderer.render(colour, coords, "spreadlets")
    splat, _ = renderer.render(colour, coords, "splat")
    assert t["spreadlets"] > 0 and t["integrate_ms"] > 0
    # float32 Laplacian canvas, exact float64 Poisson solve: relative error ~1e-6
    close(ours, splat)
    close(splat, splat_image(db, colour, coords))


def test_empty_input_gives_zero_and_splats_nothing():
    rng = np.random.default_rng(2)
    db = random_database(rng)
    renderer = Renderer(db)
    colour = np.zeros((9, 12, 3), np.float32)
    coords = np.full((9, 12, 1), 3.0, np.float32)
    for method in ("spreadlets", "splat", "filter"):
        image, t = renderer.render(colour, coords, method)
        assert image.shape == (9, 12, 3) and not image.any()
        assert t["spreadlets"] == 0
        if method != "filter":
            assert t["dense_pixels"] == 0


def test_single_pixel_draws_its_psf():
    rng = np.random.default_rng(4)
    db = laplacian_database(rng, r_max=4)
    h, w = 15, 14
    colour = np.zeros((h, w, 1), np.float32)
    colour[6, 8] = 2.0
    coords = np.full((h, w, 1), 3.3, np.float32)
    i = int(db.grid.index(np.array([3.3])))
    r = int(db.dense_radius[i])
    expect = np.zeros((h, w, 1))
    expect[6 - r:6 + r + 1, 8 - r:8 + r + 1] = 2.0 * db.dense_psf(i)
    renderer = Renderer(db)
    for method in ("spreadlets", "splat"):
        image, _ = renderer.render(colour, coords, method)
        close(image, expect)


def test_in_focus_is_the_identity():
    rng = np.random.default_rng(8)
    db = random_database(rng, channels=3)  # cell 0: delta PSF, spreadlets = its Laplacian
    colour, _ = scene(rng, db, 13, 18, 3)
    coords = np.zeros((13, 18, 1), np.float32)
    renderer = Renderer(db)
    for method in ("spreadlets", "splat", "filter"):
        image, _ = renderer.render(colour, coords, method)
        close(image, colour)


def test_psf_larger_than_the_image():
    rng = np.random.default_rng(9)
    db = laplacian_database(rng, r_max=12)
    colour, coords = scene(rng, db, 5, 4, 3, zero_fraction=0.0)
    coords[:] = 11.9  # the largest cells, radius up to 12 on a 5x4 image
    assert db.dense_radius[db.grid.index(coords.astype(np.float64))].min() >= 1
    renderer = Renderer(db)
    ours, _ = renderer.render(colour, coords, "spreadlets")
    splat, _ = renderer.render(colour, coords, "splat")
    close(splat, splat_image(db, colour, coords))
    close(ours, splat)
    image, _ = renderer.render(colour, coords, "filter")
    close(image, filter_image(db, colour, coords))


def test_all_fast_track_database_needs_no_integration():
    rng = np.random.default_rng(12)
    db = random_database(rng, channels=3, fast=1.0)
    colour, coords = scene(rng, db, 14, 11, 3)
    renderer = Renderer(db)
    ours, t = renderer.render(colour, coords, "spreadlets")
    assert t["spreadlets"] == 0 and t["dense_pixels"] > 0
    splat, _ = renderer.render(colour, coords, "splat")
    np.testing.assert_array_equal(ours, splat)  # the same dense splats in the same order
