"""Coordinate maps of every database model: coordinates, rotation angles, bad input.

Angles are radians counter-clockwise from image +x with y up; motion vectors are (X right, Y up).
"""
import math

import numpy as np
import pytest
from capsule import capsule_database

from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.errors import InputError
from runtime_cl.coords.maps import COORDINATE_MAPS, needs_motion, psf_coords
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.camera.thin_lens import ThinLens

CAMERA = ThinLens(focal_length_mm=50.0, f_number=2.0, focus_distance_m=2.0)
STATS = {"sparsity": 1.0, "ssim": 1.0, "l1": 0.0}


def space_database(model, names, ranges, symmetries, config=None, channels=1):
    """A tiny database of ``model`` with delta PSFs: only its PSF space and header matter here."""
    grid = NestedGrid.for_samples(4, (1.0,) * len(names), ranges, names)
    b = DatabaseBuilder(model, {"config": config or {}, "symmetries": symmetries}, grid, channels, 1)
    for _ in range(grid.size):
        b.add(np.zeros((0, 2), int), np.zeros((0, channels)), np.ones((1, 1, channels)), stats=STATS)
    return b.build()


def coc(depth, width):
    return CAMERA.coc_radius_px(np.asarray(depth, float), width)


def test_every_model_has_a_map():
    assert sorted(COORDINATE_MAPS) == ["combined", "physical_lens", "simple_lens", "stylized", "volume", "volume_box"]
    assert needs_motion("combined") and not needs_motion("simple_lens") and not needs_motion("volume")
    with pytest.raises(InputError, match="no coordinate map for it"):
        needs_motion("polygon")


def test_combined_angle_is_motion_angle_minus_reference_plus_the_coc_sign_turn():
    db = capsule_database(max_coc=40.0, max_motion=30.0, direction_deg=30.0)
    depth = np.array([[2.0, 2.0, 1.5, 4.0, 4.0]])  # in focus x2, in front, behind x2
    motion = np.array([[[0.0, 5.0], [3.0, 0.0], [0.0, 5.0], [0.0, 5.0], [0.0, 0.0]]])  # up, right, up, up, still
    pc = psf_coords(CAMERA, depth, db, motion)
    assert pc.coords.shape == (1, 5, 2) and pc.angle.shape == (1, 5) and pc.angle.dtype == np.float32
    np.testing.assert_allclose(pc.coords[0, :, 0], np.abs(coc(depth, 5))[0], rtol=1e-6)
    np.testing.assert_allclose(pc.coords[0, :, 1], [5.0, 3.0, 5.0, 5.0, 0.0])
    want = np.radians([90 - 30, 0 - 30, 90 - 30, 90 - 30 + 180, 0 - 30 + 180])
    np.testing.assert_allclose(np.cos(pc.angle[0]), np.cos(want), atol=1e-6)
    np.testing.assert_allclose(np.sin(pc.angle[0]), np.sin(want), atol=1e-6)
    assert np.all((pc.angle >= -math.pi) & (pc.angle < math.pi))


def test_combined_render_turns_the_capsule_with_the_motion():
    """A pixel moving up (+Y) is drawn with the +x-traced PSF turned a quarter counter-clockwise,
    behind the focal plane turned once more by 180 degrees (np.rot90 of the still render)."""
    db = capsule_database(max_coc=40.0, max_motion=30.0, skew=0.6)
    renderer = Renderer(db)
    size = 41
    colour = np.zeros((size, size, 1), np.float32)
    colour[20, 20] = 1.0
    for z, extra_turns in ((1.9, 0), (2.1, 2)):  # just in front of / behind the focal plane
        depth = np.full((size, size), z)
        right = psf_coords(CAMERA, depth, db, np.tile([7.0, 0.0], (size, size, 1)))
        up = psf_coords(CAMERA, depth, db, np.tile([0.0, 7.0], (size, size, 1)))
        plain, _ = renderer.render(colour, right.coords, "splat", angle=right.angle)
        turned, _ = renderer.render(colour, up.coords, "splat", angle=up.angle)
        still, _ = renderer.render(colour, right.coords, "splat")
        np.testing.assert_array_equal(plain, np.rot90(still, extra_turns))
        np.testing.assert_array_equal(turned, np.rot90(still, 1 + extra_turns))


def test_combined_needs_motion_in_range():
    db = capsule_database(max_coc=40.0, max_motion=16.0)
    depth = np.full((2, 3), 2.5)
    with pytest.raises(InputError, match="motion: a 'combined' database needs per-pixel motion vectors"):
        psf_coords(CAMERA, depth, db)
    far = np.zeros((2, 3, 2))
    far[1, 2] = [30.0, 40.0]
    with pytest.raises(InputError, match=r"motion length: 1 pixel\(s\) outside the database range \[0.0, 16.0\] "
                                         r"px \(largest found 50 px.*max_motion_px of at least 50"):
        psf_coords(CAMERA, depth, db, far)
    with pytest.raises(InputError, match=r"motion: shape \(2, 3\), need \(2, 3, 2\)"):
        psf_coords(CAMERA, depth, db, np.zeros((2, 3)))
    bad = np.zeros((2, 3, 2))
    bad[0, 0, 1] = np.nan
    with pytest.raises(InputError, match="motion: 1 value"):
        psf_coords(CAMERA, depth, db, bad)


