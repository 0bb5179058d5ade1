"""A render through a box of medium: the unscattered light is Beer-Lambert exactly, per pixel, from its
own segment in the box; the scattered light is the database's energy; pixels whose rays miss the box
are untouched."""
import math

import numpy as np
import pytest

import runtime_cl
from lab.precompute import precompute
from lab.psf_tracing.models.volume_box import VolumeBox, VolumeBoxConfig
from runtime_cl.camera.pinhole import Pinhole
from runtime_cl.coords.maps import psf_coords

SIGMA, H, W, WALL = 0.8, 40, 40, 3.0
CAMERA = Pinhole(fov_deg=40.0)


def _database(box):
    """One cell (the checks below hold for any cell): seconds to build."""
    config = VolumeBoxConfig(medium_density=SIGMA, g=0.6, albedo=(1.0, 1.0, 0.9), width_px=W,
                             focal_length_mm=18.0 / math.tan(math.radians(20.0)), psf_resolution=33,
                             samples=1, rays_per_psf=2 ** 17, max_camera_gap_m=1.5, max_medium_length_m=1.5,
                             max_light_gap_m=1.5, box_center=tuple(box["center"]),
                             box_axes=tuple(tuple(a) for a in box["axes"]), box_half_size=tuple(box["half_size"]))
    return runtime_cl.load_database(precompute(VolumeBox(config), progress=False).path, expect_model="volume_box")


def _wall_depth():
    return np.full((H, W), WALL)                        # a wall facing the camera 3 m away


def _render(db, rgb):
    image, _ = runtime_cl.render(rgb, _wall_depth(), CAMERA, db, method="splat")
    return image


def _cos_to_axis():
    f = CAMERA.focal_px(W)
    yy, xx = np.mgrid[:H, :W] + 0.5 - np.array([H, W])[:, None, None] / 2
    return 1.0 / np.sqrt(1.0 + (xx ** 2 + yy ** 2) / f ** 2)


def test_a_slab_of_medium_attenuates_each_pixel_by_its_own_path_and_adds_the_scattered_light(cache):
    """A slab z in [1, 2] m across the whole view: a pixel's ray crosses 1 / cos(angle) m of it. With a
    single lit pixel, every other pixel holds scattered light only, and the lit pixel holds exactly
    exp(-sigma_t L) of itself plus its own centre's scattered light."""
    slab = {"center": [0.0, 0.0, 1.5], "axes": np.eye(3).tolist(), "half_size": [50.0, 50.0, 0.5]}
    db = _database(slab)
    length = 1.0 / _cos_to_axis()
    coords = psf_coords(CAMERA, _wall_depth(), db)
    np.testing.assert_allclose(coords.direct, np.exp(-SIGMA * length), rtol=1e-5)
    np.testing.assert_allclose(coords.coords[..., 1], length, rtol=1e-5)
    rgb = np.zeros((H, W, 3), np.float32)
    rgb[20, 20] = 1.0
    image = _render(db, rgb)
    cell = int(db.grid.index(coords.coords[20, 20].astype(np.float64)[None])[0])
    psf = db.dense_psf(cell)                               # the cell's scattered light, stored with its energy
    c = psf.shape[0] // 2
    # the cell's PSF scaled to the pixel's own scattered fraction (the cell holds its mean over [lo, hi])
    lo, hi = db.grid.ranges[1]
    gain = coords.gain[20, 20]
    kept = (math.exp(-SIGMA * lo) - math.exp(-SIGMA * hi)) / (SIGMA * (hi - lo))   # one cell: the whole range
    assert gain == pytest.approx((1 - math.exp(-SIGMA * length[20, 20])) / (1 - kept), rel=1e-5)
    assert image[20, 20] == pytest.approx(math.exp(-SIGMA * length[20, 20]) + gain * psf[c, c], rel=1e-3)
    halo = image.sum(axis=(0, 1)) - image[20, 20]
    # the scattered light around the pixel is the PSF's less its centre (cut only where it leaves the
    # 40-px frame: the 33-px window fits inside it)
    np.testing.assert_allclose(halo, gain * (psf.sum(axis=(0, 1)) - psf[c, c]), rtol=1e-3)
    # Beer-Lambert takes 1 - exp(-0.8) = 55 % of the direct light; a forward-scattering medium gives a
    # good part of it back within the window
    assert np.all(0.1 < psf.sum(axis=(0, 1))) and np.all(psf.sum(axis=(0, 1)) < 1 - math.exp(-SIGMA))


def test_pixels_whose_rays_miss_the_box_are_untouched(cache):
    """A box behind the wall: no ray reaches it, the render is the input. A box over the right half of
    the view: the left half stays exactly the input although bright pixels beside it scatter."""
    behind = {"center": [0.0, 0.0, 4.0], "axes": np.eye(3).tolist(), "half_size": [50.0, 50.0, 0.5]}
    rgb = np.random.default_rng(0).uniform(0.1, 1.0, (H, W, 3)).astype(np.float32)
    np.testing.assert_allclose(_render(_database(behind), rgb), rgb, rtol=1e-6, atol=1e-7)
    right = {"center": [25.0, 0.0, 1.5], "axes": np.eye(3).tolist(), "half_size": [25.0, 50.0, 0.5]}
    rgb[:, 20:] *= 50.0                                        # bright pixels in the box's half
    image = _render(_database(right), rgb)
    np.testing.assert_allclose(image[:, :20], rgb[:, :20], rtol=1e-6, atol=1e-7)
    assert not np.allclose(image[:, 20:], rgb[:, 20:], rtol=0.05)


def test_the_runtime_finds_the_cell_range_each_psf_was_prefiltered_over():
    """runtime_cl.coords.medium_box.cell_range (forward map) against the lab's inverse map
    (lab.psf_tracing.space.boxes) for points all over a 3-D nested grid, with a power remap."""
    from runtime_cl.coords.medium_box import cell_range, scattered_fraction_gain

    model = VolumeBox(VolumeBoxConfig(samples=111, beta=1.7))
    grid = model.grid
    x = np.random.default_rng(2).uniform(0, 1, (2000, 3)) * [hi for _, hi in grid.ranges]
    x[:50, 1] = 0.0                                             # the range's ends
    x[50:100, 1] = grid.ranges[1][1]
    cells = grid.index(x)
    for dim in range(3):
        lo, hi = cell_range(grid, x, dim)
        np.testing.assert_allclose(lo, [model.boxes[i].lo[dim] for i in cells], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(hi, [model.boxes[i].hi[dim] for i in cells], rtol=1e-12, atol=1e-12)
    # the gain undoes the pre-filter: its mean over a cell's lengths is 1
    lengths = np.linspace(0.2, 0.7, 100001)
    gain = scattered_fraction_gain(SIGMA, lengths, np.full_like(lengths, 0.2), np.full_like(lengths, 0.7))
    assert gain.mean() == pytest.approx(1.0, rel=1e-6) and gain[0] < 0.5 < 1.3 < gain[-1]
