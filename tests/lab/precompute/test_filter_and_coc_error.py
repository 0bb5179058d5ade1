"""Two checks that would catch a wrong figure (issue 14), on a real traced ``simple_lens``
database (the settings of test_runtime_matches_brute_force):

- the Filter method (a gather) against a brute-force numpy gather of the same database;
- the spreadlet render against the brute-force scatter, with bounds tight enough that a 2 %
  error in the runtime's CoC fails them: the test runs the check with deliberately scaled
  cameras (aperture x 0.95, 0.98, 1.02, 1.05: the CoC scales with the aperture) and asserts
  each fails while the true camera passes.
"""
import dataclasses

import numpy as np
import pytest
from cl_reference import filter_image, splat_image
from skimage.metrics import structural_similarity

import runtime_cl
from lab.precompute import precompute
from lab.psf_tracing.models import load_model
from runtime_cl.coords.maps import psf_coords

H, W = 24, 32
CAMERA = runtime_cl.ThinLens(50.0, 0.12, 2.0, 36.0)     # CoC up to 27 px over the ramp below
CONFIG = {"max_coc_px": 30.0, "samples": 8, "psf_resolution": 69, "rays_per_pixel": 4096,
          "rays_per_psf": 2 ** 18, "rays_per_launch": 2 ** 18}
# Bounds for the true camera. Measured: SSIM 0.99983, mean |error| 0.31 % of the mean (the
# sparsifier's loss on these PSFs). A CoC 2 % off gives SSIM 0.992-0.998 and 2.2-4.2 %.
SSIM_MIN = 0.999
MEAN_ERROR_MAX = 0.01


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SPLATLAB_CACHE", str(tmp_path_factory.mktemp("cache")))
        db = runtime_cl.load_database(precompute(load_model("simple_lens", CONFIG), progress=False).path,
                                      expect_model="simple_lens")
    rng = np.random.default_rng(0)
    colour = rng.random((H, W, 3)).astype(np.float32)
    y, x = np.mgrid[:H, :W]
    depth = 0.3 * 2.0 ** ((x + y) / (H + W - 2))          # 0.3 .. 0.6 m: CoC 13 .. 27 px
    return db, colour, depth


def _passes(ours, brute):
    ssim = structural_similarity(ours, brute, data_range=float(brute.max()), channel_axis=2)
    mean_error = float(np.abs(ours - brute).mean() / np.abs(brute).mean())
    return ssim >= SSIM_MIN and mean_error <= MEAN_ERROR_MAX, (ssim, mean_error)


def test_filter_matches_a_brute_force_gather(setup):
    """out(x) = sum_o psf_x(o) in(x - o) in float64 numpy; the OpenCL gather sums in float32:
    1e-5 of the largest value (measured 1.2e-6)."""
    db, colour, depth = setup
    coords = psf_coords(CAMERA, depth, db).coords
    want = filter_image(db, colour, coords)
    got, timing = runtime_cl.render(colour, depth, CAMERA, db, method="filter")
    assert np.abs(got - want).max() <= 1e-5 * want.max()
    assert timing.counts["pixels"] == H * W


@pytest.mark.parametrize("scale", [1.0, 0.95, 0.98, 1.02, 1.05])
def test_a_two_percent_coc_error_fails_the_check(setup, scale):
    db, colour, depth = setup
    brute = splat_image(db, colour, psf_coords(CAMERA, depth, db).coords)[..., :3]
    camera = dataclasses.replace(CAMERA, f_number=CAMERA.f_number / scale)     # CoC x scale
    assert np.abs(camera.coc_radius_px(depth, W) / CAMERA.coc_radius_px(depth, W) - scale).max() < 1e-12
    ours, _ = runtime_cl.render(colour, depth, camera, db)
    ok, figures = _passes(ours[..., :3], brute)
    assert ok == (scale == 1.0), figures
