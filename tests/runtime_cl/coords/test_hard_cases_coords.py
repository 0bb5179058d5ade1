"""Hard cases of the PSF coordinates (issue 14): zero and huge motion along the axes and the
diagonals, coordinates on nested-grid boundaries and just outside [0, 1] (float32 rounding past a
range end). References: float64 numpy (hypot, atan2), the NestedGrid's own float64 index, a
float64 numpy scatter of the turned PSFs."""
import math

import numpy as np
import pytest
from capsule import capsule_database
from rotation_reference import turned_splat_image

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.coords.maps import psf_coords
from runtime_cl.errors import InputError
from runtime_cl.psf.grid_cl import PsfIndexKernel
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.spreadlets.renderer import Renderer

CAMERA = ThinLens(50.0, 2.0, 2.0)
MAX_MOTION = 16.0
# the eight axis and diagonal directions, unit length
DIRECTIONS = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)]


def _motion_field(length):
    d = np.array(DIRECTIONS, np.float64)
    d /= np.hypot(d[:, 0], d[:, 1])[:, None]
    return (d * length)[None]                                      # (1, 8, 2)


@pytest.mark.parametrize("length", [0.0, 1e-30, 1.0, MAX_MOTION])
def test_motion_length_and_angle_along_axes_and_diagonals(length):
    """Length = hypot, angle = atan2 (float64), for the 8 directions, from zero to the database's
    largest motion (the range end itself must be accepted, not refused by float32 rounding).
    Tolerances: float32 coordinates (1 ulp of the length, 2^-22 rad of the wrapped angle)."""
    db = capsule_database(max_coc=8.0, max_motion=MAX_MOTION)
    motion = _motion_field(length)
    depth = np.full((1, 8), 2.0)                                   # in focus: no coc_sign turn
    pc = psf_coords(CAMERA, depth, db, motion)
    want_len = np.hypot(motion[..., 0], motion[..., 1])
    assert np.all(pc.coords[..., 1] <= MAX_MOTION)                   # inside the range, never past it
    np.testing.assert_allclose(pc.coords[..., 1], want_len, rtol=2 ** -23, atol=0)
    want_angle = np.arctan2(motion[..., 1], motion[..., 0])
    if length == 0.0:
        want_angle[:] = 0.0       # atan2(+-0, +-0) is 0 or +-pi: a still pixel is not turned
        want_angle[0, [3, 4, 5]] = np.pi                               # ... except atan2(0, -0) = pi
        # a still pixel's PSF is the same whatever the turn of a rotation-free capsule centre; what
        # matters is that the angle is finite and wrapped
    np.testing.assert_allclose(np.cos(pc.angle), np.cos(want_angle), rtol=0, atol=2 ** -22)
    np.testing.assert_allclose(np.sin(pc.angle), np.sin(want_angle), rtol=0, atol=2 ** -22)
    assert np.all((pc.angle >= -math.pi) & (pc.angle < math.pi))


def test_huge_motion_past_the_range_is_refused_along_every_direction():
    """Just past the largest motion (1e-9 px in float64) and absurdly far (1e30 px): an InputError
    naming the motion length, along every axis and diagonal."""
    db = capsule_database(max_coc=8.0, max_motion=MAX_MOTION)
    depth = np.full((1, 8), 2.0)
    for length in (MAX_MOTION * (1 + 1e-9), 1e30):
        with pytest.raises(InputError, match=r"motion length: 8 pixel\(s\) outside the database range"):
            psf_coords(CAMERA, depth, db, _motion_field(length))


