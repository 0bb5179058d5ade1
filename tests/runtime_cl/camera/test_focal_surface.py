"""Per-pixel focus (LES10 5): the tilted sensor's focal plane (Scheimpflug) against a numpy ray
trace of the tilted sensor through an ideal thin lens, the tilted CoC against the rays' spread,
the expressive surface's interpolation, and their bad input."""
import json
import math

import numpy as np
import pytest

from runtime_cl.camera import from_header
from runtime_cl.camera.focal_surface import expressive_inverse_focus, read_surface, scheimpflug_tilt
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError

H, W = 60, 80
F_MM = 50.0
# A plane leaning back and to the side (camera space: x right, y up, z forward; metres).
NORMAL, OFFSET = np.array([0.35, -0.5, 0.79]), 1.6


def tilted_lens(f_number=1.0):
    focus, tilt = scheimpflug_tilt(NORMAL, OFFSET, F_MM / 1000.0)
    return ThinLens(focal_length_mm=F_MM, f_number=f_number, focus_distance_m=focus, sensor_tilt_deg=tilt)


def pixel_direction(lens, x, y):
    """The chief ray (z = 1) of pixel (column x, row y from the top), from the pinhole geometry."""
    f_px = lens.image_distance_m * W / (lens.sensor_width_mm / 1000.0)
    return np.array([(x + 0.5 - W / 2) / f_px, (H / 2 - y - 0.5) / f_px, 1.0])


def trace(lens, x, y, lens_point):
    """A ray of pixel (x, y) through ``lens_point`` (on the lens plane z = 0), traced physically:
    the sensor point where the chief ray meets the tilted sensor plane, the thin lens bending the
    slope by -L / f. Returns (origin, direction with z = 1)."""
    gx, gy = (math.tan(math.radians(t)) for t in lens.sensor_tilt_deg)
    v = lens.image_distance_m
    # The sensor plane z = -(v + gx X + gy Y): a point q with normal m and offset -v.
    m = np.array([gx, gy, 1.0])
    d = pixel_direction(lens, x, y)
    t = -v / (m @ d)                     # the chief line t d (t < 0: behind the lens) meets it
    sensor = t * d
    assert sensor[2] < 0 and abs(m @ sensor + v) < 1e-12
    slope = (lens_point - sensor) / (lens_point[2] - sensor[2])
    return lens_point, slope - np.array([lens_point[0], lens_point[1], 0.0]) / (F_MM / 1000.0)


def test_the_map_is_the_fitted_plane():
    """w_f(p) = (n . d) / c at every pixel: the plane n . X = c is in focus."""
    lens = tilted_lens()
    got = lens.inverse_focus_map(H, W)
    ys, xs = np.mgrid[0:H, 0:W]
    want = np.vectorize(lambda x, y: NORMAL @ pixel_direction(lens, x, y) / OFFSET)(xs, ys)
    np.testing.assert_allclose(got, want, rtol=1e-9)
    assert got.std() > 0.05 * got.mean()          # the focus really varies over the image


@pytest.mark.parametrize("pixel", [(0, 0), (79, 59), (40, 30), (10, 50)])
def test_rays_of_a_sensor_point_meet_on_the_plane(pixel):
    """Scheimpflug, by ray tracing: every ray of a tilted-sensor point passes through one point,
    which lies on the plane and at the depth the map gives."""
    lens = tilted_lens()
    a = lens.aperture_radius_m
    rays = [trace(lens, *pixel, np.array([a * math.cos(t), a * math.sin(t), 0.0])) for t in (0.3, 1.9, 4.0)]
    (o1, d1), (o2, d2), (o3, d3) = rays
    z = (o2[0] - o1[0]) / (d1[0] - d2[0]) if abs(d1[0] - d2[0]) > 1e-9 else (o2[1] - o1[1]) / (d1[1] - d2[1])
    points = [o + z * d for o, d in rays]
    np.testing.assert_allclose(points[0], points[1], atol=1e-9)
    np.testing.assert_allclose(points[0], points[2], atol=1e-9)
    assert NORMAL @ points[0] == pytest.approx(OFFSET, abs=1e-9)
    assert 1.0 / z == pytest.approx(lens.inverse_focus_map(H, W)[pixel[1], pixel[0]], rel=1e-9)


@pytest.mark.parametrize("depth", [0.6, 1.2, 3.0, 20.0])
def test_coc_is_the_spread_of_the_traced_rays(depth):
    """|coc_radius_px| at depth z is the radius of the circle the rim rays draw in the pinhole image
    at z; the sign: positive behind the pixel's own focus distance."""
    lens = tilted_lens()
    f_px = lens.focal_px(W)
    coc = lens.coc_radius_px(np.full((H, W), depth), W)
    for x, y in [(3, 4), (70, 20), (40, 55)]:
        d = pixel_direction(lens, x, y)
        radii = []
        for t in np.linspace(0, 2 * np.pi, 7, endpoint=False):
            o, s = trace(lens, x, y, lens.aperture_radius_m * np.array([math.cos(t), math.sin(t), 0.0]))
            hit = o + depth * s
            radii.append(np.hypot(*(hit[:2] / depth - d[:2])) * f_px)
        np.testing.assert_allclose(radii, abs(coc[y, x]), rtol=1e-9)
        in_focus = 1.0 / lens.inverse_focus_map(H, W)[y, x]
        assert np.sign(coc[y, x]) == np.sign(depth - in_focus)


