"""Reconstruction of a stochastic image through a medium: the input has no medium (as the labelled
input), so the stochastic pass adds it with the volume PSFs and their far field, as the plain pass does."""
import numpy as np
import pytest
from medium_databases import far_database

from runtime_cl.camera.pinhole import Pinhole
from runtime_cl.coords.maps import attenuates
from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.passes import run_pass


def _frame(rng, h=20, w=24, channels=3):
    # a pinhole: the lens samples move nothing (nor do sub-pixel positions, channels = 5)
    samples = rng.random((h, w, channels)).astype(np.float32)
    return Frame(rng.random((h, w, 3)).astype(np.float32), rng.uniform(1.2, 2.4, (h, w)).astype(np.float32),
                 samples=samples)


@pytest.mark.parametrize("channels", [3, 5])
@pytest.mark.parametrize("name, plain", [("stochastic_spreadlets", "spreadlets"), ("stochastic_splat", "splat")])
def test_a_still_pinhole_through_fog_is_the_plain_render(name, plain, channels):
    """Every sample of a still pinhole re-centres onto its own pixel, so the reconstruction is the
    plain pass's fog, far field included, and darker than the input where the medium absorbs."""
    rng = np.random.default_rng(7)
    near, far = far_database(rng, model="volume", psf_resolution=15, radius=7), far_database(rng, hole=5)
    frame, camera = _frame(rng, channels=channels), Pinhole(fov_deg=40.0)
    got, _ = run_pass(name, frame, camera, near, far_field=far)
    want, _ = run_pass(plain, frame, camera, near, far_field=far)
    without, _ = run_pass(name, frame, camera, near)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6 * want.max())
    assert np.all(got >= without - 1e-6) and got.sum() > without.sum() * 1.01   # the far field's halos


def test_normalising_a_medium_is_refused():
    assert attenuates("volume") and attenuates("volume_box") and not attenuates("simple_lens")
    rng = np.random.default_rng(8)
    near = far_database(rng, model="volume", psf_resolution=15, radius=7)
    with pytest.raises(InputError, match=r"normalize = True: a 'volume' database's PSFs carry the medium's loss.*"
                                         r"give normalize = False"):
        run_pass("stochastic_spreadlets", _frame(rng), Pinhole(fov_deg=40.0), near, normalize=True)
