"""An angle bank without Laplacian entries (``AngleBank(laplacian=False)``): every cell draws its
dense PSF turned (or, at 0 and pi, a dual database's row differences), so the frame has no
Laplacian plane to merge and integrate. ``bank_needs`` chooses it per frame when the extra adds
cost less than that plane. References: a float64 numpy scatter of the turned dense PSFs, and the
bank with Laplacian entries (exact PSFs, so the two agree wherever both are exact)."""
import numpy as np
import pytest
from rotation_reference import turned_splat_image
from test_dual_basis import databases, scene, some_half_turns

from runtime_cl.psf.upload import dense_row_spans
from runtime_cl.spreadlets.angle_bank import LAPLACIAN_PLANE_ADDS, AngleBank, bank_needs
from runtime_cl.spreadlets.renderer import Renderer

from cl_reference import cells


def banked(db, colour, coords, angle, laplacian):
    r = Renderer(db, spreadlet_rotation="bank")
    r._bank = AngleBank(db, cells=bank_needs(db, colour, coords, angle)[0], laplacian=laplacian)
    return r, r._bank


def bank_angles(bank, db, coords, rng, shape):
    """Angles the bank holds exactly: each pixel a random one of its cell's K angles, with
    quarter and half turns among them."""
    K = bank.angles[cells(db, coords)]
    return (2 * np.pi * rng.integers(0, K, shape) / K).astype(np.float32)


@pytest.mark.parametrize("which", ["dual", "laplacian"])
def test_no_laplacian_entries_draw_the_turned_dense_psfs(which):
    rng = np.random.default_rng(21)
    dual, lap = databases(rng)
    db = dual if which == "dual" else lap
    colour, coords = scene(rng)
    probe = some_half_turns(rng, colour.shape[:2], share=0.3)
    r, bank = banked(db, colour, coords, probe, laplacian=False)
    assert not np.any(bank.fast == 0)          # KIND_LAPLACIAN: none
    angle = bank_angles(bank, db, coords, rng, colour.shape[:2])
    image, _ = r.render(colour, coords, "spreadlets", angle=angle, bank_checked=True)
    want = turned_splat_image(db, colour, coords, angle.astype(np.float64))
    np.testing.assert_allclose(image, want, rtol=0, atol=2e-5 * np.abs(want).max())
    wrapper = r._wrapper("spreadlets", 3, True)
    assert "laplacian" not in wrapper.kinds and "dense" in wrapper.kinds
    assert ("rows" in wrapper.kinds) == (which == "dual")


def test_quarter_and_half_turns_agree_with_the_laplacian_bank():
    """Quarter turns are exact for every kind, so both banks draw the same image there."""
    rng = np.random.default_rng(22)
    dual, _ = databases(rng)
    colour, coords = scene(rng)
    angle = (0.5 * np.pi * rng.integers(0, 4, colour.shape[:2])).astype(np.float32)
    a, _ = banked(dual, colour, coords, angle, False)[0].render(colour, coords, "spreadlets", angle=angle,
                                                                   bank_checked=True)
    b, _ = banked(dual, colour, coords, angle, True)[0].render(colour, coords, "spreadlets", angle=angle,
                                                                  bank_checked=True)
    np.testing.assert_allclose(a, b, rtol=0, atol=5e-5 * np.abs(b).max())


def lone_disc_frames(db):
    """(coords, angle, full, few): 120^2 pixels of the cell whose dense PSF costs the most
    adds more than its Laplacian, turned by 0.3 rad; ``full`` lights them all, ``few`` two."""
    dense_n = dense_row_spans(db)[2]
    values = np.linspace(*db.grid.ranges[0], 200, dtype=np.float32)
    extra = dense_n - np.diff(db.C)
    best = values[np.argmax(extra[cells(db, values[:, None])])]
    big = 120
    coords = np.full((big, big, 1), best, np.float32)
    angle = np.full((big, big), 0.3, np.float32)
    full = np.ones((big, big, 1), np.float32)
    few = np.zeros_like(full)
    few[10, 10] = few[100, 100] = 1.0
    return coords, angle, full, few, int(cells(db, coords[:1, 0])[0]), int(extra.max())


def test_bank_needs_drops_the_laplacian_when_it_costs_more():
    """Few Laplacian pixels in a big box: dropped (extra adds < LAPLACIAN_PLANE_ADDS x box);
    a frame full of them keeps it. The rule against a count done here from the database."""
    _, lap = databases(np.random.default_rng(23), fast=(), row_fast=())
    coords, angle, full, few, c, extra_per_px = lone_disc_frames(lap)
    box = lambda n: (n + 2 * lap.pad) ** 2
    assert extra_per_px * 120 ** 2 >= LAPLACIAN_PLANE_ADDS * box(120)
    assert 2 * extra_per_px < LAPLACIAN_PLANE_ADDS * box(91)
    need, keep = bank_needs(lap, full, coords, angle)
    assert keep and need[c] and need.sum() == 1
    need, keep = bank_needs(lap, few, coords, angle)
    assert not keep and need[c] and need.sum() == 1
    need, keep = bank_needs(lap, np.zeros_like(full), coords, angle)
    assert not need.any() and not keep


def test_the_renderer_rebuilds_the_bank_when_the_choice_changes():
    """Each frame renders as from a bank built for it alone (the same entries: bitwise); the bank
    of the other choice is kept, so alternating frames build each bank once."""
    _, lap = databases(np.random.default_rng(24), fast=(), row_fast=())
    coords, angle, full, few, _, _ = lone_disc_frames(lap)
    r = Renderer(lap, spreadlet_rotation="bank")
    banks = []
    for colour, keep in ((few, False), (full, True), (full, True), (few, False)):
        before = r._bank
        image, _ = r.render(colour, coords, "spreadlets", angle=angle)
        assert r._bank.laplacian == keep
        assert (r._bank is before) == (before is not None and before.laplacian == keep)
        banks.append(r._bank)
        want, _ = banked(lap, colour, coords, angle, keep)[0].render(colour, coords, "spreadlets", angle=angle,
                                                                       bank_checked=True)
        np.testing.assert_array_equal(image, want)
    assert banks[0] is banks[3] and banks[1] is banks[2] and banks[0] is not banks[1]


def test_frames_grown_together_render_from_their_own_choice():
    """A caller that grows several frames before rendering them (the stochastic passes' slots)
    renders each from the bank of the choice its growth returned: as a renderer that saw that
    frame alone (bitwise), although a later frame chose otherwise."""
    _, lap = databases(np.random.default_rng(25), fast=(), row_fast=())
    coords, angle, full, few, _, _ = lone_disc_frames(lap)
    r = Renderer(lap, spreadlet_rotation="bank")
    choices = [r.grow_bank(colour, coords, angle) for colour in (few, full)]
    assert choices == [False, True]
    for colour, choice in zip((few, full), choices):
        image, _ = r.render(colour, coords, "spreadlets", angle=angle, bank_checked=True, bank_laplacian=choice)
        alone, _ = Renderer(lap, spreadlet_rotation="bank").render(colour, coords, "spreadlets", angle=angle)
        np.testing.assert_array_equal(image, alone)
    assert Renderer(lap, spreadlet_rotation="bilinear").grow_bank(few, coords, angle) is None
