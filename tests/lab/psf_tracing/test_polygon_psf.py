"""Polygonal irises through SimpleLens: the traced PSF against the polygon indicator scaled to the
CoC (area, shape, the near side's 180-degree turn), the symmetry tag, config keys."""
import math

import numpy as np
import pytest

from lab.errors import UserError
from lab.optics.aperture import PolygonAperture
from lab.psf_tracing.models import load_model

R = 57
N_RAYS = 2 ** 20


def shape_reference(aperture, r, resolution=R, near=True, ss=16):
    """Pixel shares of the aperture scaled to CoC radius r (supersampled ss x ss per pixel), as the
    near side shows it: image offset (x right, y up) = -r * aperture point."""
    c = resolution // 2
    sub = (np.arange(resolution * ss) + 0.5) / ss - 0.5 - c  # pixel k spans [k - 1/2, k + 1/2)
    x, y_up = sub[None, :], -sub[:, None]
    sign = -1.0 if near else 1.0
    w = aperture.weight(sign * x / r, sign * y_up / r) if hasattr(aperture, "weight") else \
        aperture.contains(sign * x / r, sign * y_up / r).astype(np.float64)
    w = w.reshape(resolution, ss, resolution, ss).sum(axis=(1, 3))
    return w / w.sum()


def expected_l1_noise(ref, n):
    """E|counts / n - p| summed over pixels for multinomial counts (normal approximation)."""
    return float(np.sum(np.sqrt(2 / np.pi * ref * (1 - ref) / n)))


def trace(table, r, seed=1):
    m = load_model("simple_lens", {"max_coc_px": 26.0, "psf_resolution": R, **table})
    return m, m.trace_box([r], [r], n_rays=N_RAYS, seed=seed).psf[..., 0].astype(np.float64)


@pytest.mark.parametrize("blades, rotation, rounding", [(6, 0.0, 0.0), (3, 0.0, 0.0), (5, 20.0, 0.35)])
def test_traced_polygon_matches_the_scaled_indicator(blades, rotation, rounding):
    r = 22.5
    m, psf = trace({"aperture": "polygon", "aperture_blades": blades, "aperture_rotation_deg": rotation,
                    "aperture_rounding": rounding}, r)
    ref = shape_reference(m.aperture, r)
    noise = expected_l1_noise(ref, N_RAYS)
    assert np.abs(psf - ref).sum() < 1.3 * noise + 0.005
    # the comparison is sharp enough to see the wrong orientation and a 2 % larger CoC
    upright = shape_reference(m.aperture, r, near=False)
    if blades % 2:
        assert np.abs(psf - upright).sum() > 5 * noise
    assert np.abs(psf - shape_reference(m.aperture, 1.02 * r)).sum() > 2 * noise


def test_hexagon_area_from_the_interior_level():
    """A uniform shape of area A r^2 puts 1 / (A r^2) into every fully covered pixel."""
    r = 24.0
    m, psf = trace({"aperture": "polygon", "aperture_blades": 6}, r)
    ref = shape_reference(m.aperture, r)
    interior = ref >= ref.max() * (1 - 1e-9)
    area = 1.0 / (r * r * psf[interior].mean())
    assert area == pytest.approx(3 * math.sqrt(3) / 2, rel=0.005)
    assert m.aperture.area == pytest.approx(3 * math.sqrt(3) / 2, rel=1e-12)


def test_symmetry_tags():
    assert load_model("simple_lens", {"max_coc_px": 5.0, "psf_resolution": 15}).symmetries == ("rotation",)
    m = load_model("simple_lens", {"max_coc_px": 5.0, "psf_resolution": 15, "aperture": "polygon"})
    assert m.symmetries == ("coc_sign",) and isinstance(m.aperture, PolygonAperture)
    assert m.aperture.blades == 6  # the default blade count


def test_every_model_lists_documented_symmetries_the_runtime_maps():
    from lab.psf_tracing.models import get_model, model_names
    from lab.psf_tracing.models.common import SYMMETRY_TAGS
    from runtime_cl.coords.maps import COORDINATE_MAPS
    from runtime_cl.psf.far_field import MODEL as FAR_FIELD

    for name in model_names():
        tags = get_model(name).symmetries
        if isinstance(tags, property):  # by aperture: simple_lens checked above, the others below
            continue
        assert set(tags) <= set(SYMMETRY_TAGS), name
        # the far field is drawn by FFT beside its volume database (runtime_cl.psf.far_field), never
        # splatted on its own: no pass may take it for a model with coordinates
        assert (name in COORDINATE_MAPS) != (name == FAR_FIELD), name
    lens = {"psf_resolution": 31, "samples": 4}
    assert load_model("physical_lens", lens).symmetries == ("optical_axis",)
    assert load_model("physical_lens", dict(lens, aperture="star")).symmetries == ("optical_axis", "stop_turn")
    moving = {"max_coc_px": 4.0, "max_motion_px": 4.0, "psf_resolution": 31}
    assert load_model("combined", moving).symmetries == ("motion_direction", "coc_sign")
    assert load_model("combined", dict(moving, aperture="heart")).symmetries == ("motion_angle", "coc_sign")
    assert {"stop_turn", "motion_angle"} <= set(SYMMETRY_TAGS)


@pytest.mark.parametrize("table, match", [
    ({"aperture": "polygon", "aperture_blades": 2}, "aperture_blades = 2"),
    ({"aperture": "polygon", "aperture_rounding": 1.2}, "aperture_rounding = 1.2"),
    ({"aperture": "circle", "aperture_rounding": 0.2}, r"does not use \['aperture_rounding'\]"),
    ({"aperture": "kidney"}, "known apertures"),
])
def test_bad_aperture_keys(table, match):
    with pytest.raises(UserError, match=match):
        load_model("simple_lens", {"max_coc_px": 5.0, "psf_resolution": 15, **table})
