"""Renderer: timings and counts, input validation, thin-lens PSF coordinates."""
import numpy as np
import pytest
from cl_reference import random_database

from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.coords.maps import psf_coords, thin_lens_coords
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.psf.disc import disc_psf
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.camera.thin_lens import ThinLens


@pytest.fixture(scope="module")
def renderer():
    return Renderer(random_database(np.random.default_rng(1), channels=1, fast=0.3))


def test_timings_and_counts(renderer):
    rng = np.random.default_rng(0)
    colour = rng.random((16, 20, 3)).astype(np.float32)
    coords = (rng.random((16, 20, 1)) * 6).astype(np.float32)
    for method in ("spreadlets", "splat", "filter"):
        image, t = renderer.render(colour, coords, method)
        assert image.shape == (16, 20, 3) and image.dtype == np.float32
        for key in ("upload_ms", "kernel_ms", "integrate_ms", "download_ms", "compile_ms", "total_ms"):
            assert t[key] >= 0.0, key
        assert t["kernel_ms"] > 0 and t["pixels"] == 320
        assert t["total_ms"] >= t["kernel_ms"]
    _, t = renderer.render(colour, coords, "spreadlets")
    assert t["compile_ms"] == 0.0  # built once per Renderer and colour channel count
    cell = renderer.db.grid.index(coords.astype(np.float64))
    fast = renderer.db.fast_track[cell]
    assert t["spreadlets"] == np.diff(renderer.db.C)[cell][~fast].sum()
    assert t["dense_pixels"] == ((2 * renderer.db.dense_radius[cell][fast].astype(int) + 1) ** 2).sum()


def test_bad_input_is_an_input_error(renderer):
    colour = np.ones((4, 5, 3), np.float32)
    coords = np.ones((4, 5, 1), np.float32)
    with pytest.raises(InputError, match=r"method = 'blur'.*spreadlets"):
        renderer.render(colour, coords, "blur")
    with pytest.raises(InputError, match=r"colour: 2 channels, need 1 or 3 .*or 4"):
        renderer.render(np.ones((4, 5, 2), np.float32), coords)
    with pytest.raises(InputError, match=r"coords: shape \(4, 6, 1\) does not match"):
        renderer.render(colour, np.ones((4, 6, 1), np.float32))
    with pytest.raises(InputError, match=r"outside the database range \[0.0, 6.0\].*max 7"):
        renderer.render(colour, np.full((4, 5, 1), 7.0, np.float32))
    bad = colour.copy()
    bad[1, 1, 1] = np.inf
    with pytest.raises(InputError, match="colour: 1 value"):
        renderer.render(bad, coords)


def test_disc_database_is_exact_and_in_focus_is_identity():
    db = disc_database(8.0, samples=10)
    assert np.allclose([db.dense_psf(i).sum() for i in range(db.n_samples)], 1.0)
    rng = np.random.default_rng(3)
    colour = rng.random((20, 24, 3)).astype(np.float32)
    coords = (rng.random((20, 24, 1)) * 8).astype(np.float32)
    renderer = Renderer(db)
    ours, _ = renderer.render(colour, coords, "spreadlets")
    splat, _ = renderer.render(colour, coords, "splat")
    np.testing.assert_allclose(ours, splat, atol=1e-5 * splat.max())
    focus, _ = renderer.render(colour, np.zeros_like(coords), "spreadlets")
    np.testing.assert_allclose(focus, colour, atol=1e-5)
    # PSFs sum to 1: with one PSF everywhere, a constant image stays constant away from the border
    flat, same = np.ones_like(colour), np.full_like(coords, 7.5)
    assert 5 <= db.dense_radius[db.grid.index(same[:1, :1].astype(np.float64))].max() <= 8
    for method in ("spreadlets", "splat", "filter"):
        image, _ = renderer.render(flat, same, method)
        np.testing.assert_allclose(image[9:11, 9:15], 1.0, atol=1e-5)
        assert image[0, 0, 0] < 0.9  # and darkens at the border, where in = 0 outside
    assert disc_psf(0.3).shape == (1, 1)


def test_thin_lens_coords():
    camera = ThinLens(focal_length_mm=50, f_number=2.0, focus_distance_m=3.0)
    db = disc_database(20.0, samples=8)
    depth = np.array([[3.0, 2.0, 4.0, np.inf]] * 2)
    coords = thin_lens_coords(camera, depth, db)
    assert coords.shape == (2, 4, 1) and coords.dtype == np.float32
    expect = np.abs(camera.coc_radius_px(depth, 4))
    np.testing.assert_allclose(coords[..., 0], expect, rtol=1e-6)
    assert coords[0, 0, 0] == 0.0  # in focus
    pc = psf_coords(camera, depth, db)
    np.testing.assert_array_equal(pc.coords, coords)
    assert pc.angle is None  # a disc database: symmetry rotation


def test_thin_lens_coords_beyond_the_database():
    camera = ThinLens(focal_length_mm=50, f_number=1.4, focus_distance_m=3.0)
    db = disc_database(4.0, samples=8)
    depth = np.full((8, 1024), 3.0)
    depth[2, :5] = 0.5  # far out of focus
    r = float(np.abs(camera.coc_radius_px(0.5, 1024)))
    with pytest.raises(InputError, match=rf"CoC radius: 5 pixel\(s\) outside the database range \[0.0, 4.0\] px "
                                         rf"\(largest found {r:.4g} px.*max CoC of at least {np.ceil(r):.0f}"):
        thin_lens_coords(camera, depth, db)
    with pytest.raises(InputError, match="depth Z = 0.0"):
        thin_lens_coords(camera, np.zeros((2, 2)), db)


def test_thin_lens_coords_need_a_simple_lens_database():
    db = random_database(np.random.default_rng(0), model="combined", beta=(2.0, 1.0), samples=12)
    camera = ThinLens(focal_length_mm=50, f_number=2.0, focus_distance_m=3.0)
    with pytest.raises(InputError, match="motion: a 'combined' database needs per-pixel motion vectors"):
        psf_coords(camera, np.ones((2, 2)), db)
    with pytest.raises(InputError, match=r"'combined' has PSF coordinates \['c0', 'c1'\].*'coc_radius_px'"):
        psf_coords(camera, np.ones((2, 2)), db, np.zeros((2, 2, 2)))
    with pytest.raises(InputError, match="need a 'simple_lens' database"):
        thin_lens_coords(camera, np.ones((2, 2)), db)


@pytest.mark.parametrize("edge", [1.0, 2.5])
def test_soft_rim_disc_database_is_exact(edge):
    p = disc_psf(6.0, edge=edge)
    assert p.shape == (2 * int(np.ceil(6.0 + edge / 2)) + 1,) * 2 and np.isclose(p.sum(), 1.0)
    assert np.count_nonzero(laplacian5(np.pad(p, 1))) > np.count_nonzero(laplacian5(np.pad(disc_psf(6.0), 1)))
    db = disc_database(8.0, samples=10, edge=edge)
    rng = np.random.default_rng(4)
    colour = rng.random((18, 22, 3)).astype(np.float32)
    coords = (rng.random((18, 22, 1)) * 8).astype(np.float32)
    renderer = Renderer(db)
    ours, _ = renderer.render(colour, coords, "spreadlets")
    splat, _ = renderer.render(colour, coords, "splat")
    np.testing.assert_allclose(ours, splat, atol=1e-5 * splat.max())
