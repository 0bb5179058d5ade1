"""The shaped-aperture thin-lens sensor against the camera contract, as ``thinlens`` is checked.

Two small bright emitters, one far behind the focus plane and one in front of it, through a
5-blade iris rotated by 10 degrees (no symmetry hides a flip) and through the stylized heart
(point down: a turn shows): each must image to the aperture scaled to
``ThinLens.coc_radius_px``, centred on its pinhole projection, upright behind the focus plane
and turned by 180 degrees in front of it. The expected spot is the iris indicator
(``PolygonAperture.contains``) convolved with the emitter's own disc and the box pixel; the
radius that fits the render best must be the predicted one, and the 180-degree turned or
mirrored iris must fit clearly worse.
"""
import math

import numpy as np
import pytest
from scipy.signal import fftconvolve

from lab.optics.aperture import PolygonAperture, make_aperture
from lab.reference.mitsuba_scene import scene_dict
from lab.reference.render import render_pinhole, render_reference
from lab.scene import parse_scene

W, FINE, EMITTER_PX = 64, 8, 1.0
IRIS = {"blades": 5, "rotation_deg": 10.0}
POINTS = {"background": ((20.0, 20.0), 4.0, 1.0), "foreground": ((44.0, 44.0), 0.5, -1.0)}


def _render(aperture):
    cam = {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50.0,
           "aperture_radius_mm": 150.0, "focus_distance_m": 1.0, "sensor_width_mm": 36.0,
           "aperture": aperture}   # a huge aperture: spots of 10-14 px at 64 px
    base = {"scene": {"name": "iris", "resolution": [W, W]}, "camera": cam, "render": {"max_depth": 1}}
    lens = parse_scene({**base, "emitters": [{"type": "constant", "radiance": [0, 0, 0]}]},
                       "iris.toml").camera.thin_lens()
    k = W * lens.image_distance_m / (lens.sensor_width_mm / 1000)   # px per unit tangent
    shapes = [{"type": "sphere", "center": [(W / 2 - px) * z / k, (W / 2 - py) * z / k, z],
               "radius": EMITTER_PX * z / k, "emitter": {"radiance": [100.0, 100.0, 100.0]}}
              for (px, py), z, _ in POINTS.values()]
    scene = parse_scene({**base, "shapes": shapes}, "iris.toml")
    img = render_reference(scene, spp=4096, progress=False)[..., 0].astype(np.float64)
    return scene, lens, img


@pytest.fixture(scope="module")
def spots():
    return _render(IRIS)


@pytest.fixture(scope="module")
def heart_spots():
    return _render({"shape": "heart"})


def expected_spot(iris, centre, radius, sign):
    """Iris of circumradius ``radius`` px (turned by 180 degrees if ``sign`` < 0) * emitter disc * pixel."""
    fine = (np.arange(W * FINE) + 0.5) / FINE
    x, y = np.meshgrid(fine, fine)
    inside = iris.contains(sign * (x - centre[0]) / radius, -sign * (y - centre[1]) / radius)
    r = math.ceil(EMITTER_PX * FINE)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = (xx ** 2 + yy ** 2 <= (EMITTER_PX * FINE) ** 2).astype(float)
    blurred = fftconvolve(inside.astype(float), disc / disc.sum(), mode="same")
    return blurred.reshape(W, FINE, W, FINE).mean(axis=(1, 3))


def test_scene_dict_uses_the_polygon_sensor(spots):
    scene, lens, _ = spots
    sensor = scene_dict(scene, "scene")["sensor"]
    assert sensor["type"] == "splatlab_aperture_thinlens" and sensor["aperture"] == "polygon"
    assert (sensor["blades"], sensor["rotation_deg"]) == (5, 10.0)
    assert sensor["aperture_radius"] == pytest.approx(lens.aperture_radius_m)
    assert scene_dict(scene, "pinhole")["sensor"]["type"] == "perspective"


def _check_spot(rendered, name, aperture, mirrored=None):
    _, lens, img = rendered
    centre, z, sign = POINTS[name]
    ys, xs = np.mgrid[0:W, 0:W] + 0.5
    side = (xs + ys < W) if sign > 0 else (xs + ys > W)
    measured = np.where(side, img, 0.0)
    measured /= measured.sum()
    radius = abs(float(lens.coc_radius_px(z, W)))
    assert radius > 10 and np.sign(lens.coc_radius_px(z, W)) == sign

    def misfit(shape, r, s=sign):
        e = np.where(side, expected_spot(shape, centre, r, s), 0.0)
        return float(((measured - e / e.sum()) ** 2).sum())

    radii = radius + np.arange(-12, 13) * 0.125
    best = radii[np.argmin([misfit(aperture, r) for r in radii])]
    assert best == pytest.approx(radius, abs=0.25)
    at_prediction = misfit(aperture, radius)
    assert misfit(aperture, radius, -sign) > 2.5 * at_prediction       # not turned the other way
    if mirrored is not None:
        assert misfit(mirrored, radius) > 2.5 * at_prediction          # not mirrored (camera-space x)


@pytest.mark.parametrize("name", list(POINTS))
def test_spot_is_the_iris_at_the_thin_lens_coc(spots, name):
    _check_spot(spots, name, PolygonAperture(**IRIS),
                PolygonAperture(blades=5, rotation_deg=-IRIS["rotation_deg"]))


@pytest.mark.parametrize("name", list(POINTS))
def test_spot_is_the_stylized_heart_at_the_thin_lens_coc(heart_spots, name):
    scene = heart_spots[0]
    assert scene_dict(scene, "scene")["sensor"]["aperture"] == "heart"
    _check_spot(heart_spots, name, make_aperture("heart"))      # the heart is its own mirror image


def test_exposure_matches_the_pinhole(spots):
    """Weight 1 per ray: the iris spreads the emitters' light, it does not change how much arrives."""
    scene, _, img = spots
    pinhole = render_pinhole(scene, spp=256, progress=False)[..., 0]
    assert img.sum() == pytest.approx(float(pinhole.sum()), rel=0.03)
