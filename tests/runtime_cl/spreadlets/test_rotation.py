"""Per-pixel PSF rotation (``Renderer.render(angle=...)``): exact quarter turns, arbitrary angles
against scipy and plain numpy, energy, runs, bad input.

Angles turn the PSF counter-clockwise as the image is viewed (image +x towards y up), the way
``np.rot90`` turns an array whose rows grow downward. These check the per-pixel turn
(``spreadlet_rotation="bilinear"``); the angle bank, the default, is checked in test_angle_bank.py.
"""
import dataclasses

import numpy as np
import pytest
from capsule import capsule_database
from cl_reference import STATS, laplacian_database, random_database
from rotation_reference import (turned_filter_image, turned_spreadlet_canvas, turned_splat_image)
from scipy import ndimage

from runtime_cl.errors import InputError
from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.spreadlets.splat import TileSplatter, canvas_shape

METHODS = ("spreadlets", "splat", "filter")


def lit_pixel(db, size=41, channels=1):
    """A single lit pixel at the centre of a size^2 image, every pixel in the database's first cell."""
    colour = np.zeros((size, size, channels), np.float32)
    colour[size // 2, size // 2] = np.arange(1, channels + 1)
    coords = np.tile(np.array([lo for lo, _ in db.grid.ranges], np.float32), (size, size, 1))
    return colour, coords


def full(size, degrees):
    return np.full((size, size), np.radians(degrees), np.float32)


@pytest.fixture(scope="module")
def capsule():
    return Renderer(capsule_database(radius=4.0, length=10.0), spreadlet_rotation="bilinear")


@pytest.mark.parametrize("fast", [False, True])
@pytest.mark.parametrize("k,degrees", [(1, 90.0), (2, 180.0), (3, 270.0), (3, -90.0), (0, 360.0)])
def test_quarter_turns_are_rot90(fast, k, degrees):
    db = capsule_database(fast=fast, skew=0.6)  # no turn or flip of it looks the same
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    colour, coords = lit_pixel(db)
    for method in METHODS:
        plain, _ = renderer.render(colour, coords, method)
        turned, t = renderer.render(colour, coords, method, angle=full(41, degrees))
        assert t["rotated"]
        if method == "spreadlets" and not fast:
            # the Laplacian canvas is turned exactly; the FFT integration of a differently placed
            # canvas rounds differently: 1e-6 of the peak
            np.testing.assert_allclose(turned, np.rot90(plain, k), rtol=0, atol=1e-6 * plain.max())
        else:
            np.testing.assert_array_equal(turned, np.rot90(plain, k))


def test_quarter_turns_of_the_laplacian_canvas_are_exact():
    import pyopencl as cl

    db = laplacian_database(np.random.default_rng(3), r_max=6, channels=3)
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    splatter = TileSplatter(renderer.ddb, 3, dense_all=False, rotate=True)
    colour, coords = lit_pixel(db, size=33, channels=3)
    coords[:] = 5.0
    ctx = renderer.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    canvases = []
    for degrees in (0.0, 90.0, 180.0):
        out = splatter.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), 33, 33,
                           angle_buf=cl.Buffer(ctx, flags, hostbuf=full(33, degrees)))
        assert out.spreadlets > 0 and out.pad == db.rotated_pad
        side = 33 + 2 * out.pad  # square around the lit pixel: the canvas may be larger (FFT sizes)
        canvases.append(out.canvas[0, :side, :side].copy())
    np.testing.assert_array_equal(canvases[1], np.rot90(canvases[0], 1))
    np.testing.assert_array_equal(canvases[2], np.rot90(canvases[0], 2))


