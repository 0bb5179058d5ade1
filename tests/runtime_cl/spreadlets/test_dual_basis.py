"""Dual databases (basis "dual", as ``combined`` stores its PSFs): every cell as Laplacian
spreadlets and again as row differences. A pixel turned by 0 or pi is drawn from the row
differences, any other turn from the Laplacian, per pixel or from the angle bank. References: the
same cells as a Laplacian-only database (whose half turns are exact), the Splat baseline and a
float64 numpy scatter of the turned dense PSFs."""
import numpy as np
import pytest
from cl_reference import STATS
from rotation_reference import turned_splat_image
from test_row_basis import row_differences

from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.database import DatabaseBuilder, SpreadletDatabase
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.psf.upload import DeviceDatabase, half_turn_rows
from runtime_cl.spreadlets.angle_bank import AngleBank, bank_needs
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import TileSplatter

R_MAX = 8
SYMMETRIES = ["motion_direction", "coc_sign"]


def lopsided(rng, i):
    """A flat crescent-like crop (no symmetry, one level per cell), or for every third cell a
    square with a horizontal ramp (as a moving capsule's rows are): its dense PSF."""
    ramp = i % 3 == 2
    r = R_MAX if ramp else int(rng.integers(2, R_MAX + 1))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    shape = (np.hypot(xx, yy) <= r) & (np.hypot(xx - r / 2, yy + r / 3) > r / 2)
    if ramp:
        shape = np.ones_like(shape)
    level = (1.0 + (xx + r) / (2 * r)) if ramp else 1.0 + 0.1 * i
    return (shape * level)[..., None].astype(np.float32)


def laplacian_terms(dense):
    r = dense.shape[0] // 2
    lap = laplacian5(np.pad(dense.astype(np.float64), ((1, 1), (1, 1), (0, 0))))
    ys, xs = np.nonzero(np.any(lap != 0, axis=-1))
    return np.stack([xs - r - 1, ys - r - 1], 1), lap[ys, xs]


def databases(rng, samples=10, fast=(3,), row_fast=(4,)):
    """(dual, laplacian-only) databases of the same exact PSFs."""
    grid = NestedGrid.for_samples(samples, (2.0,), [(0.0, float(R_MAX))], ["coc"])
    dual = DatabaseBuilder("combined", {"basis": "dual", "symmetries": SYMMETRIES}, grid, 1, 2 * R_MAX + 1)
    lap = DatabaseBuilder("combined", {"basis": "laplacian", "symmetries": SYMMETRIES}, grid, 1, 2 * R_MAX + 1)
    for i in range(grid.size):
        dense = lopsided(rng, i)
        pts, vals = laplacian_terms(dense)
        dual.add(pts, vals, dense, fast_track=i in fast, stats=STATS, rows=(*row_differences(dense), i in row_fast))
        lap.add(pts, vals, dense, fast_track=i in fast, stats=STATS)
    return dual.build(), lap.build()


def scene(rng, h=36, w=44):
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < 0.3] = 0.0
    coords = rng.uniform(0.0, R_MAX, (h, w, 1)).astype(np.float32)
    return colour, coords


def some_half_turns(rng, shape, share=0.7):
    pick = rng.random(shape)
    angle = np.where(pick < share / 2, 0.0, np.where(pick < share, np.pi, rng.uniform(-np.pi, np.pi, shape)))
    return angle.astype(np.float32)


