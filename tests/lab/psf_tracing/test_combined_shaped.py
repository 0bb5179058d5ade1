"""Combined with a shaped aperture (symmetry ``motion_angle``): the traced PSF is the aperture,
fixed in the frame, swept along the motion (against a brute-force numpy integral); the angle
bins; the runtime's bin and turn of every motion direction, rendered from a database of exact
PSFs."""
import math

import numpy as np
import pytest

from lab.psf_tracing.models import load_model
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.coords.defocus import combined_coords
from runtime_cl.frame import Frame
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.passes import run_pass
from runtime_cl.psf.database import DatabaseBuilder

from shaped_capsule import shaped_capsule_psf

R = 61
BASE = {"max_coc_px": 12.0, "max_motion_px": 32.0, "psf_resolution": R, "rays_per_psf": 2 ** 18,
        "rays_per_pixel": 64, "rays_per_launch": 2 ** 20}


@pytest.mark.parametrize("aperture, bins, period", [
    ({"aperture": "polygon", "aperture_blades": 6}, 6, 60.0),
    ({"aperture": "polygon", "aperture_blades": 7, "aperture_rotation_deg": 10.0}, 6, 360 / 7),
    ({"aperture": "star"}, 8, 72.0),
    ({"aperture": "heart"}, 36, 360.0),
])
def test_a_shaped_aperture_adds_the_motion_angle_in_bins_of_at_most_10_degrees(aperture, bins, period):
    m = load_model("combined", {**BASE, **aperture, "samples": 20})
    assert m.config.angle_bins == bins and m.symmetries == ("motion_angle", "coc_sign")
    g = m.grid
    assert g.ns == 3 and g.bins == bins and g.names[-1] == "motion_angle_deg"
    half = period / bins / 2
    assert g.ranges[-1] == pytest.approx((-half, period - half))   # bin 0 is centred on 0 degrees
    assert g.nested_size >= 20 and g.size == bins * g.nested_size


@pytest.mark.parametrize("blades, coc, direction", [(3, 8.0, 90.0), (3, 6.0, 37.0), (5, 7.0, 200.0)])
def test_the_traced_psf_sweeps_the_fixed_aperture_along_the_motion(blades, coc, direction):
    """The aperture's corners stay where the iris has them whatever the motion; the old rule
    (the capsule traced along +x and turned with the motion) turns them too, and is rejected."""
    m = load_model("combined", {**BASE, "aperture": "polygon", "aperture_blades": blades})
    point = [coc, 16.0, direction % m.aperture.turn_period_deg]
    psf = m.trace_box(point, point, n_rays=2 ** 21, seed=3).psf[..., 0].astype(np.float64)
    # coc > 0 in the model is |CoC| of a point in front of the focal plane: the aperture turned
    exact = shaped_capsule_psf(m.aperture, -coc, 16.0, point[2], R)
    turned = np.rot90(shaped_capsule_psf(m.aperture, -coc, 16.0, 0.0, R), 1) if direction == 90.0 else None
    assert np.abs(psf - exact).sum() < 0.06
    if turned is not None:
        assert np.abs(psf - turned).sum() > 0.3


def _bin_database(aperture_model, coc, length):
    """A binned ``combined`` database whose every cell of bin b holds the exact PSF (and its
    5-point Laplacian) of |CoC| ``coc`` and motion ``length`` along the bin's centre."""
    grid = aperture_model.grid
    params = {"config": {"max_coc_px": grid.ranges[0][1], "max_motion_px": grid.ranges[1][1]},
              "symmetries": ["motion_angle", "coc_sign"]}
    size = 41
    b = DatabaseBuilder("combined", params, grid, 1, size)
    for bin_ in range(grid.bins):
        lo, hi = grid.bin_range(bin_)
        psf = shaped_capsule_psf(aperture_model.aperture, -coc, length, (lo + hi) / 2, size).astype(np.float32)
        lap = laplacian5(np.pad(psf, 1))
        ys, xs = np.nonzero(lap)
        for _ in range(grid.nested_size):
            b.add(np.stack([xs - size // 2 - 1, ys - size // 2 - 1], 1), lap[ys, xs], psf,
                  stats={"sparsity": 0.5, "ssim": 1.0, "l1": 0.0})
    return b.build()


def test_the_runtime_turns_each_pixel_by_its_motion_minus_its_bins_centre():
    """Points moving in every direction, in front of and behind the focal plane, through a
    triangular iris: each is drawn as the exact sweep of the upright-or-turned triangle along its
    own motion. Directions on a bin centre plus a multiple of 120 degrees are turns by whole
    periods (exact); others turn the aperture by less than half a bin."""
    m = load_model("combined", {**BASE, "aperture": "polygon", "aperture_blades": 3, "angle_bins": 12,
                                "samples": 1})
    coc, length, width = 5.0, 12.0, 128
    db = _bin_database(m, coc, length)
    lens = ThinLens(focal_length_mm=85.0, f_number=0.5, focus_distance_m=2.0, sensor_width_mm=36.0)
    inv = np.linspace(1 / 200.0, 1 / 0.5, 400001)
    signed = lens.coc_radius_px(1.0 / inv, width)
    cases = [(0.0, -1), (130.0, -1), (250.0, 1), (-90.0, 1), (47.0, -1), (193.0, 1)]
    rgb = np.zeros((width, width, 1), np.float32)
    depth = np.full((width, width), 2.0)
    motion = np.zeros((width, width, 2))
    spots = [(24 + 40 * (i // 3), 24 + 40 * (i % 3)) for i in range(len(cases))]
    for (row, col), (phi, side) in zip(spots, cases):
        rgb[row, col] = 1.0
        depth[row, col] = 1.0 / inv[np.argmin(np.abs(signed - side * coc))]
        motion[row, col] = length * math.cos(math.radians(phi)), length * math.sin(math.radians(phi))
    coords = combined_coords(lens, depth, db, motion)
    out, _ = run_pass("spreadlets", Frame(rgb, depth, motion=motion), lens, db)
    k = 16
    for (row, col), (phi, side) in zip(spots, cases):
        drawn = out[row - k:row + k + 1, col - k:col + k + 1, 0].astype(np.float64)
        real = float(lens.coc_radius_px(np.array([depth[row, col]]), width)[0])
        assert abs(real - side * coc) < 0.01 and coords.coords[row, col, 2] == pytest.approx((phi + 5) % 120 - 5)
        exact = shaped_capsule_psf(m.aperture, real, length, phi, 2 * k + 1)
        # the old rule: the whole horizontal capsule turned by the motion angle
        whole = np.rot90(shaped_capsule_psf(m.aperture, real, length, 0.0, 2 * k + 1), 1) if phi == -90.0 else None
        on_centre = (phi + 5) % 10 == 5.0
        assert drawn.sum() == pytest.approx(1.0, abs=1e-3)
        assert np.abs(drawn - exact).sum() < (0.08 if on_centre else 0.12), (phi, np.abs(drawn - exact).sum())
        if whole is not None:
            assert np.abs(drawn - whole).sum() > 0.3   # 0.39 measured; the exact sweeps are within 0.05