@pytest.mark.parametrize("length", [0.0, 7.0, MAX_MOTION])
def test_motion_blur_renders_like_the_turned_numpy_scatter_in_all_eight_directions(length):
    """One lit pixel per direction, rendered by the dense splat with its turned PSF, against the
    float64 numpy scatter of the same turned crops. Tolerance 1e-5 of the peak: float32 bilinear
    taps and weights."""
    db = capsule_database(max_coc=8.0, max_motion=MAX_MOTION, skew=0.6)
    size = 33
    colour = np.zeros((size, 8 * size, 1), np.float32)
    colour[size // 2, size // 2::size] = 1.0
    motion = np.repeat(np.repeat(_motion_field(length), size, axis=1), size, axis=0)
    depth = np.full(colour.shape[:2], 1.9)                          # just in front of the focus
    pc = psf_coords(CAMERA, depth, db, motion)
    image, _ = Renderer(db).render(colour, pc.coords, "splat", angle=pc.angle)
    want = turned_splat_image(db, colour, pc.coords, pc.angle)
    np.testing.assert_allclose(image, want, rtol=0, atol=1e-5 * want.max())
    for k in range(8):                                             # energy stays 1 per direction
        assert image[:, k * size:(k + 1) * size].sum() == pytest.approx(1.0, rel=1e-5)


def test_coordinates_at_the_range_end_that_float32_rounds_up_are_kept_inside():
    """A database whose largest CoC (0.1 px) float32 cannot hold: float32(0.1) > 0.1. A pixel
    whose CoC is exactly 0.1 in float64 is accepted, its float32 coordinate stays <= 0.1, and it
    lands in the last cell (float64 NestedGrid index and the OpenCL index kernel agree), and the
    render runs. A CoC 1e-12 past it is refused. (Under NumPy 2 the clamp compared float32 with
    float32 and let 0.1000000015 through, which the render then refused.)"""
    r_max = 0.1
    assert float(np.float32(r_max)) > r_max
    db = disc_database(r_max, samples=6)
    z = 1.0 / (1.0 / CAMERA.focus_distance_m + r_max / CAMERA.coc_scale_px(64))   # CoC -0.1 px
    depth = np.full((2, 64), CAMERA.focus_distance_m)
    depth[0, 5] = z
    coc = abs(CAMERA.coc_radius_px(z, 64))
    assert coc == pytest.approx(r_max, rel=1e-15)
    if coc > r_max:   # rounding put it past the end in float64 too: nudge it back to the end
        depth[0, 5] = np.nextafter(z, np.inf)
    pc = psf_coords(CAMERA, depth, db)
    assert pc.coords.dtype == np.float32 and float(pc.coords.max()) <= r_max
    last = db.grid.size - 1
    assert db.grid.index(pc.coords[0, 5].astype(np.float64)) == last
    cells, _ = PsfIndexKernel(db.grid).index(pc.coords.reshape(-1, 1))
    assert cells.reshape(2, 64)[0, 5] == last and cells.max() == last
    image, _ = runtime_cl.render(np.ones((2, 64, 1), np.float32), depth, CAMERA, db)
    assert image.shape == (2, 64, 1)
    depth[0, 5] = 1.0 / (1.0 / CAMERA.focus_distance_m + r_max * (1 + 1e-12) / CAMERA.coc_scale_px(64))
    with pytest.raises(InputError, match=r"CoC radius: 1 pixel\(s\) outside the database range \[0.0, 0.1\]"):
        psf_coords(CAMERA, depth, db)


def test_every_nested_grid_boundary_in_float64_picks_the_upper_cell():
    """Points exactly on every cell boundary of a 2-D nested grid (grid coordinates integer, so
    exact in float64): the index is the cell whose box starts there (half-open boxes), checked
    against the box of each cell, and the range ends 0 and 1 are inside."""
    db = capsule_database(max_coc=8.0, max_motion=MAX_MOTION, samples=10)
    grid = db.grid
    n = grid.n
    g = np.stack(np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="ij"), -1).reshape(-1, 2)
    idx = grid.index_of_grid(g)
    assert idx.min() >= 0 and idx.max() < grid.size
    # the same boundary points nudged up by 1e-9 grid units (inside the upper box) pick the same
    # cell, except at the top end n, which belongs to the last box below it
    up = np.minimum(g + 1e-9, n)
    np.testing.assert_array_equal(grid.index_of_grid(up), idx)
    # physical coordinates at the exact range ends 0 and the maxima: inside, no error
    ends = np.array([[0.0, 0.0], [8.0, 0.0], [0.0, MAX_MOTION], [8.0, MAX_MOTION]])
    assert np.all(grid.index(ends) < grid.size)
    with pytest.raises(InputError, match="outside the database range"):
        grid.index(np.array([[8.0 * (1 + 1e-12), 0.0]]))
    with pytest.raises(InputError, match="outside the database range"):
        grid.index(np.array([[0.0, -1e-300]]))
