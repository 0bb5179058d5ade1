"""Mixed databases (basis "mixed": some cells row differences, the others Laplacian spreadlets, as
``combined`` stores its still and moving cells). A row cell is drawn from its row differences at
a half turn and from its dense PSF turned at any other angle, in the per-pixel turn and in the
angle bank; the Laplacian cells as before. References: the Splat baseline (the same dense PSFs,
turned per pixel exactly) and a float64 numpy scatter."""
import numpy as np
import pytest
from cl_reference import STATS, laplacian_database
from rotation_reference import turned_splat_image
from test_row_basis import row_differences

from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.database import DatabaseBuilder, SpreadletDatabase
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.spreadlets.angle_bank import AngleBank
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import TileSplatter

R_MAX = 8


def mixed_database(rng, samples=10, fast=(3,)):
    """Lopsided crops (no symmetry): even cells as exact row differences, odd ones as exact
    Laplacians, ``fast`` cells dense."""
    grid = NestedGrid.for_samples(samples, (2.0,), [(0.0, float(R_MAX))], ["coc"])
    rows = [i for i in range(grid.size) if i % 2 == 0]
    b = DatabaseBuilder("combined", {"test": "mixed", "basis": "mixed", "row_cells": rows,
                                     "symmetries": ["motion_direction", "coc_sign"]}, grid, 1, 2 * R_MAX + 1)
    for i in range(grid.size):
        r = int(rng.integers(2, R_MAX + 1))
        yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
        shape = (np.hypot(xx, yy) <= r) & (np.hypot(xx - r / 2, yy + r / 3) > r / 2)
        dense = (shape[..., None] * rng.uniform(0.5, 1.5, (2 * r + 1, 2 * r + 1, 1))).astype(np.float32)
        if i in rows:
            pts, vals = row_differences(dense)
        else:
            lap = laplacian5(np.pad(dense.astype(np.float64), ((1, 1), (1, 1), (0, 0))))
            ys, xs = np.nonzero(np.any(lap != 0, axis=-1))
            pts, vals = np.stack([xs - r - 1, ys - r - 1], 1), lap[ys, xs]
        b.add(pts, vals, dense, fast_track=i in fast, stats=STATS)
    return b.build()


def scene(rng, h=36, w=44, cells=None, db=None):
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < 0.3] = 0.0
    coords = rng.uniform(0.0, R_MAX, (h, w, 1)).astype(np.float32)
    if cells is not None:   # only pixels of these cells lit
        colour[~np.isin(db.grid.index(coords.astype(np.float64)), cells)] = 0.0
    return colour, coords


def test_row_cells_draw_rows_at_half_turns_and_dense_turned_otherwise():
    rng = np.random.default_rng(5)
    db = mixed_database(rng, fast=())
    assert db.basis == "mixed" and db.row_cells.sum() == len(db.params["row_cells"])
    colour, coords = scene(rng, cells=db.params["row_cells"], db=db)
    pick = rng.random(colour.shape[:2])
    angle = np.where(pick < 0.4, 0.0, np.where(pick < 0.8, np.pi, rng.uniform(-np.pi, np.pi, pick.shape)))
    angle = angle.astype(np.float32)
    out, t = Renderer(db).render(colour, coords, "spreadlets", angle=angle)
    want = turned_splat_image(db, colour, coords, angle)
    assert t["spreadlets"] > 0 and t["dense_pixels"] > 0   # half turns as rows, the rest dense
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-5 * np.abs(want).max())


@pytest.mark.parametrize("rotation", ["bilinear", "bank"])
def test_every_cell_kind_at_quarter_turns(rotation):
    """Quarter turns are exact for every kind (rows at 0 and pi, dense at pi/2 and 3pi/2;
    Laplacian and fast cells at all four), turned per pixel or taken from the bank."""
    rng = np.random.default_rng(6)
    db = mixed_database(rng)
    colour, coords = scene(rng)
    angle = (rng.integers(0, 4, colour.shape[:2]) * (np.pi / 2)).astype(np.float32)
    renderer = Renderer(db, spreadlet_rotation=rotation)
    out, _ = renderer.render(colour, coords, "spreadlets", angle=angle)
    splat, _ = renderer.render(colour, coords, "splat", angle=angle)
    want = turned_splat_image(db, colour, coords, angle)
    np.testing.assert_allclose(splat, want, rtol=0, atol=2e-5 * np.abs(want).max())
    np.testing.assert_allclose(out, want, rtol=0, atol=5e-5 * np.abs(want).max())


def test_bank_holds_rows_at_zero_and_half_turn():
    rng = np.random.default_rng(7)
    db = mixed_database(rng)
    bank = AngleBank(db)
    for i in db.params["row_cells"]:
        base, K = bank.base[i], bank.angles[i]
        kinds = bank.fast[base:base + K]
        assert kinds[0] == kinds[K // 2] == 2 and np.all(np.delete(kinds, [0, K // 2]) == 1)
        stored = bank.C[base + 1] - bank.C[base]
        assert stored == bank.C[base + K // 2 + 1] - bank.C[base + K // 2] == len(db.spreadlets(i)[0])


def test_planes_follow_what_a_frame_can_draw():
    rng = np.random.default_rng(8)
    db = mixed_database(rng)
    from runtime_cl.psf.upload import DeviceDatabase

    ddb = DeviceDatabase(db)
    assert TileSplatter(ddb, 3, dense_all=False).kinds == ("laplacian", "dense", "rows")
    still = mixed_database(rng, fast=())
    ddb = DeviceDatabase(still)
    assert TileSplatter(ddb, 3, dense_all=False).kinds == ("laplacian", "rows")
    # turned by any angle, a row cell may draw dense
    assert TileSplatter(ddb, 3, dense_all=False, rotate=True).kinds == ("laplacian", "dense", "rows")
    assert TileSplatter(ddb, 3, dense_all=False, rotate=True, half_turns=True).kinds == ("laplacian", "rows")
    assert TileSplatter(ddb, 3, dense_all=True).kinds == ("dense",)
    lap = DeviceDatabase(laplacian_database(rng))
    assert TileSplatter(lap, 3, dense_all=False).kinds == ("laplacian",)


def test_still_frame_of_a_mixed_database_matches_a_numpy_scatter():
    rng = np.random.default_rng(9)
    db = mixed_database(rng)
    colour, coords = scene(rng)
    out, t = Renderer(db).render(colour, coords, "spreadlets")
    want = turned_splat_image(db, colour, coords, np.zeros(colour.shape[:2]))
    assert t["integrate_ms"] > 0   # the Laplacian cells' plane is integrated
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-5 * np.abs(want).max())


@pytest.mark.parametrize("cells", [None, [0, 99], [2, 1], "0"])
def test_bad_row_cells_are_refused(cells):
    db = mixed_database(np.random.default_rng(10))
    params = dict(db.params)
    if cells is None:
        del params["row_cells"]
    else:
        params["row_cells"] = cells
    with pytest.raises(InputError, match="row_cells"):
        SpreadletDatabase(db.model, params, db.grid, db.channels, db.psf_resolution, db.C, db.P, db.V,
                          db.fast_track, db.dense_radius, db.dense_offsets, db.dense_values, db.stats)
