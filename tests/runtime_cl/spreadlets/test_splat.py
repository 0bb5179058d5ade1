"""Splatting kernels against plain numpy scatters/gathers on small random databases and images.

Tolerances: the kernels sum float32 products in their own order (per tile, then tiles in a
fixed order); the references sum in float64. Each output is a sum of at most a few thousand
terms of magnitude <= max|term|, so the float32 error is below ~1e-6 of the sum of |terms|;
we allow 1e-5 of the largest |value| (plus a tiny absolute floor for values that cancel to 0).
"""
import dataclasses

import numpy as np
import pytest
from cl_reference import (filter_image, laplacian_database, random_database, spreadlet_canvases,
                          splat_image)

from runtime_cl.psf.upload import DeviceDatabase, dense_row_spans, row_major_order
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import TileSplatter, canvas_shape, default_tile


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
    splatter = TileSplatter(DeviceDatabase(db), cc, dense_all=False)
    ddb = splatter.ddb
    import pyopencl as cl

    ctx = ddb.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    out = splatter.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), 23, 31,
                       tile=(8, 10))
    assert out.tiles == 4 * 3 and out.tile == (8, 10)
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


@pytest.mark.parametrize("tile,tiles", [(1, 23 * 17), ((17, 5), 5), ((4, 23), 5), (64, 1)])
def test_tile_size_does_not_change_the_result(tile, tiles):
    rng = np.random.default_rng(5)
    db = random_database(rng, r_max=9, fast=0.0)
    colour, coords = scene(rng, db, 23, 17, 1)
    renderer = Renderer(db, tile=tile)
    image, t = renderer.render(colour, coords, "splat")
    assert t["tiles"] == tiles
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


