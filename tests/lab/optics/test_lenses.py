"""The built-in lenses are what lab/optics/lenses.py says they are: focal length, f-number, and
the achromat's small axial colour."""
import pytest

from lab.optics.lens_camera import ThickLensCamera
from lab.optics.lenses import LENSES, lens_names
from lab.optics.thick_lens import LensSystem

D_NM = 587.5618


@pytest.mark.parametrize("name, efl, f_number", [("singlet", 49.7, 2.8), ("achromat", 49.4, 3.1)])
def test_focal_length_and_f_number(name, efl, f_number):
    lens = LensSystem(LENSES[name])
    assert lens.effective_focal_length_mm(D_NM) == pytest.approx(efl, abs=0.05)
    assert lens.effective_focal_length_mm(D_NM) / (2 * lens.entrance_pupil(D_NM)[1]) == pytest.approx(f_number, abs=0.05)
    for focus_m in (0.5, 2.0, 10.0):                  # every built-in lens focuses over a scene's range
        ThickLensCamera.focused(lens, focus_m, (650.0, 510.0, 475.0), D_NM, 1024, 36.0)


def test_the_achromat_has_a_fraction_of_the_singlets_axial_colour():
    def axial_colour(name):
        lens = LensSystem(LENSES[name])
        return lens.back_focal_distance_mm(650.0) - lens.back_focal_distance_mm(475.0)

    assert axial_colour("singlet") == pytest.approx(0.80, abs=0.01)
    assert 0 < axial_colour("achromat") < axial_colour("singlet") / 6
    assert lens_names() == ["achromat", "singlet"]
