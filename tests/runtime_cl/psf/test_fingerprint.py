"""A database refuses an input whose camera header disagrees with what it was traced for."""
import dataclasses

import numpy as np
import pytest
from cl_reference import random_database

from runtime_cl.errors import InputError
from runtime_cl.psf.fingerprint import check_header

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0}
IRIS = {"blades": 6, "rotation_deg": 0.0, "rounding": 0.0}
PINHOLE = {"lens": "pinhole", "fov_x_deg": 40.0}
FOG = {"sigma_t": 0.25, "albedo": [0.9, 0.9, 0.85], "g": 0.6}


def _db(fingerprint):
    db = random_database(np.random.default_rng(0))
    return dataclasses.replace(db, params=dict(db.params, fingerprint=fingerprint))


def test_a_matching_header_passes():
    check_header(_db({"aperture": None}), THIN)
    check_header(_db({"aperture": IRIS}), dict(THIN, aperture=dict(IRIS)))
    check_header(_db({"focal_length_mm": 49.7, "focus_distance_m": 3.0}), dict(THIN, focal_length_mm=49.9))
    check_header(random_database(np.random.default_rng(0)), dict(THIN, aperture={"blades": 5}))  # unrecorded
    check_header(_db({"medium": FOG, "fov_x_deg": 40.0}), dict(PINHOLE, medium=dict(FOG)))


@pytest.mark.parametrize("fingerprint, header, said", [
    ({"aperture": None}, dict(THIN, aperture=IRIS), "aperture = {'blades': 6"),
    ({"aperture": {"shape": "star"}}, THIN, "aperture = None, but the 'simple_lens' database was traced for "
                                            "aperture = {'shape': 'star'}"),
    ({"aperture": IRIS}, dict(THIN, aperture=dict(IRIS, blades=5)), "'blades': 5"),
    ({"focal_length_mm": 49.7}, dict(THIN, focal_length_mm=85.0), "focal_length_mm = 85.0"),
    ({"medium": FOG}, PINHOLE, "medium = None, but the 'simple_lens' database was traced for medium = {"),
    ({"medium": FOG}, dict(PINHOLE, medium=dict(FOG, sigma_t=0.5)), "'sigma_t': 0.5"),
    ({"medium": FOG}, dict(PINHOLE, medium=dict(FOG, albedo=[0.9, 0.9, 0.9])), "'albedo': [0.9, 0.9, 0.9]"),
])
def test_a_disagreeing_header_is_refused_naming_both(fingerprint, header, said):
    with pytest.raises(InputError) as e:
        check_header(_db(fingerprint), header, "in.exr camera")
    msg = str(e.value)
    assert msg.startswith("in.exr camera: ") and said in msg and "splatlab precompute" in msg


@pytest.mark.parametrize("medium", [{"sigma_t": -1, "albedo": [1, 1, 1], "g": 0}, {"sigma_t": 1, "albedo": [1, 1], "g": 0},
                                    {"sigma_t": 1, "albedo": [1, 1, 1], "g": 1.0}, {"sigma_t": 1}, "fog"])
def test_a_bad_header_medium_is_refused(medium):
    from runtime_cl.camera import from_header

    with pytest.raises(InputError, match=r"in.exr camera: medium = .*sigma_t"):
        from_header(dict(PINHOLE, medium=medium), "in.exr camera")
