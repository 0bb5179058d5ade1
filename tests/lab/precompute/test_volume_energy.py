"""A render through an absorbing medium darkens as Beer-Lambert says: the volume database keeps
each PSF's energy (sparsified normalised, then scaled), and the runtime draws it."""
import math

import numpy as np
import pytest

import runtime_cl
from lab.precompute import precompute
from lab.psf_tracing.models.volume import Volume, VolumeConfig

SIGMA = 0.9


@pytest.mark.parametrize("albedo", [(0.0, 0.0, 0.0), (1.0, 1.0, 0.9)])
def test_a_render_through_the_medium_darkens_like_its_psfs(cache, albedo):
    model = Volume(VolumeConfig(albedo=albedo, psf_resolution=33, samples=6, rays_per_psf=2 ** 19,
                                min_distance_m=1.0, max_distance_m=3.0))
    db = runtime_cl.load_database(precompute(model, progress=False).path, expect_model="volume")
    energy = np.asarray(db.stats["energy"])
    assert energy.shape == (db.n_samples,) and np.all(energy > 0) and np.all(energy < 1)
    h, w, d = 48, 48, 2.0
    camera = runtime_cl.ThinLens(50.0, 2.0, 10.0)
    f_px = camera.image_distance_m * w / 0.036
    yy, xx = np.mgrid[:h, :w] + 0.5 - np.array([h, w])[:, None, None] / 2
    depth = d / np.sqrt(1.0 + (xx ** 2 + yy ** 2) / f_px ** 2)   # every pixel sees a point 2 m away
    image, _ = runtime_cl.render(np.ones((h, w, 3), np.float32), depth, camera, db, method="splat")
    centre = image[16:32, 16:32].mean(axis=(0, 1))                # the halo of the border stays in
    # the cell holding 2 m stores its PSF pre-filtered over its box [lo, hi] of distances
    box = model.boxes[int(db.grid.index(np.array([[d]]))[0])]
    lo, hi = box.lo[0], box.hi[0]
    beer_lambert = (math.exp(-SIGMA * lo) - math.exp(-SIGMA * hi)) / (SIGMA * (hi - lo))
    assert lo <= d <= hi
    if albedo == (0.0, 0.0, 0.0):
        # every photon that arrives is unscattered: the image is the input times exp(-sigma_t d)
        np.testing.assert_allclose(centre, beer_lambert, rtol=0.01)
    else:
        assert np.all(centre > beer_lambert * 1.05) and np.all(centre < 0.95)
        assert centre[2] < centre[0]                               # the blue albedo 0.9
