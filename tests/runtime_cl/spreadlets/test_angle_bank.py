"""The angle bank (``spreadlet_rotation="bank"``): PSFs pre-turned at quantised angles.

Against independent references: at the bank's own angles a render equals the per-pixel turn
(spreadlets: the bilinear kernel path, itself checked against numpy in test_rotation.py; dense
fast-tracked PSFs: a float64 numpy scatter of the turned PSFs); at other angles it equals the
render at the nearest bank angle (numpy rounding), and its error against the exact turn is no
larger than shifting the PSF by the bank's angle error.
"""
import math

import numpy as np
import pytest
from capsule import capsule_database
from cl_reference import cells, random_database
from rotation_reference import turned_spreadlet_canvas, turned_splat_image
from scipy import ndimage

from runtime_cl.errors import InputError
from runtime_cl.spreadlets.angle_bank import ANGLE_ERROR_PX, AngleBank, angles_for_reach
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import TileSplatter, canvas_shape


def scattered(db, size=48, lit=30, seed=0):
    rng = np.random.default_rng(seed)
    colour = np.zeros((size, size, 1), np.float32)
    colour[rng.integers(0, size, lit), rng.integers(0, size, lit)] = rng.uniform(0.5, 1.0, (lit, 1))
    coords = np.tile(np.array([lo for lo, _ in db.grid.ranges], np.float32), (size, size, 1))
    return colour, coords


def bank_angles(K, shape, rng):
    return (2 * np.pi * rng.integers(-K, K, shape) / K).astype(np.float32)


@pytest.mark.parametrize("reach", [0.5, 3.0, 30.0, 52.0, 400.0])
@pytest.mark.parametrize("error", [0.1, 0.5, 2.0])
def test_angle_count_bounds_the_displacement(reach, error):
    K = angles_for_reach(reach, error)
    assert K % 4 == 0 and K >= 4
    assert math.pi * reach / K <= error + 1e-12 or K == 1024


def test_bank_angles_match_the_per_pixel_turn_dense():
    db = capsule_database(radius=3.0, length=12.0, fast=True, skew=0.6)
    K = int(AngleBank(db).angles[0])
    colour, coords = scattered(db)
    angle = bank_angles(K, colour.shape[:2], np.random.default_rng(1))
    image, t = Renderer(db, spreadlet_rotation="bank").render(colour, coords, "spreadlets", angle=angle)
    assert t["rotated"]
    # float32 kernel vs float64 numpy turn of the same dense PSFs: 1e-5 of the peak
    want = turned_splat_image(db, colour, coords, angle.astype(np.float64))
    np.testing.assert_allclose(image, want, rtol=0, atol=1e-5 * np.abs(want).max())


def test_bank_angles_match_the_per_pixel_turn_canvas():
    """The Laplacian canvas of spreadlets banked at the bank's own angles equals numpy's bilinear
    sharing of each turned spreadlet (merging shares per pixel changes float32 rounding only)."""
    import pyopencl as cl

    rng = np.random.default_rng(50)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    bank = AngleBank(db)
    h, w = 19, 21
    colour = rng.random((h, w, 3)).astype(np.float32)
    coords = (rng.random((h, w, 1)) * 6).astype(np.float32)
    cell = cells(db, coords)
    K = bank.angles[cell]
    angle = (2 * np.pi * rng.integers(-K, K) / K).astype(np.float32)
    renderer = Renderer(db)
    splatter = TileSplatter(renderer.ddb, 3, dense_all=False, rotate=True, spreadlet_rotation="bank", bank=bank)
    ctx = renderer.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    out = splatter.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), h, w,
                       tile=(8, 7), angle_buf=cl.Buffer(ctx, flags, hostbuf=angle))
    assert out.pad == bank.pad <= db.rotated_pad
    want = turned_spreadlet_canvas(db, colour, coords, angle.astype(np.float64), canvas_shape(h, w, bank.pad),
                                   pad=bank.pad)
    np.testing.assert_allclose(out.canvas[0], want, rtol=0, atol=1e-5 * np.abs(want).max())
    dense = turned_splat_image(db, np.where(db.fast_track[cell][..., None], colour, 0), coords,
                               angle.astype(np.float64))
    p = out.pad
    np.testing.assert_allclose(out.canvas[1, p:p + h, p:p + w], dense, rtol=0, atol=1e-5 * np.abs(dense).max())