def test_dual_draws_what_the_laplacian_draws_with_fewer_terms():
    """Any angles: half turns from the row differences (exact), other turns from the Laplacian,
    as the Laplacian-only database draws them (its half turns are exact too). Turned per pixel
    (the kernel's own dual path; the bank's is checked below)."""
    rng = np.random.default_rng(5)
    dual, lap = databases(rng)
    colour, coords = scene(rng)
    angle = some_half_turns(rng, colour.shape[:2])
    out, t = Renderer(dual, spreadlet_rotation="bilinear").render(colour, coords, "spreadlets", angle=angle)
    want, tl = Renderer(lap, spreadlet_rotation="bilinear").render(colour, coords, "spreadlets", angle=angle)
    np.testing.assert_allclose(out, want, rtol=0, atol=5e-5 * np.abs(want).max())
    # each lit pixel drew its row differences at a half turn, its Laplacian otherwise
    half = (angle == 0) | (angle == np.float32(np.pi))
    lit, cell = np.any(colour != 0, axis=2), dual.grid.index(coords.astype(np.float64))
    laps = np.where(dual.fast_track, 0, np.diff(dual.C))
    rows = np.where(half_turn_rows(dual), np.where(dual.row_fast, 0, np.diff(dual.row_C)), laps)
    assert t["spreadlets"] == np.where(half, rows[cell], laps[cell])[lit].sum() < 0.9 * tl["spreadlets"]
    colour[~half] = 0.0   # half turns alone: exactly the turned dense PSFs
    out, _ = Renderer(dual, spreadlet_rotation="bilinear").render(colour, coords, "spreadlets", angle=angle)
    exact = turned_splat_image(dual, colour, coords, angle)
    np.testing.assert_allclose(out, exact, rtol=0, atol=2e-5 * np.abs(exact).max())


@pytest.mark.parametrize("rotation", ["bilinear", "bank"])
def test_every_kind_at_quarter_turns(rotation):
    """Quarter turns are exact for every kind (rows or row-fast at 0 and pi, Laplacian or fast at
    pi/2 and 3pi/2), turned per pixel or taken from the bank."""
    rng = np.random.default_rng(6)
    dual, _ = databases(rng)
    colour, coords = scene(rng)
    angle = (rng.integers(0, 4, colour.shape[:2]) * (np.pi / 2)).astype(np.float32)
    renderer = Renderer(dual, spreadlet_rotation=rotation)
    out, _ = renderer.render(colour, coords, "spreadlets", angle=angle)
    splat, _ = renderer.render(colour, coords, "splat", angle=angle)
    want = turned_splat_image(dual, colour, coords, angle)
    np.testing.assert_allclose(splat, want, rtol=0, atol=2e-5 * np.abs(want).max())
    np.testing.assert_allclose(out, want, rtol=0, atol=5e-5 * np.abs(want).max())


def test_bank_matches_the_per_pixel_turn():
    rng = np.random.default_rng(11)
    dual, _ = databases(rng)
    colour, coords = scene(rng)
    angle = some_half_turns(rng, colour.shape[:2])
    banked, _ = Renderer(dual, spreadlet_rotation="bank").render(colour, coords, "spreadlets", angle=angle)
    turned, _ = Renderer(dual).render(colour, coords, "spreadlets", angle=angle)
    # the bank rounds each angle to its nearest entry (0.25 px at a PSF's rim): close, not equal
    err = np.abs(banked - turned).sum() / np.abs(turned).sum()
    assert err < 0.01


def test_half_turns_take_the_cheaper_of_rows_and_laplacian():
    """Flat crescents draw their row differences at 0 and pi; ramps (a moving capsule's rows), a
    difference per pixel, keep their Laplacian; a row fast track costs the dense PSF."""
    dual, _ = databases(np.random.default_rng(13), samples=12, fast=(), row_fast=(0,))
    rows = half_turn_rows(dual)
    ramps = np.arange(dual.n_samples) % 3 == 2
    assert not rows[ramps].any() and rows[~ramps & (np.arange(dual.n_samples) > 0)].all()
    assert np.all(np.diff(dual.row_C)[ramps] > np.diff(dual.C)[ramps])


