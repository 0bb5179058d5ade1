"""Row-difference databases (basis "rows"): the splat kernel's merge sums each canvas row, so
the spreadlet pass draws the stored PSFs exactly, as stored or half-turned; every other turn, and
a Poisson integrator, is refused. The float64 references are plain numpy scatters."""
import numpy as np
import pytest
from cl_reference import STATS, splat_image

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.psf.synthetic import defocus_scene, disc_database
from runtime_cl.spreadlets.renderer import Renderer


def row_differences(dense):
    """Every non-zero backward difference along rows of a (2r+1)^2 crop: offsets and values."""
    r = dense.shape[0] // 2
    d = np.diff(np.pad(dense.astype(np.float64), ((0, 0), (1, 1), (0, 0))), axis=1)
    ys, xs = np.nonzero(np.any(d != 0, axis=2))
    return np.stack([xs - r, ys - r], 1), d[ys, xs]


def lopsided_database(rng, samples=8, r_max=9, channels=3, fast=()):
    """Random crescent-like crops (no symmetry) with their exact row differences."""
    grid = NestedGrid.for_samples(samples, (2.0,), [(0.0, float(r_max))], ["coc"])
    b = DatabaseBuilder("stylized", {"test": "rows", "basis": "rows", "symmetries": ["coc_sign"]}, grid,
                        channels, 2 * r_max + 1)
    for i in range(grid.size):
        r = int(rng.integers(1, r_max + 1))
        yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
        shape = (np.hypot(xx, yy) <= r) & (np.hypot(xx - r / 2, yy + r / 3) > r / 2)
        dense = (shape[..., None] * rng.uniform(0.5, 1.5, (2 * r + 1, 2 * r + 1, channels))).astype(np.float32)
        pts, vals = row_differences(dense)
        b.add(pts, vals, dense, fast_track=i in fast, stats=STATS)
    return b.build()


def scene(rng, h=40, w=52, r_max=9.0):
    colour = rng.random((h, w, 3)).astype(np.float32)
    colour[rng.random((h, w)) < 0.3] = 0.0
    coords = rng.uniform(0.0, r_max, (h, w, 1)).astype(np.float32)
    return colour, coords


@pytest.mark.parametrize("fast", [(), (2, 5)])
def test_spreadlets_draw_the_stored_psfs(fast):
    rng = np.random.default_rng(1)
    db = lopsided_database(rng, fast=fast)
    colour, coords = scene(rng)
    out, t = Renderer(db).render(colour, coords, "spreadlets")
    want = splat_image(db, colour, coords)
    assert t["integrate_ms"] < 5 and t["spreadlets"] > 0
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-6 * want.max())


def test_half_turns_draw_the_turned_psfs():
    """Angle pi on the right half: each PSF there is the stored one turned by 180 degrees, which
    for row differences is minus the term at 1 - x (not a turned offset); a lit pixel shows it."""
    rng = np.random.default_rng(2)
    db = lopsided_database(rng)
    renderer = Renderer(db)
    colour = np.zeros((41, 41, 3), np.float32)
    colour[20, 20] = (1.0, 2.0, 3.0)
    coords = np.full((41, 41, 1), 7.5, np.float32)
    plain, _ = renderer.render(colour, coords, "spreadlets")
    turned, t = renderer.render(colour, coords, "spreadlets", angle=np.full((41, 41), np.pi, np.float32))
    assert t["rotated"]
    np.testing.assert_allclose(turned, np.rot90(plain, 2), rtol=0, atol=1e-6 * plain.max())
    colour, coords = scene(rng)
    angle = np.where(rng.random(colour.shape[:2]) < 0.5, np.pi, 0.0).astype(np.float32)
    out, _ = renderer.render(colour, coords, "spreadlets", angle=angle)
    want, _ = renderer.render(colour, coords, "splat", angle=angle)
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-6 * want.max())


def test_other_turns_and_integrators_are_refused():
    db = lopsided_database(np.random.default_rng(3))
    colour, coords = scene(np.random.default_rng(4))
    with pytest.raises(InputError, match="row differences.*180 degrees.*basis = 'laplacian'"):
        Renderer(db).render(colour, coords, "spreadlets", angle=np.full(colour.shape[:2], 0.3, np.float32))
    with pytest.raises(InputError, match="integrator = 'pyramid'.*row differences.*give no integrator"):
        Renderer(db, integrator="pyramid")
    # Splat and Filter draw the dense PSFs: any angle
    Renderer(db).render(colour, coords, "splat", angle=np.full(colour.shape[:2], 0.3, np.float32))


def test_long_rows_sum_without_drift():
    """4096-px rows of defocused discs: the row sums run in double, so the far end of every row
    is as exact as its start (a float32 running sum drifts by ~sqrt(n) ulps of the row's level)."""
    colour, coc = defocus_scene(48, 4096, 20.0, seed=5)
    db = disc_database(20.0, samples=24, edge=1.5, basis="rows")
    out, _ = Renderer(db).render(colour, coc, "spreadlets")
    want, _ = Renderer(db).render(colour, coc, "splat")
    err = np.abs(out - want).max(axis=(0, 2))
    assert err.max() < 1e-5 * want.max()
    assert err[-512:].max() < 4 * max(err[:512].max(), 1e-7 * want.max())


def test_layers_and_the_pass_api_take_a_row_database():
    camera = ThinLens(focal_length_mm=50.0, f_number=1.4, focus_distance_m=0.6)
    rng = np.random.default_rng(6)
    rgb = rng.random((48, 64, 3)).astype(np.float32)
    depth = np.where(np.arange(64) < 30, 0.6, 0.35) * np.ones((48, 1))
    r = float(np.abs(camera.coc_radius_px(depth, 64)).max())
    rows, lap = (disc_database(r + 1.0, samples=16, edge=1.0, basis=b) for b in ("rows", "laplacian"))
    for layers in (1, 2):
        a, _ = runtime_cl.render(rgb, depth, camera, rows, method="spreadlets", layers=layers)
        b, _ = runtime_cl.render(rgb, depth, camera, lap, method="spreadlets", layers=layers, integrator="exact")
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * b.max())
    with pytest.raises(InputError, match="give no integrator"):
        runtime_cl.render(rgb, depth, camera, rows, method="spreadlets", integrator="fft32")
