"""What a scene decides of a PSF model's settings: the CoC range from its depths, and its aperture."""
import numpy as np
import pytest

from lab.errors import UserError
from lab.exr_io import LabelledImage
from lab.psf_settings import model_table

from test_plan import THIN, scene


def _image(depth_m):
    h, w = 8, 16
    return LabelledImage(np.zeros((h, w, 3), np.float32), np.ones((h, w), np.float32),
                         np.full((h, w), depth_m, np.float32), {})


def test_the_cocs_of_the_input_set_the_database_range():
    s = scene(THIN)
    lens = s.camera.thin_lens()
    table = model_table(s, "simple_lens", _image(0.5))
    needed = abs(float(lens.coc_radius_px(0.5, 16)))
    assert table["max_coc_px"] >= needed and table["max_coc_px"] % 8 == 0 and table["max_coc_px"] - needed < 8
    assert table["psf_resolution"] > 2 * table["max_coc_px"]
    assert model_table(s, "simple_lens", _image(0.5)) == table                # the same scene, the same key


@pytest.mark.parametrize("shape", ["star", "heart", "polygon"])
def test_a_table_that_contradicts_the_round_camera_is_an_error_naming_both(shape):
    s = scene(THIN, {"simple_lens": {"aperture": shape}})
    with pytest.raises(UserError) as e:
        model_table(s, "simple_lens", _image(0.5))
    msg = str(e.value)
    assert "p.toml [psf.simple_lens]" in msg and repr(shape) in msg and "aperture = 'circle'" in msg
    assert model_table(scene(THIN, {"simple_lens": {"aperture": "circle"}}), "simple_lens", _image(0.5))


def test_a_stylized_camera_sets_the_shape_and_no_fringes():
    s = scene(dict(THIN, aperture={"shape": "heart"}))
    table = model_table(s, "stylized", _image(0.5))
    assert table["aperture"] == "heart" and table["channel_scale"] == (1.0, 1.0, 1.0)
    with pytest.raises(UserError, match=r"\[psf.stylized\] aperture = 'star'.*aperture = 'heart'"):
        model_table(scene(dict(THIN, aperture={"shape": "heart"}), {"stylized": {"aperture": "star"}}),
                    "stylized", _image(0.5))
    with pytest.raises(UserError, match=r"channel_scale = \[1.0, 0.9, 0.8\]"):
        model_table(scene(dict(THIN, aperture={"shape": "heart"}), {"stylized": {"channel_scale": [1.0, 0.9, 0.8]}}),
                    "stylized", _image(0.5))


def test_a_fog_that_sees_the_sky_is_refused():
    from lab.scene import parse_scene

    s = parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                     "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "model": "pinhole", "fov_deg": 40},
                     "medium": {"sigma_t": 0.5}, "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]},
                    "f.toml")
    with pytest.raises(UserError, match=r"f.toml \[medium\].*128 pixel\(s\) see no surface"):
        model_table(s, "volume", _image(float("inf")))
    table = model_table(s, "volume", _image(2.0))
    assert table["medium_density"] == 0.5 and table["width_px"] == 16
    assert table["min_distance_m"] == 2.0 and 2.0 < table["max_distance_m"] <= 2.5


def test_the_far_field_completes_the_volume_window_across_the_frame():
    import dataclasses

    from lab.scene import parse_scene

    s = parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                     "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "model": "pinhole", "fov_deg": 40},
                     "medium": {"sigma_t": 0.5, "g": 0.3}, "psf": {"volume": {"psf_resolution": 9}},
                     "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    near, far = model_table(s, "volume", _image(2.0)), model_table(s, "volume_far", _image(2.0))
    for key in ("medium_density", "g", "albedo", "width_px", "focal_length_mm", "min_distance_m", "max_distance_m"):
        assert far[key] == near[key], key
    # the volume keeps +-2 px (9 // 2 - 2); 8 px PSF pixels reach 15 px in 2 of them, + 2 margin each side
    assert far["hole_half_px"] == 2 and far["pixel_scale"] == 8 and far["psf_resolution"] == 9

    def psf(**tables):
        return dataclasses.replace(s, psf={**s.psf, **tables})

    assert model_table(psf(volume_far={"pixel_scale": 3}), "volume_far", _image(2.0))["psf_resolution"] == 15
    with pytest.raises(UserError, match=r"\[psf.volume_far\] hole_half_px = 7: .*hole_half_px = 2"):
        model_table(psf(volume_far={"hole_half_px": 7}), "volume_far", _image(2.0))


def test_a_guard_banded_input_sets_the_lens_database_sensor():
    """A thick lens's PSFs depend on where a pixel lies on the sensor: with a guard band the
    input's sensor is wider than the scene's at the same pixel pitch, and the database is traced
    for the input's (the scene's width with the guarded pixel count put the margin's pixels at the
    wrong eccentricities, and the render's fingerprint check refused the pair)."""
    from dataclasses import replace

    from lab.paths import SCENES
    from lab.reference.guard_band import guarded_scene
    from lab.scene import load_scene

    scene = load_scene(SCENES / "tiny_rain.toml")
    guarded = guarded_scene(scene, 5)
    h, w = guarded.height, guarded.width
    image = LabelledImage(np.zeros((h, w, 3), np.float32), np.ones((h, w), np.float32),
                          np.full((h, w), 2.0, np.float32), guarded.camera.camera_json())
    table = model_table(scene, "physical_lens", image)
    assert table["width_px"] == w == scene.width + 10
    assert table["sensor_width_mm"] == pytest.approx(scene.camera.sensor_width_mm * w / scene.width)
    assert table["sensor_height_mm"] == pytest.approx(table["sensor_width_mm"] * h / w)
    plain = model_table(scene, "physical_lens", replace(image, camera={}))   # no header: the scene's sensor
    assert plain["sensor_width_mm"] == scene.camera.sensor_width_mm