def blocky_scene(rng, db, h, w, block_w, zero_fraction=0.1):
    """Colour with some empty pixels; PSF coordinates constant over blocks of block_w x 3 pixels,
    so rows hold runs of same-cell pixels longer than the kernel's run limit."""
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < zero_fraction] = 0.0
    lo, hi = db.grid.ranges[0]
    blocks = lo + rng.random((-(-h // 3), -(-w // block_w))) * (hi - lo)
    coords = np.repeat(np.repeat(blocks, 3, axis=0), block_w, axis=1)[:h, :w, None].astype(np.float32)
    return colour, coords


@pytest.mark.parametrize("method", ["spreadlets", "splat"])
def test_runs_of_same_cell_pixels(method):
    rng = np.random.default_rng(21)
    db = random_database(rng, r_max=7, fast=0.3, spreadlets=(5, 60))
    colour, coords = blocky_scene(rng, db, 20, 90, block_w=45)
    cell = db.grid.index(coords.astype(np.float64))
    assert (cell[:, 1:] == cell[:, :-1]).mean() > 0.9  # long runs of the same cell
    runs = Renderer(db, tile=(40, 16))  # runs end at tile edges, cells, empty pixels
    short = Renderer(db, tile=(40, 16), run_max=8)  # ... and every 8 pixels
    pixels = Renderer(db, tile=(40, 16), run_max=1)
    ours, t = runs.render(colour, coords, method)
    again, _ = runs.render(colour, coords, method)
    assert np.array_equal(ours, again)  # deterministic: bit for bit
    eight, t8 = short.render(colour, coords, method)
    one, t1 = pixels.render(colour, coords, method)
    assert (t["spreadlets"], t["dense_pixels"]) == (t8["spreadlets"], t8["dense_pixels"]) \
        == (t1["spreadlets"], t1["dense_pixels"])
    if method == "splat":
        # a dense run adds PSF row by PSF row, each pixel of the run in turn: every output pixel
        # receives its terms in the same order as pixel by pixel, so the sums are identical
        assert np.array_equal(ours, one) and np.array_equal(eight, one)
        close(ours, splat_image(db, colour, coords))
    else:
        close(ours, one)
        close(eight, one)
        hc, wc = canvas_shape(20, 90, db.pad)
        lap, dense = spreadlet_canvases(db, colour, coords, (hc, wc))
        import pyopencl as cl

        ctx = runs.device.context
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        for renderer in (runs, short):
            out = renderer._wrappers[("spreadlets", 3, False, False)].run(
                cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), 20, 90, tile=(40, 16))
            close(out.canvas[0], lap)
            close(out.canvas[1], dense)
            assert out.spreadlets == t["spreadlets"]


def test_spreadlets_are_uploaded_row_by_row():
    rng = np.random.default_rng(22)
    db = random_database(rng, spreadlets=(0, 50))
    order = row_major_order(db.C, db.P)
    assert sorted(order) == list(range(db.n_spreadlets))  # a permutation
    p = db.P[order].astype(int)
    for i in range(db.n_samples):
        a, b = db.C[i], db.C[i + 1]
        assert np.all((order[a:b] >= a) & (order[a:b] < b))  # stays within its sample
        key = p[a:b, 1] * 1000 + p[a:b, 0]
        assert np.all(np.diff(key) >= 0)
    # the stored order does not matter beyond rounding: shuffle every sample's spreadlets
    shuffled = np.concatenate([a + rng.permutation(b - a) for a, b in zip(db.C[:-1], db.C[1:])]).astype(int)
    other = dataclasses.replace(db, P=db.P[shuffled], V=db.V[shuffled], checksum=None, path=None)
    assert not np.array_equal(other.P, db.P)
    colour, coords = scene(rng, db, 17, 21, 3)
    a, _ = Renderer(db).render(colour, coords, "spreadlets")
    b, _ = Renderer(other).render(colour, coords, "spreadlets")
    close(a, b)


def test_default_tile():
    assert default_tile(1024, 1024, 58, 2) == (128, 128)
    assert default_tile(1024, 1024, 200, 2) == (256, 256)  # large PSFs: less overlap
    assert default_tile(1024, 1024, 58, 32) == (64, 64)  # four tiles per compute unit
    assert default_tile(20, 90, 5, 2) == (32, 20)  # never below 32, clamped to the image


def test_dense_splats_skip_the_zero_part_of_each_row():
    rng = np.random.default_rng(23)
    db = random_database(rng, r_max=6, fast=0.5, channels=3)
    dense = db.dense_values.copy()
    for i in range(1, db.n_samples):  # zero corners, whole rows and single channels
        a, b = db.dense_offsets[i], db.dense_offsets[i + 1]
        side = 2 * int(db.dense_radius[i]) + 1
        crop = dense[a:b].reshape(side, side, 3)
        crop[:, :i % side] = 0.0
        crop[i % side, :] = 0.0
        crop[:, -1, 1:] = 0.0  # a pixel with one non-zero channel is kept
    db = dataclasses.replace(db, dense_values=dense, checksum=None, path=None)
    span_off, span, pixels = dense_row_spans(db)
    for i in range(db.n_samples):
        for oy, row in enumerate(np.any(db.dense_psf(i) != 0, axis=-1)):
            cols = np.flatnonzero(row)
            want = (cols[0], cols[-1] + 1) if len(cols) else (0, 0)
            assert tuple(span[span_off[i] + oy]) == want
        assert pixels[i] == np.sum(span[span_off[i]:span_off[i + 1], 1] - span[span_off[i]:span_off[i + 1], 0])
    assert pixels.sum() < ((2 * db.dense_radius.astype(int) + 1) ** 2).sum()
    colour, coords = scene(rng, db, 19, 23, 3)
    cell = db.grid.index(coords.astype(np.float64))[np.any(colour != 0, axis=-1)]
    renderer = Renderer(db)
    image, t = renderer.render(colour, coords, "splat")
    close(image, splat_image(db, colour, coords))  # the reference splats the whole crops
    assert t["dense_pixels"] == pixels[cell].sum()
    import pyopencl as cl

    ctx = renderer.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    out = TileSplatter(renderer.ddb, 3, dense_all=False).run(
        cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), 19, 23)
    _, dense_ref = spreadlet_canvases(db, colour, coords, canvas_shape(19, 23, db.pad))
    close(out.canvas[1], dense_ref)  # fast-tracked cells: trimmed dense splats
    assert out.dense_pixels == pixels[cell[db.fast_track[cell]]].sum()


def test_bad_tile_or_run_length_is_an_input_error():
    from runtime_cl.errors import InputError

    rng = np.random.default_rng(24)
    db = random_database(rng)
    colour, coords = scene(rng, db, 6, 7, 3)
    with pytest.raises(InputError, match=r"tile = \(0, 4\): need a size >= 1"):
        Renderer(db, tile=(0, 4)).render(colour, coords, "splat")
    with pytest.raises(InputError, match=r"run_max = 0: must be an integer in \[1, 256\]"):
        Renderer(db, run_max=0).render(colour, coords, "spreadlets")


@pytest.mark.parametrize("method", ["spreadlets", "splat"])
def test_unlit_tiles_leave_nothing_from_the_last_frame(method):
    """A tile without a lit pixel neither zeroes nor fills its buffer and the merge skips it, so a
    frame lit only in a band (a depth layer) after a fully lit one draws that band alone."""
    rng = np.random.default_rng(21)
    db = random_database(rng, channels=3, fast=0.3)
    renderer = Renderer(db, tile=8)
    full, coords = scene(rng, db, 40, 48, 3, zero_fraction=0.0)
    band = full.copy()
    band[:, :20] = 0.0
    band[30:] = 0.0
    renderer.render(full, coords, method)
    out, _ = renderer.render(band, coords, method)
    fresh, _ = Renderer(db, tile=8).render(band, coords, method)
    np.testing.assert_array_equal(out, fresh)
    assert np.any(out[:, 20:] != 0)