def test_untilted_map_is_one_over_f_and_headers_round_trip():
    flat = ThinLens(F_MM, 2.0, 3.0)
    np.testing.assert_array_equal(flat.inverse_focus_map(4, 5), np.full((4, 5), 1 / 3.0))
    assert "sensor_tilt_deg" not in flat.to_json()          # old headers stay as they were
    lens = tilted_lens()
    data = json.loads(json.dumps(lens.to_json()))
    assert from_header(data) == lens and data["sensor_tilt_deg"] == list(lens.sensor_tilt_deg)
    surface = ThinLens(F_MM, 2.0, 3.0, focal_surface={"points": [[1, 2, 2.0]], "dof_extent": 2.0},
                       focus_points=((1, 2),))
    assert from_header(json.loads(json.dumps(surface.to_json()))) == surface


def test_per_pixel_focus_needs_the_depth_map():
    with pytest.raises(InputError, match=r"differs per pixel; give the \(H, 80\) depth map"):
        tilted_lens().coc_radius_px(2.0, W)


@pytest.mark.parametrize("normal, offset, needle", [
    ([0.3, 0.4, 0.8], 0.0, "passes through the lens, so it contains the view direction"),
    ([0.0, 1.0, 0.0], -1.5, "runs along the optical axis"),
    ([0.0, 0.6, -0.8], 2.0, "crosses it behind the camera"),
    ([0.0, 0.0, 1.0], 0.03, "passes through the lens"),
    ([0.0, -0.999, 0.04], -1.5, "crosses it behind the camera"),
])
def test_degenerate_planes_are_refused(normal, offset, needle):
    with pytest.raises(InputError, match=needle):
        scheimpflug_tilt(normal, offset, F_MM / 1000.0)


def test_a_ground_plane_far_below_the_axis_is_a_small_tilt():
    """The tilt-shift landscape: ground 1.5 m below, crossing the axis at 37.5 m: 1.9 degrees."""
    focus, tilt = scheimpflug_tilt([0.0, -0.999, 0.04], 1.5, F_MM / 1000.0)
    assert focus == pytest.approx(1.5 / 0.04 * math.hypot(0.999, 0.04) / math.hypot(0.999, 0.04))
    v = 1.0 / (1000.0 / F_MM - 1.0 / focus)
    assert tilt[0] == 0.0 and tilt[1] == pytest.approx(math.degrees(math.atan(v * 0.999 / 1.5)))


def test_a_tilt_along_the_view_direction_is_refused_in_the_header():
    data = dict(ThinLens(F_MM, 2.0, 3.0).to_json(), sensor_tilt_deg=[0.0, 75.0])
    with pytest.raises(InputError, match="sensor_tilt_deg = \\[0.0, 75.0\\].*along the view direction"):
        from_header(data, "in.exr camera")


def test_expressive_surface_interpolates_its_constraints():
    """Each constraint's pixel gets its depth exactly; constraints taken from a plane (in 1/z, affine
    in the pixel) give that plane everywhere (the MLS fits a plane per pixel)."""
    plane = lambda x, y: 0.5 + 0.01 * (x + 0.5) - 0.004 * (y + 0.5)    # noqa: E731  (1/z over pixels)
    pts = [[5, 7], [60, 10], [30, 50], [70, 55], [12, 40]]
    surface = read_surface({"points": [[x, y, 1.0 / plane(x, y)] for x, y in pts], "beta": 3})
    got = expressive_inverse_focus(H, W, surface)
    ys, xs = np.mgrid[0:H, 0:W]
    np.testing.assert_allclose(got, plane(xs, ys), rtol=1e-9)
    bumpy = read_surface({"points": [[5, 7, 1.0], [60, 10, 4.0], [30, 50, 2.0], [31, 50, 8.0]], "beta": 2})
    got = expressive_inverse_focus(H, W, bumpy)
    for x, y, z in bumpy["points"]:
        assert got[int(y), int(x)] == 1.0 / z


@pytest.mark.parametrize("surface, needle", [
    ({"points": []}, "give 1 to 256 constraints"),
    ({"points": [[1, 2, -3.0]]}, r"0 < depth <= 1e\+06 m"),
    ({"points": [[1, 2, 3e7]]}, r"30000000.0\]\]: give 1 to 256 constraints .* 0 < depth <= 1e\+06 m"),
    ({"points": [[1e9, 2, 3.0]]}, r"1000000000.0, 2, 3.0\]\]: give 1 to 256"),
    ({"points": [[1, 2, 3.0]], "beta": 20}, "beta = 20"),
    ({"points": [[1, 2, 3.0]], "dof_extent": 0}, "dof_extent = 0: .* must be 0.01 to 100"),
    ({"points": [[1, 2, 3.0]], "dof_extent": 1e3}, "dof_extent = 1000.0"),
    ({"points": [[1, 2, 3.0]], "alpha": [1, 2]}, r"one weight in \(0, 1e\+06\] per point"),
    ({"points": [[1, 2, 3.0]], "alpha": [1e9]}, r"alpha = \[1000000000.0\]"),
    ({"pts": [[1, 2, 3.0]]}, "focal_surface = "),
    ({"points": [[1, 2, 3.0]], "sharpness": 2}, r"focal_surface: unknown key\(s\) \['sharpness'\]; known keys are"),
])
def test_bad_focal_surface(surface, needle):
    with pytest.raises(InputError, match=needle):
        read_surface(surface)
