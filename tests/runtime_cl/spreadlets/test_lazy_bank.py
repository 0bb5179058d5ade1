"""The angle bank builds only the entries (cell, angle) its frames draw (``AngleBank(entries=)``,
``Renderer.grow_bank``). Reference: a bank of every angle of the same cells, whose entries are
the same arrays, so every frame must render bitwise the same from both; and the drawn entries
counted here in float64 from each pixel's cell and angle."""
import numpy as np
import pytest
from cl_reference import cells, random_database

from runtime_cl.errors import InputError
from runtime_cl.spreadlets.angle_bank import AngleBank, entry_of
from runtime_cl.spreadlets.renderer import Renderer


def frame(rng, h=23, w=29, lo=0.0, hi=6.0):
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < 0.25] = 0.0
    coords = rng.uniform(lo, hi, (h, w, 1)).astype(np.float32)
    return colour, coords


def full_bank_render(db, bank, colour, coords, angle):
    """The frame from a bank of every angle of ``bank``'s cells."""
    r = Renderer(db)
    r._bank = AngleBank(db, cells=bank.cells, laplacian=bank.laplacian)
    return r.render(colour, coords, "spreadlets", angle=angle, bank_checked=True)[0]


def drawn_entries(db, bank, colour, coords, angle) -> set:
    """(cell, k) of each lit pixel: the nearest of its cell's K angles, in float64."""
    lit = np.any(colour != 0, axis=2)
    c = cells(db, coords)[lit]
    K = bank.angles[c]
    k = np.mod(np.rint(np.mod(angle[lit].astype(np.float64), 2 * np.pi) * K / (2 * np.pi)), K).astype(int)
    return set(zip(c.tolist(), k.tolist()))


@pytest.mark.parametrize("laplacian_cells", [0.3, 1.0])
def test_a_frame_renders_as_from_the_whole_bank_and_builds_what_it_draws(laplacian_cells):
    rng = np.random.default_rng(31)
    db = random_database(rng, r_max=6, fast=1.0 - laplacian_cells, spreadlets=(5, 40))
    colour, coords = frame(rng)
    angle = rng.uniform(-7.0, 7.0, colour.shape[:2]).astype(np.float32)
    r = Renderer(db)
    image, _ = r.render(colour, coords, "spreadlets", angle=angle)
    bank = r._bank
    assert bank.built.sum() < bank.n_entries
    np.testing.assert_array_equal(image, full_bank_render(db, bank, colour, coords, angle))
    built = {(int(i), int(k)) for i in range(db.n_samples) for k in
             np.flatnonzero(bank.built[bank.base[i]:bank.base[i] + bank.angles[i]])}
    want = drawn_entries(db, bank, colour, coords, angle)
    # each drawn entry built; the extra ones are neighbours of angles within 1e-3 step of a half way
    assert want <= built and len(built - want) <= 0.01 * len(want) + 2


def test_angles_half_way_between_bank_angles():
    """Angles on the half-way points of the bank's steps, where the device's float32 rounding
    may go either way: the bank builds both neighbours and renders as the whole bank."""
    rng = np.random.default_rng(32)
    db = random_database(rng, r_max=6, fast=0.4, spreadlets=(5, 40))
    colour, coords = frame(rng)
    r = Renderer(db)
    r.render(colour, coords, "spreadlets", angle=np.full(colour.shape[:2], 0.3, np.float32))   # the bank's cells
    K = r._bank.angles[cells(db, coords)]
    half = (2 * np.pi * (rng.integers(-K, K) + 0.5) / K).astype(np.float32)
    image, _ = r.render(colour, coords, "spreadlets", angle=half)
    np.testing.assert_array_equal(image, full_bank_render(db, r._bank, colour, coords, half))
    lit = np.any(colour != 0, axis=2)
    cc, kk = entry_of(r._bank.angles, cells(db, coords)[lit], half[lit])
    assert len(cc) == 2 * lit.sum()   # every lit pixel within the margin: both neighbours


def test_later_frames_grow_the_bank_and_render_as_on_their_own():
    """Frames at new angles of the same cells add entries; each renders bitwise as a renderer
    that saw it alone (the canvas pad does not depend on which entries were built)."""
    rng = np.random.default_rng(33)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    colour, coords = frame(rng)
    r = Renderer(db)
    sizes = []
    for seed in range(3):
        angle = np.random.default_rng(seed).uniform(-3, 3, colour.shape[:2]).astype(np.float32)
        image, _ = r.render(colour, coords, "spreadlets", angle=angle)
        alone, _ = Renderer(db).render(colour, coords, "spreadlets", angle=angle)
        np.testing.assert_array_equal(image, alone)
        sizes.append(int(r._bank.built.sum()))
    assert sizes[0] < sizes[1] < sizes[2]
    before = r._bank
    r.render(colour, coords, "spreadlets", angle=angle)   # nothing new: the same bank
    assert r._bank is before


def test_entry_flags_of_the_wrong_length():
    db = random_database(np.random.default_rng(34), r_max=4)
    with pytest.raises(InputError, match="entries: shape"):
        AngleBank(db, entries=np.ones(3, bool))


def test_an_empty_frame_builds_nothing():
    """A black frame (an empty depth layer) with turned pixels renders black and builds no entry."""
    rng = np.random.default_rng(35)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    _, coords = frame(rng)
    r = Renderer(db)
    image, _ = r.render(np.zeros(coords.shape[:2] + (3,), np.float32), coords, "spreadlets",
                        angle=np.full(coords.shape[:2], 0.3, np.float32))
    assert not image.any() and not r._bank.built.any()


def test_depth_layers_draw_from_one_bank_grown_on_the_whole_frame():
    """The spreadlet passes grow the bank once per frame, on every pixel a layer draws (colour or
    coverage alone: a black opaque pixel splats its opacity), and render the layers without
    checking it again: the same image as layers that each grow the bank they draw from (so no
    entry a layer needs is missing), and no rebuild from frame to frame."""
    from runtime_cl.layers.composite import PixelLayer, render_layers
    from runtime_cl.spreadlets.layers import SpreadletLayerSplatter

    rng = np.random.default_rng(36)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    colour, coords = frame(rng)
    alpha = (rng.random(colour.shape[:2]) < 0.8).astype(np.float32)
    colour[rng.random(colour.shape[:2]) < 0.2] = 0.0   # black, mostly opaque pixels
    coc = (coords[..., 0] - 3.0).astype(np.float32)
    angle = rng.uniform(-3, 3, colour.shape[:2]).astype(np.float32)
    layer = PixelLayer(colour * alpha[..., None], alpha, coc)
    once = Renderer(db)
    drawn = np.any(layer.rgb != 0, axis=2) | (alpha != 0)
    once.grow_bank(drawn[..., None].astype(np.float32), coords, angle)
    bank = once._bank
    a, _ = render_layers(SpreadletLayerSplatter(once, "spreadlets", [(coords, angle)], bank_checked=True), layer, 3)
    b, _ = render_layers(SpreadletLayerSplatter(Renderer(db), "spreadlets", [(coords, angle)]), layer, 3)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * np.abs(b).max())
    render_layers(SpreadletLayerSplatter(once, "spreadlets", [(coords, angle)], bank_checked=True), layer, 3)
    assert once._bank is bank