@pytest.mark.parametrize("model,symmetries", [("stylized", ["coc_sign"]), ("simple_lens", ["coc_sign"])])
def test_coc_sign_turns_points_behind_the_focal_plane(model, symmetries):
    db = space_database(model, ("coc_radius_px",), ((0.0, 40.0),), symmetries)
    depth = np.array([[1.5, 2.0, 4.0, np.inf]])
    pc = psf_coords(CAMERA, depth, db)
    np.testing.assert_allclose(pc.coords[0, :, 0], np.abs(coc(depth, 4))[0], rtol=1e-6)
    np.testing.assert_array_equal(pc.angle, np.float32([[0.0, 0.0, -math.pi, -math.pi]]))  # 180 degrees


def test_simple_lens_circle_needs_no_angle_and_unknown_symmetries_are_refused():
    db = space_database("simple_lens", ("coc_radius_px",), ((0.0, 40.0),), ["rotation"])
    assert psf_coords(CAMERA, np.full((2, 2), 3.0), db).angle is None
    odd = space_database("simple_lens", ("coc_radius_px",), ((0.0, 40.0),), ["motion_direction"])
    with pytest.raises(InputError, match=r"records symmetries \['motion_direction'\]"):
        psf_coords(CAMERA, np.full((2, 2), 3.0), odd)
    stylized = space_database("stylized", ("coc_radius_px",), ((0.0, 40.0),), ["rotation"])
    with pytest.raises(InputError, match=r"records symmetries \['rotation'\], the runtime's coordinate map applies "
                                         r"\['coc_sign'\]"):
        psf_coords(CAMERA, np.full((2, 2), 3.0), stylized)


def physical_db(width=7, max_ecc=10.0):
    return space_database("physical_lens", ("depth_m", "eccentricity_px"), ((0.5, 20.0), (0.0, max_ecc)),
                          ["optical_axis"], {"width_px": width}, channels=3)


def test_physical_lens_eccentricity_and_azimuth():
    db = physical_db()
    depth = np.full((5, 7), 3.0)
    depth[0, 0] = 0.5
    pc = psf_coords(None, depth, db)
    assert pc.coords.shape == (5, 7, 2)
    np.testing.assert_allclose(pc.coords[..., 0], depth)
    assert pc.coords[2, 3, 1] == 0.0  # the centre pixel of an odd image
    assert pc.coords[0, 3, 1] == 2.0 and pc.coords[2, 6, 1] == 3.0
    np.testing.assert_allclose(pc.coords[0, 0, 1], math.hypot(3, 2), rtol=1e-6)
    assert pc.angle[0, 3] == np.float32(math.pi / 2)  # straight above the centre: azimuth 90 degrees
    assert pc.angle[4, 3] == np.float32(-math.pi / 2)  # below
    assert pc.angle[2, 6] == 0.0 and pc.angle[2, 0] == np.float32(-math.pi)  # right: 0, left: 180
    np.testing.assert_allclose(pc.angle[0, 6], math.atan2(2, 3), rtol=1e-6)  # upper right


def test_physical_lens_bad_input():
    db = physical_db()
    with pytest.raises(InputError, match=r"image width 8 px: the physical_lens database was traced for images 7 px"):
        psf_coords(None, np.full((5, 8), 3.0), db)
    far = np.full((5, 7), 3.0)
    far[1, 1] = 50.0
    with pytest.raises(InputError, match=r"depth: 1 pixel\(s\) outside the database range \[0.5, 20.0\] m"
                                         r".*far_m >= 50"):
        psf_coords(None, far, db)
    far[1, 1] = np.inf
    with pytest.raises(InputError, match="give the background a finite depth"):
        psf_coords(None, far, db)
    with pytest.raises(InputError, match=r"eccentricity: 4 pixel\(s\).*max_eccentricity_px >= 4"):
        psf_coords(None, np.full((5, 7), 3.0), physical_db(max_ecc=3.5))
    with pytest.raises(InputError, match="depth Z = -1.0"):
        psf_coords(None, np.full((5, 7), -1.0), db)


def test_volume_distance():
    db = space_database("volume", ("distance_m",), ((0.0, 10.0),), ["rotation"], channels=3)
    depth = np.full((3, 5), 2.0)
    pc = psf_coords(CAMERA, depth, db)
    assert pc.angle is None and pc.coords.shape == (3, 5, 1)
    f_px = CAMERA.image_distance_m * 5 / 0.036
    assert pc.coords[1, 2, 0] == 2.0  # the centre pixel looks along the axis
    np.testing.assert_allclose(pc.coords[0, 0, 0], 2.0 * math.sqrt(1 + (2 ** 2 + 1 ** 2) / f_px ** 2), rtol=1e-6)
    with pytest.raises(InputError, match=r"light distance: 15 pixel\(s\).*max_distance_m >= 12"):
        psf_coords(CAMERA, np.full((3, 5), 12.0), db)


def test_a_database_of_another_space_is_refused():
    db = space_database("volume", ("coc_radius_px",), ((0.0, 10.0),), ["rotation"])
    with pytest.raises(InputError, match=r"'volume' has PSF coordinates \['coc_radius_px'\].*\['distance_m'\]"):
        psf_coords(CAMERA, np.ones((2, 2)), db)
