"""volume_far: the halo beyond the volume PSF's window, in coarse pixels, with the window left out.
Together the two count every crossing once: checked against one wide full-resolution trace."""
import numpy as np
import pytest

from lab.config import from_table
from lab.errors import UserError
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.volume import Volume, VolumeConfig
from lab.psf_tracing.models.volume_far import VolumeFar, VolumeFarConfig

MEDIUM = dict(medium_density=0.5, g=0.6, albedo=(0.9, 0.9, 0.8), width_px=64, focal_length_mm=30.0,
              min_distance_m=1.0, max_distance_m=3.0)


def test_registered_with_its_own_defaults():
    m = load_model("volume_far", {})
    assert get_model("volume_far") is VolumeFar and m.bins() == (8, 125)
    assert m.grid.size >= 16 and m.symmetries == ("rotation",) and m.channels == 3
    assert Volume(VolumeConfig()).bins() == (1, -1)


@pytest.mark.parametrize("table, match", [
    ({"pixel_scale": 1}, "pixel_scale = 1: .*2 or more"),
    ({"hole_half_px": -1}, "hole_half_px = -1"),
    ({"psf_resolution": 21, "pixel_scale": 4, "hole_half_px": 40}, "hole_half_px = 40: .*reaches only 32"),
])
def test_bad_binning_is_refused(table, match):
    with pytest.raises(UserError, match=match):
        from_table(VolumeFarConfig, table, "[psf.volume_far]")


def test_near_and_far_together_are_one_wide_trace():
    """A 33 px volume window (kept half-width 14) plus the far field in 5 x 5 px bins (an odd
    scale: bin j holds whole pixels 5j-2 .. 5j+2) over +-72 px, against one 149 px
    full-resolution trace (kept +-72 px) binned 5 x 5: the same energy, and the same halo in the
    bins outside the window, within Monte Carlo noise."""
    d, n = 1.5, 2 ** 23
    near = Volume(VolumeConfig(psf_resolution=33, **MEDIUM)).trace_box((d,), (d,), n, seed=1)
    far = VolumeFar(VolumeFarConfig(psf_resolution=33, pixel_scale=5, hole_half_px=14, **MEDIUM))
    far = far.trace_box((d,), (d,), n, seed=2)
    wide = Volume(VolumeConfig(psf_resolution=149, **MEDIUM)).trace_box((d,), (d,), n, seed=3)
    per = n / 3.0
    e_near, e_far = near.counts.sum(axis=(0, 1)) / per, far.counts.sum(axis=(0, 1)) / per
    e_wide = wide.counts.sum(axis=(0, 1)) / per
    np.testing.assert_allclose(e_near + e_far, e_wide, rtol=0.01)
    assert np.all(e_far > 0.05)  # the far field holds a real part of the light
    w = wide.counts[2:-2, 2:-2].astype(float).reshape(29, 5, 29, 5, 3).sum(axis=(1, 3))
    f = far.counts[2:-2, 2:-2].astype(float)            # bins j = -14 .. 14
    j = np.abs(np.arange(-14, 15))
    ring = (j[:, None] > 3) | (j[None, :] > 3)          # bins |j| <= 3 share pixels with the window
    rel = np.abs(w[ring] - f[ring]).sum() / w[ring].sum()
    noise = np.sqrt(w[ring]).sum() / w[ring].sum()      # the L1 a Poisson difference of this size has
    assert rel < 2 * noise + 0.005, (rel, noise)
    assert f[~ring].sum() < 0.3 * f.sum()              # the window's pixels are left out
