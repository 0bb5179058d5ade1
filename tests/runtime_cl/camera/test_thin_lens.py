"""Thin-lens CoC (numpy mirror) against first principles."""
import math

import numpy as np
import pytest

from runtime_cl.errors import InputError
from runtime_cl.camera.thin_lens import ThinLens

LENS = ThinLens(focal_length_mm=50, f_number=2.0, focus_distance_m=3.0, sensor_width_mm=36)


def test_in_focus_is_zero_and_sign_convention():
    r = LENS.coc_radius_px(np.array([3.0, 6.0, 1.5]), 1024)
    assert r[0] == 0 and r[1] > 0 and r[2] < 0


def test_matches_textbook_coc_diameter():
    # c = A |S2 - S1| / S2 * f / (S1 - f), A = f / N (aperture diameter), on the sensor
    f, n, s1, s2 = 0.05, 2.0, 3.0, 7.0
    c = (f / n) * abs(s2 - s1) / s2 * f / (s1 - f)
    px = c / 0.036 * 1024
    assert LENS.coc_radius_px(s2, 1024) == pytest.approx(px / 2, rel=1e-12)


def test_infinity_is_the_limit():
    far = LENS.coc_radius_px(np.inf, 1000)
    assert far == pytest.approx(LENS.coc_scale_px(1000) / 3.0)
    assert LENS.coc_radius_px(1e12, 1000) == pytest.approx(far)


def test_fov_matches_sensor_at_image_distance():
    v = LENS.image_distance_m
    assert 1 / 0.05 == pytest.approx(1 / 3.0 + 1 / v)
    assert math.tan(math.radians(LENS.fov_x_deg()) / 2) == pytest.approx(0.018 / v)


@pytest.mark.parametrize("z", [0.0, -1.0, float("nan")])
def test_bad_depth(z):
    with pytest.raises(InputError, match="depth Z"):
        LENS.coc_radius_px(np.array([1.0, z]), 64)


@pytest.mark.parametrize("kw,match", [({"f_number": -2}, "f_number"), ({"focus_distance_m": 0.04}, "cannot focus"),
                                      ({"focal_length_mm": float("nan")}, "focal_length_mm")])
def test_bad_lens(kw, match):
    args = dict(focal_length_mm=50, f_number=2.0, focus_distance_m=3.0)
    args.update(kw)
    with pytest.raises(InputError, match=match):
        ThinLens(**args)


def test_json_roundtrip_and_unknown_keys():
    assert ThinLens.from_json(LENS.to_json()) == LENS
    with pytest.raises(InputError, match=r"unknown key\(s\) \['fstop'\]"):
        ThinLens.from_json({**LENS.to_json(), "fstop": 2}, source="x.exr header splatlab.camera")
