"""``splatlab bench thick_layered``'s pieces that run without a reference: the paraxial thin lens it
compares with, and the scenes it refuses before rendering anything."""
import numpy as np
import pytest

from lab.bench.thick_layered import _crops, bench_thick_layered, paraxial_thin_lens
from lab.cameras.thick import ThickCamera
from lab.errors import UserError
from lab.paths import SCENES


def test_the_thin_lens_has_the_thick_lenses_paraxial_coc():
    """Equal CoC scale (px per dioptre) at the width it is built for and any other: the f-number
    scales the CoC and nothing else; focal length, focus and sensor are the thick lens's."""
    cam = ThickCamera(model="thick", position=(0.0, 0.0, 0.0), look_at=(0.0, 0.0, 1.0), lens="singlet",
                      focus_distance_m=1.5, sensor_width_mm=24.0).runtime_camera()
    thin = paraxial_thin_lens(cam, 400)
    for width in (400, 96):
        assert thin.coc_scale_px(width) == pytest.approx(cam.coc_scale_px(width), rel=1e-9)
    assert thin.focus_distance_m == cam.focus_distance_m and thin.focal_length_mm == cam.focal_length_mm
    assert thin.coc_radius_px(0.5, 400) == pytest.approx(cam.coc_radius_px(0.5, 400), rel=1e-9)


def test_corner_crops_side_by_side():
    img = np.arange(20 * 30 * 3, dtype=np.float32).reshape(20, 30, 3)
    strip = _crops(img, [(0, 0, 4), (16, 26, 4)], zoom=2)
    assert strip.shape == (8, 16, 3)
    np.testing.assert_array_equal(strip[::2, 8::2], img[16:20, 26:30])


@pytest.mark.parametrize("scene, needle", [("foreground.toml", "camera model 'thin'"),
                                           ("tiny_rain.toml", "runs no layered pass")])
def test_scenes_it_cannot_bench_are_refused_before_rendering(scene, needle, tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path))
    with pytest.raises(UserError, match=needle):
        bench_thick_layered(SCENES / scene, repeats=1)
    assert not any(tmp_path.iterdir())          # nothing rendered