@pytest.mark.parametrize("degrees", [30.0, 45.0, 73.0, 200.0])
def test_arbitrary_angles_match_scipy_rotate(capsule, degrees):
    """Dense PSFs are turned as ``ndimage.rotate(order=1)`` does (bilinear, inverse-mapped), then
    scaled to keep their energy; scipy's result scaled the same way agrees to float32 rounding
    (1e-6 of the peak; the positions differ by float32 vs float64 arithmetic only). Spreadlets
    land bilinearly and are integrated: against the turned integrated PSF they measured 1.6-2.6 %
    L1 (of the energy) and 3.7-5.7 % of the peak at most (the tent shares each Laplacian value over
    a pixel, a slightly different softening than interpolating the image), so 4 % and 8 %.
    Rounding to the nearest pixel instead is far worse (> 5 % L1), which is why it is not the default.
    """
    colour, coords = lit_pixel(capsule.db)
    angle = full(41, degrees)
    plain, _ = capsule.render(colour, coords, "spreadlets")
    ref_spreadlets = ndimage.rotate(plain[..., 0].astype(np.float64), degrees, order=1, reshape=False)
    psf = capsule.db.dense_psf(0)[..., 0].astype(np.float64)
    r = psf.shape[0] // 2
    embedded = np.zeros((41, 41))
    embedded[20 - r:21 + r, 20 - r:21 + r] = psf
    ref = ndimage.rotate(embedded, degrees, order=1, reshape=False)
    ref *= psf.sum() / ref.sum()
    for method in ("splat", "filter"):
        image, _ = capsule.render(colour, coords, method, angle=angle)
        np.testing.assert_allclose(image[..., 0], ref, rtol=0, atol=1e-6 * ref.max())
    image, _ = capsule.render(colour, coords, "spreadlets", angle=angle)
    err = np.abs(image[..., 0] - ref_spreadlets)
    assert err.sum() < 0.04 * plain.sum() and err.max() < 0.08 * plain.max()
    nearest, _ = Renderer(capsule.db, spreadlet_rotation="nearest").render(colour, coords, "spreadlets", angle=angle)
    assert np.abs(nearest[..., 0] - ref_spreadlets).sum() > 0.05 * plain.sum()


@pytest.mark.parametrize("degrees", [17.0, 45.0, 123.0, -160.0])
def test_energy_is_kept(degrees):
    """Dense turns are scaled to the stored sum per channel: exact to float32 rounding. Spreadlets
    keep their sum and first moments under bilinear sharing; the energy of the integrated PSF
    moved by 0.1-0.2 % for the capsules measured: 0.5 % allowed."""
    db = capsule_database(radius=6.0, length=14.0)
    rgb = dataclasses.replace(db, channels=3, V=np.repeat(db.V, 3, axis=1) * [1.0, 0.5, 2.0],
                              dense_values=np.repeat(db.dense_values, 3, axis=1) * [1.0, 0.5, 2.0],
                              checksum=None, path=None)
    renderer = Renderer(rgb, spreadlet_rotation="bilinear")
    colour, coords = lit_pixel(rgb, size=61)
    for method in METHODS:
        plain, _ = renderer.render(colour, coords, method)
        turned, _ = renderer.render(colour, coords, method, angle=full(61, degrees))
        np.testing.assert_allclose(plain.sum(axis=(0, 1)), [1.0, 0.5, 2.0], rtol=1e-5)
        tol = 5e-3 if method == "spreadlets" else 1e-5
        np.testing.assert_allclose(turned.sum(axis=(0, 1)), plain.sum(axis=(0, 1)), rtol=tol)


@pytest.mark.parametrize("db_channels,cc", [(1, 3), (3, 3), (3, 1)])
def test_turned_dense_methods_match_numpy(db_channels, cc):
    rng = np.random.default_rng(40 + db_channels + cc)
    db = laplacian_database(rng, r_max=5, channels=db_channels)
    h, w = 17, 23
    colour = rng.random((h, w, cc)).astype(np.float32)
    colour[rng.random((h, w)) < 0.2] = 0.0
    coords = (rng.random((h, w, 1)) * 5).astype(np.float32)
    angle = rng.uniform(-7, 7, (h, w)).astype(np.float32)
    angle[:4] = np.radians(90.0 * rng.integers(-4, 5, (4, w)))  # some quarter turns
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    for method, reference in (("splat", turned_splat_image), ("filter", turned_filter_image)):
        image, t = renderer.render(colour, coords, method, angle=angle)
        want = reference(db, colour, coords, angle)
        np.testing.assert_allclose(image, want, rtol=0, atol=1e-5 * np.abs(want).max())


