"""Sellmeier glass catalog against Schott's published n_d and Abbe numbers."""
import pytest

from lab.errors import UserError
from lab.optics.glass import (GLASSES, LINE_C_NM, LINE_D_NM, LINE_F_NM, abbe_number, get_glass,
                              glass_names)


def test_nbk7_index_and_abbe_number_from_its_sellmeier_coefficients():
    bk7 = get_glass("N-BK7")
    assert bk7.index(LINE_D_NM) == pytest.approx(1.5168, abs=5e-5)
    assert abbe_number(bk7) == pytest.approx(64.17, abs=0.05)


@pytest.mark.parametrize("name", [n for n in GLASSES if n != "air"])
def test_every_glass_matches_its_data_sheet(name):
    g = get_glass(name)
    assert g.index(LINE_D_NM) == pytest.approx(g.nd, abs=5e-5)
    assert abbe_number(g) == pytest.approx(g.vd, abs=0.05)


def test_catalog_has_a_crown_and_dense_flints():
    assert "N-BK7" in GLASSES and "N-SF11" in GLASSES
    assert get_glass("N-SF11").index(LINE_D_NM) > 1.78 and abbe_number(get_glass("N-SF11")) < 30


@pytest.mark.parametrize("name", ["N-BK7", "F2", "N-SF10", "N-SF11"])
def test_normal_dispersion_blue_bends_more(name):
    n = get_glass(name).index([475.0, 510.0, 650.0])
    assert n[0] > n[1] > n[2] > 1.0


def test_air_is_one_everywhere():
    air = get_glass("air")
    assert air.index(LINE_F_NM) == air.index(LINE_C_NM) == 1.0 and air.is_air


def test_unknown_glass_lists_the_catalog():
    with pytest.raises(UserError) as e:
        get_glass("BK-7")
    assert "'BK-7'" in str(e.value) and all(n in str(e.value) for n in glass_names())


@pytest.mark.parametrize("nm", [100.0, 5000.0, float("nan")])
def test_wavelength_outside_the_fit_is_an_error(nm):
    with pytest.raises(UserError, match="wavelength_nm"):
        get_glass("N-BK7").index(nm)
