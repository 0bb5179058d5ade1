"""Linear motion: centred displacement in image axes, and the thin lens's chief-ray shift it stands for."""
import numpy as np
import pytest
from drjit.llvm import Array2f, Float

from lab.errors import UserError
from lab.optics.motion import LinearMotion, chief_ray_shift_px
from lab.optics.thin_lens import ThinLens


@pytest.mark.parametrize("deg, unit", [(0.0, (1.0, 0.0)), (90.0, (0.0, -1.0)), (180.0, (-1.0, 0.0)),
                                       (45.0, (0.7071068, -0.7071068))])
def test_offset_is_centred_and_along_the_direction(deg, unit):
    m = LinearMotion(deg)
    t = np.array([0.0, 0.25, 0.5, 0.75, 0.999], np.float32)
    off = m.offset_px(Float(t), Float(np.full(5, 40.0, np.float32)))
    got = np.stack([off.x.numpy(), off.y.numpy()], axis=1)
    want = (t[:, None] - 0.5) * 40.0 * np.array(unit)[None, :]
    np.testing.assert_allclose(got, want, atol=1e-4)
    np.testing.assert_allclose(np.stack(m.offset_px_np(t, 40.0), axis=1), want, atol=1e-5)
    assert got[2] == pytest.approx([0.0, 0.0], abs=1e-6)  # mid-shutter: no displacement


def test_bad_direction():
    for bad in (float("inf"), "up", True):
        with pytest.raises(UserError, match="motion_direction_deg"):
            LinearMotion(bad)


@pytest.mark.parametrize("inv_depth", [1 / 0.7, 1 / 2.0, 1 / 25.0])
def test_chief_ray_shift_is_what_the_thin_lens_does_to_every_lens_ray(inv_depth):
    """Moving the object laterally shifts the sensor hit of every lens point by the same amount:
    motion and defocus add, so image-space motion is exact for lateral motion."""
    lens, width = ThinLens(50, 2.0, 2.0, 36), 1920
    rng = np.random.default_rng(0)
    h = rng.uniform(-1, 1, (2, 64)) * lens.aperture_radius_m
    lateral = np.array([0.013, -0.004])  # metres, x right and y up
    still = lens.trace_to_sensor(Array2f(Float(h[0]), Float(h[1])), inv_depth)
    moved = lens.trace_to_sensor(Array2f(Float(h[0]), Float(h[1])), inv_depth,
                                 Array2f(*(float(v) for v in lateral * inv_depth)))
    # the object point at lateral X sits in direction X / z: field_slope = X inv_depth
    a = lens.sensor_to_image_px(still, width)
    b = lens.sensor_to_image_px(moved, width)
    shift = np.stack([(b.x - a.x).numpy(), -(b.y - a.y).numpy()])  # to x right, y up
    want = chief_ray_shift_px(lens, width, lateral, inv_depth)
    np.testing.assert_allclose(shift, np.repeat(want[:, None], 64, axis=1), rtol=2e-3, atol=2e-3)
    assert np.abs(want).max() > 1.0  # a shift that matters