def streak_database(rng, samples=12, r_max=9):
    """Dense crops that are mostly zero: off-centre streaks 1-3 rows high (motion-blur-like), so
    the turned PSF's support (rotate.cl turned_cols) is far smaller than its reach square."""
    grid = NestedGrid.for_samples(samples, (2.0,), [(0.0, float(r_max))], ["coc"])
    b = DatabaseBuilder("simple_lens", {"test": "streaks"}, grid, 1, 2 * r_max + 1)
    for i in range(grid.size):
        r = int(rng.integers(1, r_max + 1))
        dense = np.zeros((2 * r + 1, 2 * r + 1, 1), np.float32)
        if i % 5:  # every fifth cell stays all zero
            y0, x0 = int(rng.integers(0, 2 * r)), int(rng.integers(0, r))
            dense[y0:y0 + int(rng.integers(1, 4)), x0:x0 + int(rng.integers(1, 2 * r + 2 - x0))] = rng.random()
        b.add(np.zeros((0, 2), int), np.zeros((0, 1)), dense, fast_track=True, stats=STATS)
    return b.build()


def test_turned_streaks_match_numpy():
    """Turned PSFs are sampled only over their non-zero support: streaks whose support is thin
    and off-centre, at angles from 1e-4 rad to near quarter turns, still match the full turn."""
    rng = np.random.default_rng(45)
    db = streak_database(rng)
    h, w = 23, 25
    colour = rng.random((h, w, 3)).astype(np.float32)
    coords = (rng.random((h, w, 1)) * 9).astype(np.float32)
    angle = rng.uniform(-7, 7, (h, w)).astype(np.float32)
    angle[:3] = (np.pi / 2 * rng.integers(-4, 5, (3, 1)) + rng.choice([1e-4, -1e-4, 1e-2], (3, w))).astype(np.float32)
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    for method, reference in (("splat", turned_splat_image), ("filter", turned_filter_image)):
        image, _ = renderer.render(colour, coords, method, angle=angle)
        want = reference(db, colour, coords, angle)
        np.testing.assert_allclose(image, want, rtol=0, atol=1e-5 * np.abs(want).max())


@pytest.mark.parametrize("how", ["bilinear", "nearest"])
def test_turned_spreadlet_canvas_matches_numpy(how):
    import pyopencl as cl

    rng = np.random.default_rng(50)
    db = random_database(rng, r_max=6, fast=0.3, spreadlets=(5, 40))
    h, w = 19, 21
    colour = rng.random((h, w, 3)).astype(np.float32)
    coords = (rng.random((h, w, 1)) * 6).astype(np.float32)
    angle = rng.uniform(-4, 4, (h, w)).astype(np.float32)
    angle[::3] = np.radians(180.0)
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    splatter = TileSplatter(renderer.ddb, 3, dense_all=False, rotate=True, spreadlet_rotation=how)
    ctx = renderer.device.context
    flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
    out = splatter.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), h, w,
                       tile=(8, 7), angle_buf=cl.Buffer(ctx, flags, hostbuf=angle))
    want = turned_spreadlet_canvas(db, colour, coords, angle, canvas_shape(h, w, db.rotated_pad), how == "bilinear")
    np.testing.assert_allclose(out.canvas[0], want, rtol=0, atol=1e-5 * np.abs(want).max())


@pytest.mark.parametrize("method", METHODS)
def test_runs_break_where_the_angle_changes(method):
    """Runs of same-cell pixels also need the same angle; runs change only float rounding."""
    rng = np.random.default_rng(60)
    db = laplacian_database(rng, r_max=5, fast=0.3)
    h, w = 12, 60
    colour = rng.random((h, w, 3)).astype(np.float32)
    coords = np.full((h, w, 1), 3.7, np.float32)
    angle = np.repeat(rng.uniform(-3, 3, (h, 6)), 10, axis=1).astype(np.float32)  # blocks of 10 pixels
    runs, _ = Renderer(db).render(colour, coords, method, angle=angle)
    single, _ = Renderer(db, run_max=1).render(colour, coords, method, angle=angle)
    np.testing.assert_allclose(runs, single, rtol=0, atol=1e-5 * np.abs(single).max())
    if method != "filter":
        assert not np.allclose(runs, Renderer(db).render(colour, coords, method)[0], atol=1e-3)