@pytest.mark.parametrize("fast", [False, True])
def test_other_angles_take_the_nearest_bank_angle(fast):
    db = capsule_database(radius=3.0, length=12.0, fast=fast, skew=0.6)
    colour, coords = scattered(db, seed=2)
    rng = np.random.default_rng(3)
    angle = rng.uniform(-np.pi, np.pi, colour.shape[:2]).astype(np.float32)
    renderer = Renderer(db, spreadlet_rotation="bank")
    image, _ = renderer.render(colour, coords, "spreadlets", angle=angle)
    bank = renderer._bank
    K = int(bank.angles[0])
    nearest = (2 * np.pi * np.rint(angle.astype(np.float64) * K / (2 * np.pi)) / K).astype(np.float32)
    want, _ = renderer.render(colour, coords, "spreadlets", angle=nearest)
    assert renderer._bank is bank
    np.testing.assert_array_equal(image, want)


@pytest.mark.parametrize("degrees", [7.0, 33.3, 101.0, -146.0])
def test_error_against_the_exact_turn_is_a_small_shift(degrees):
    """A lone capsule (9 px radius, 24 px long) turned by an angle between the bank's: its error
    against the exact per-pixel turn (numpy, float64) is at most that of shifting the exactly
    turned PSF by the bank's angle error (ANGLE_ERROR_PX) -- the largest move the angle rounding
    gives any PSF point."""
    db = capsule_database(radius=9.0, length=24.0, fast=True, skew=0.3)
    colour = np.zeros((71, 71, 1), np.float32)
    colour[35, 35] = 1.0
    coords = np.tile(np.array([lo for lo, _ in db.grid.ranges], np.float32), (71, 71, 1))
    angle = np.full((71, 71), np.radians(degrees), np.float32)
    image, _ = Renderer(db, spreadlet_rotation="bank").render(colour, coords, "spreadlets", angle=angle)
    exact = turned_splat_image(db, colour, coords, angle.astype(np.float64))[..., 0]
    shifted = ndimage.shift(exact, (0.0, ANGLE_ERROR_PX), order=1)
    err, bound = np.abs(image[..., 0] - exact).sum(), np.abs(shifted - exact).sum()
    assert 0.0 < err <= bound
    np.testing.assert_allclose(image.sum(), 1.0, rtol=1e-5)   # turned crops keep the energy


def test_half_turns_keep_the_unbanked_path():
    """Only 0 and pi (the coc_sign symmetry): exact without a bank, so none is built."""
    db = capsule_database(radius=3.0, length=12.0, skew=0.6)
    colour, coords = scattered(db, seed=4)
    angle = np.where(np.random.default_rng(5).random(colour.shape[:2]) < 0.5, np.pi, 0.0).astype(np.float32)
    banked, plain = Renderer(db, spreadlet_rotation="bank"), Renderer(db, spreadlet_rotation="bilinear")
    a, _ = banked.render(colour, coords, "spreadlets", angle=angle)
    b, _ = plain.render(colour, coords, "spreadlets", angle=angle)
    np.testing.assert_array_equal(a, b)
    assert banked._bank is None


@pytest.mark.parametrize("bad", [0.0, -1.0, 20.0, True, "1", float("nan")])
def test_bad_angle_error(bad):
    db = capsule_database()
    with pytest.raises(InputError, match="angle_error_px"):
        AngleBank(db, angle_error_px=bad)


def test_the_bank_grows_with_the_cells_frames_turn():
    """A renderer banks only the cells its frames turn by other than quarter turns (the rest get
    the four exact quarter turns); a frame turning new cells rebuilds it, and every frame renders
    as with a bank of every cell (same entries, so bitwise)."""
    rng = np.random.default_rng(7)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    h, w = 17, 19
    colour = rng.random((h, w, 3)).astype(np.float32)
    low = (rng.random((h, w, 1)) * 2).astype(np.float32)          # the first cells only
    high = (4 + rng.random((h, w, 1)) * 2).astype(np.float32)      # others
    angle = rng.uniform(-3, 3, (h, w)).astype(np.float32)
    angle[::2] = np.float32(np.pi)
    lazy = Renderer(db, spreadlet_rotation="bank")
    full = Renderer(db, spreadlet_rotation="bank")
    full._bank = AngleBank(db)
    for coords in (low, high, low):
        a, _ = lazy.render(colour, coords, "spreadlets", angle=angle)
        b, _ = full.render(colour, coords, "spreadlets", angle=angle)
        np.testing.assert_array_equal(a, b)
    turned = np.unique(cells(db, np.concatenate([low, high])[np.tile(angle[::1] != np.float32(np.pi), (2, 1))]))
    assert set(np.flatnonzero(lazy._bank.cells)) == set(turned)
    assert (lazy._bank.angles[~lazy._bank.cells] == 4).all()