def test_bank_holds_rows_at_zero_and_half_turn():
    rng = np.random.default_rng(7)
    dual, _ = databases(rng)
    bank, rows = AngleBank(dual), half_turn_rows(dual)
    assert rows.any() and not rows.all()
    for i in range(dual.n_samples):
        base, K = bank.base[i], bank.angles[i]
        kinds = bank.fast[base:base + K]
        others = np.delete(kinds, [0, K // 2])
        laplacian = 1 if dual.fast_track[i] else 0
        assert kinds[0] == kinds[K // 2] == ((1 if dual.row_fast[i] else 2) if rows[i] else laplacian)
        assert np.all(others == laplacian)
        if rows[i] and not dual.row_fast[i]:
            stored = bank.C[base + 1] - bank.C[base]
            assert stored == bank.C[base + K // 2 + 1] - bank.C[base + K // 2] == len(dual.row_spreadlets(i)[0])


def test_planes_follow_what_a_frame_can_draw():
    rng = np.random.default_rng(8)
    dual, lap = databases(rng)
    ddb = DeviceDatabase(dual)
    assert TileSplatter(ddb, 3, dense_all=False).kinds == ("laplacian", "dense", "rows")
    assert TileSplatter(ddb, 3, dense_all=True).kinds == ("dense",)
    no_fast, _ = databases(rng, fast=(), row_fast=())
    assert TileSplatter(DeviceDatabase(no_fast), 3, dense_all=False).kinds == ("laplacian", "rows")
    assert TileSplatter(DeviceDatabase(lap), 3, dense_all=False).kinds == ("laplacian", "dense")


def test_still_frame_draws_rows_only():
    rng = np.random.default_rng(9)
    dual, _ = databases(rng)
    colour, coords = scene(rng)
    out, _ = Renderer(dual).render(colour, coords, "spreadlets")
    want = turned_splat_image(dual, colour, coords, np.zeros(colour.shape[:2]))
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-5 * np.abs(want).max())


def test_round_trip_and_checksum_cover_the_rows(tmp_path):
    dual, _ = databases(np.random.default_rng(12))
    path = tmp_path / "dual.spdb"
    dual.save(path)
    back = SpreadletDatabase.load(path)
    assert back.basis == "dual" and back.info()["row_spreadlets"] == int(dual.row_C[-1])
    for name in ("row_C", "row_P", "row_V", "row_fast"):
        np.testing.assert_array_equal(getattr(back, name), getattr(dual, name))
    back.row_V[0] += 1.0
    assert back.compute_checksum() != dual.checksum


def test_row_arrays_only_with_basis_dual():
    dual, lap = databases(np.random.default_rng(10))
    fields = dict(model=dual.model, grid=dual.grid, channels=1, psf_resolution=dual.psf_resolution, C=dual.C,
                  P=dual.P, V=dual.V, fast_track=dual.fast_track, dense_radius=dual.dense_radius,
                  dense_offsets=dual.dense_offsets, dense_values=dual.dense_values, stats=dual.stats)
    with pytest.raises(InputError, match="row_C"):
        SpreadletDatabase(params=dual.params, **fields)   # dual without its rows
    with pytest.raises(InputError, match="row_C"):
        SpreadletDatabase(params=lap.params, row_C=dual.row_C, row_P=dual.row_P, row_V=dual.row_V,
                          row_fast=dual.row_fast, **fields)
    with pytest.raises(InputError, match="rows"):
        DatabaseBuilder("combined", {"basis": "dual"}, dual.grid, 1, 17).add([[0, 0]], [1.0], np.ones((1, 1)))


@pytest.mark.parametrize("rotation", ["bilinear", "bank"])
def test_laplacian_box_holds_every_laplacian_pixel(rotation):
    """The tiles report the box of the pixels that drew Laplacian spreadlets; grown by the padding
    it holds every non-zero pixel of the Laplacian plane (the crop integration relies on it)."""
    rng = np.random.default_rng(14)
    dual, _ = databases(rng, fast=(), row_fast=())
    colour, coords = scene(rng, h=70, w=90)
    angle = some_half_turns(rng, colour.shape[:2], share=0.95)
    colour[:30] = 0.0   # the Laplacian pixels (turned by other than 0, pi) in the lower part only
    renderer = Renderer(dual, spreadlet_rotation=rotation, tile=16)
    if rotation == "bank":   # with its Laplacian entries (a frame this small is cheaper without)
        renderer._bank = AngleBank(dual, cells=bank_needs(dual, colour, coords, angle)[0])
    wrapper = renderer._wrapper("spreadlets", 3, True)
    import pyopencl as cl
    ctx = renderer.device.context
    bufs = [cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
            for a in (colour, coords, angle)]
    result = wrapper.run(bufs[0], bufs[1], 70, 90, 16, bufs[2])
    lap = result.canvas[result.kinds.index("laplacian")]
    ys, xs = np.nonzero(np.any(lap != 0, axis=2))
    y0, y1, x0, x1 = result.laplacian_box
    assert len(ys) and y0 <= ys.min() and ys.max() < y1 and x0 <= xs.min() and xs.max() < x1
    assert y0 >= 30 and (y1 - y0) * (x1 - x0) < lap.shape[0] * lap.shape[1]   # tighter than the canvas
