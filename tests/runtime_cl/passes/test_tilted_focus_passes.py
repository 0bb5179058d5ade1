"""Every thin-lens pass honours a per-pixel focus (tilted sensor, expressive surface): a surface on
the focal plane renders sharp, the same surface through the untilted lens does not, and the blur of
a point grows with its distance from the focal surface."""
import numpy as np
import pytest

import runtime_cl
from runtime_cl.camera.focal_surface import scheimpflug_tilt
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.psf.synthetic import disc_database

H, W = 36, 48
# 50 mm f/0.25 (blur visible at 48 px), the plane leaning back and sideways (camera space, x right,
# y up), 0.3 to 0.7 m away.
FOCUS, TILT = scheimpflug_tilt([0.3, -0.45, 0.84], 0.4, 0.05)
TILTED = ThinLens(50.0, 0.25, FOCUS, sensor_tilt_deg=TILT)
FLAT = ThinLens(50.0, 0.25, FOCUS)
METHODS = [("spreadlets", {}), ("splat", {}), ("filter", {}), ("polygon", {"aperture": "hexadecagon"}),
           ("layered", {"rays": 32})]


@pytest.fixture(scope="module")
def on_plane():
    """A textured surface lying on the tilted focal plane, and a database wide enough for the flat lens."""
    rng = np.random.default_rng(11)
    depth = 1.0 / TILTED.inverse_focus_map(H, W)
    rgb = rng.random((H, W, 3)).astype(np.float32)
    r_max = float(np.ceil(np.abs(FLAT.coc_radius_px(depth, W)).max())) + 1
    return rgb, depth, disc_database(r_max, samples=8)


def render(method, options, rgb, depth, camera, db):
    return runtime_cl.render(rgb, depth, camera, None if method in ("polygon", "layered") else db,
                             method=method, **options)[0][..., :3]


@pytest.mark.parametrize("method, options", METHODS)
def test_a_surface_on_the_focal_plane_is_sharp(on_plane, method, options):
    rgb, depth, db = on_plane
    assert np.abs(FLAT.coc_radius_px(depth, W)).max() > 3.0      # untilted, the surface would blur
    sharp = render(method, options, rgb, depth, TILTED, db)
    blurred = render(method, options, rgb, depth, FLAT, db)
    # 2e-3: the spreadlet passes' float32 Laplacian integration of an image of values up to 1
    np.testing.assert_allclose(sharp, rgb, atol=2e-3)
    assert np.abs(blurred - rgb).mean() > 0.05


@pytest.mark.parametrize("method, options", [m for m in METHODS if m[0] != "filter"])
def test_blur_grows_with_the_distance_from_the_surface(method, options):
    """A bright point at pixel p, at depths stepping away from the pixel's own focus (in 1/z): its
    spread (second moment) grows monotonically; at the focus it stays in its pixel. An expressive
    surface (constraints only, no lens focus) and the tilted lens alike."""
    surface = ThinLens(50.0, 0.25, 0.5, focal_surface={"points": [[10, 10, 0.4], [40, 8, 0.7], [24, 30, 0.5]],
                                                      "beta": 2, "dof_extent": 1.5})
    for camera in (TILTED, surface):
        x, y = 20, 15
        w_f = camera.inverse_focus_map(H, W)[y, x]
        spreads = []
        for coc in (0.0, 1.5, 3.0, 5.0):                    # px, behind the focus
            depth = np.full((H, W), 1.0 / (w_f - coc / camera.coc_scale_px(W)))
            rgb = np.zeros((H, W, 3), np.float32)
            rgb[y, x] = 50.0
            db = disc_database(float(np.ceil(np.abs(camera.coc_radius_px(depth, W)).max())) + 2, samples=8)
            out = render(method, dict(options, rays=256) if method == "layered" else options, rgb, depth, camera, db)
            lum = np.clip(out[..., 0], 0, None)
            ys, xs = np.mgrid[0:H, 0:W]
            spreads.append(float((lum * ((xs - x) ** 2 + (ys - y) ** 2)).sum() / lum.sum()))
        assert spreads[0] < 0.05, (method, spreads)                       # in focus: its own pixel
        assert all(b > a + 0.2 for a, b in zip(spreads, spreads[1:])), (method, spreads)