def test_rotation_invariant_database_ignores_the_angle():
    db = capsule_database()
    disc = dataclasses.replace(db, params=dict(db.params, symmetries=["rotation"]), checksum=None, path=None)
    renderer = Renderer(disc)
    assert renderer.rotation_invariant and not Renderer(db).rotation_invariant
    colour, coords = lit_pixel(disc)
    plain, _ = renderer.render(colour, coords, "splat")
    same, t = renderer.render(colour, coords, "splat", angle=full(41, 33.0))
    assert not t["rotated"]
    np.testing.assert_array_equal(same, plain)


def test_bad_angles_are_input_errors(capsule):
    colour, coords = lit_pixel(capsule.db, size=9)
    with pytest.raises(InputError, match=r"angle: shape \(9, 8\) does not match the image \(9, 9\)"):
        capsule.render(colour, coords, angle=np.zeros((9, 8)))
    with pytest.raises(InputError, match=r"angle: shape \(9, 9, 1\) has 3 dimension"):
        capsule.render(colour, coords, angle=np.zeros((9, 9, 1)))
    bad = np.zeros((9, 9))
    bad[2, 3], bad[4, 4] = np.nan, np.inf
    with pytest.raises(InputError, match="angle: 2 value.*NaN or infinite.*radians"):
        capsule.render(colour, coords, angle=bad)
    with pytest.raises(InputError, match=r"spreadlet_rotation = 'cubic': must be one of \['bilinear', 'nearest', 'bank'\]"):
        Renderer(capsule.db, spreadlet_rotation="cubic")


@pytest.mark.parametrize("method", ["spreadlets", "splat"])
def test_half_turns_keep_the_unturned_padding(method):
    """Angles of only 0 and +-pi (the coc_sign symmetry) keep every turned PSF inside its stored
    square, so the splatter keeps the database's pad instead of rotated_pad; the image is the
    one every pixel's turned PSF gives (numpy, float64), and the turned spreadlets' canvas is
    the numpy one at the smaller pad."""
    import pyopencl as cl

    from runtime_cl.spreadlets.splat import half_turns

    rng = np.random.default_rng(60)
    db = laplacian_database(rng, r_max=6, channels=3, fast=0.4)
    assert db.rotated_pad > db.pad   # else the test shows nothing
    h, w = 19, 23
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < 0.2] = 0.0
    coords = (rng.random((h, w, 1)) * 6).astype(np.float32)
    angle = rng.choice(np.float32([0.0, np.pi, -np.pi]), (h, w))
    assert half_turns(angle) and not half_turns(angle + np.float32(1e-3))
    renderer = Renderer(db, spreadlet_rotation="bilinear")
    image, _ = renderer.render(colour, coords, method, angle=angle)
    wrapper = renderer._wrappers[(method, 3, True, True)]   # the half-turn splatter was used
    assert wrapper.pad == db.pad
    want = turned_splat_image(db, colour, coords, angle)
    # the spreadlets are these PSFs' exact Laplacians: the FFT integration rounds at 1e-6 of the peak
    np.testing.assert_allclose(image, want, rtol=0, atol=1e-5 * np.abs(want).max())
    if method == "spreadlets":
        ctx = renderer.device.context
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        out = wrapper.run(cl.Buffer(ctx, flags, hostbuf=colour), cl.Buffer(ctx, flags, hostbuf=coords), h, w,
                          tile=(8, 7), angle_buf=cl.Buffer(ctx, flags, hostbuf=angle))
        canvas = turned_spreadlet_canvas(db, colour, coords, angle, canvas_shape(h, w, db.pad), True, pad=db.pad)
        np.testing.assert_allclose(out.canvas[0], canvas, rtol=0, atol=1e-5 * np.abs(canvas).max())
