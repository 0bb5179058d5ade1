"""PSF model registry and the SimpleLens config: defaults (LSR18 Tbl. 1), TOML, errors."""
import tomllib

import pytest

from lab.config import from_table
from lab.errors import UserError
from lab.psf_tracing.models import PSFModel, get_model, load_model, model_names, register_model
from lab.psf_tracing.models.simple_lens import SimpleLens, SimpleLensConfig, min_psf_resolution

SCENE = """
[psf.simple_lens]
max_coc_px = 40.0
psf_resolution = 128
rays_per_psf = 65536
seed = 3
"""


def test_registry():
    assert "simple_lens" in model_names()
    assert get_model("simple_lens") is SimpleLens
    with pytest.raises(UserError, match="simple_lens"):
        get_model("thick_lens_typo")
    with pytest.raises(ValueError, match="twice"):
        register_model("simple_lens")(type("Dup", (PSFModel,), {}))


def test_defaults_follow_lsr18_table_1():
    m = SimpleLens(SimpleLensConfig(max_coc_px=100.0))
    assert m.grid.ns == 1 and m.channels == 1 and m.beta == (2.0,)
    assert m.grid.size >= 100 and m.grid.ranges == ((0.0, 100.0),)
    assert m.symmetries == ("rotation",)
    assert m.config.psf_resolution == 512 and m.config.rays_per_psf == 2 ** 24
    assert m.config.density == 1.0 and m.config.aperture == "circle"
    # the boxes tile [0, max] in order, narrow at small CoC (beta > 1)
    assert m.boxes[0].lo == (0.0,) and m.boxes[-1].hi == (100.0,)
    assert all(a.hi == b.lo for a, b in zip(m.boxes, m.boxes[1:]))
    assert m.boxes[1].hi[0] - m.boxes[1].lo[0] < m.boxes[-1].hi[0] - m.boxes[-1].lo[0]


def test_loads_from_a_scene_table():
    table = tomllib.loads(SCENE)["psf"]["simple_lens"]
    m = load_model("simple_lens", table, "scenes/x.toml [psf.simple_lens]")
    assert m.config.max_coc_px == 40.0 and m.resolution == 128 and m.config.seed == 3
    psf = m.trace(99)
    assert psf.shape == (128, 128, 1)


def test_min_resolution():
    assert min_psf_resolution(40.0) == 85
    assert min_psf_resolution(40.2) == 87
    SimpleLensConfig(max_coc_px=40.0, psf_resolution=85)  # the minimum is accepted
    m = SimpleLens(SimpleLensConfig(max_coc_px=40.0, psf_resolution=85))
    r = m.trace_cell(m.grid.size - 1, n_rays=2 ** 18)
    assert r.n_outside == 0
    assert r.psf[:2].sum() == 0 and r.psf[-2:].sum() == 0  # the margin is empty


@pytest.mark.parametrize("table, match", [
    ({"max_coc_px": 250.0, "psf_resolution": 256}, r"psf_resolution >= 505"),
    ({"max_coc_px": -3.0}, "max_coc_px"),
    ({"max_coc_px": 0.0}, "max_coc_px"),
    ({"max_coc_px": 10.0, "beta": -1.0}, "beta"),
    ({"max_coc_px": 10.0, "samples": 0}, "samples"),
    ({"max_coc_px": 10.0, "rays_per_psf": -5}, "rays_per_psf"),
    ({"max_coc_px": 10.0, "rays_per_launch": 2 ** 31}, "rays_per_launch"),
    ({"max_coc_px": 10.0, "seed": -1}, "seed"),
    ({"max_coc_px": 10.0, "density": 0.0}, "density"),
    ({"max_coc_px": 10.0, "max_coc": 10.0}, r"unknown key\(s\) \['max_coc'\]"),
    ({"psf_resolution": 64}, r"missing key\(s\) \['max_coc_px'\]"),
    ({"max_coc_px": 10.0, "samples": 1.5}, "integer"),
    ({"max_coc_px": 10.0, "aperture": "kidney"}, "known apertures"),
    ({"max_coc_px": 10.0, "lens_focus_distance_m": 0.01}, "canonical lens"),
    ({"max_coc_px": float("inf")}, "max_coc_px"),
])
def test_bad_config_is_a_user_error(table, match):
    with pytest.raises(UserError, match=match) as info:
        from_table(SimpleLensConfig, table, "scene.toml [psf.simple_lens]")
    assert "scene.toml [psf.simple_lens]" in str(info.value)


def test_direct_construction_is_validated_too():
    with pytest.raises(UserError, match="psf_resolution"):
        SimpleLensConfig(max_coc_px=30.0, psf_resolution=40)
    with pytest.raises(UserError, match="seed"):
        SimpleLensConfig(max_coc_px=30.0, seed=True)


def test_bad_cell_is_a_user_error():
    m = SimpleLens(SimpleLensConfig(max_coc_px=5.0, psf_resolution=32))
    for cell in (-1, m.grid.size, 2.0):
        with pytest.raises(UserError, match="cell"):
            m.trace(cell)


@pytest.mark.slow
def test_throughput_meets_lsr18_pace():
    from lab.bench.tracing import measure_throughput

    m = load_model("simple_lens", {"max_coc_px": 250.0})
    t = measure_throughput(m)
    assert t.n_rays == 2 ** 24 and t.rays_per_launch == 2 ** 22 and t.resolution == 512
    assert t.mrays_per_second >= 35.0, t


@pytest.mark.parametrize("table, aperture", [
    ({}, None),
    ({"aperture": "polygon", "aperture_blades": 5}, {"blades": 5, "rotation_deg": 0.0, "rounding": 0.0}),
    ({"aperture": "star"}, {"shape": "star"}),
])
def test_a_database_fingerprint_states_its_aperture_as_the_header_does(table, aperture):
    model = load_model("simple_lens", dict(table, max_coc_px=8.0))
    assert model.fingerprint() == {"medium": None, "aperture": aperture}


@pytest.mark.parametrize("name, table", [
    ("simple_lens", {"max_coc_px": 8.0}), ("combined", {"max_coc_px": 8.0, "max_motion_px": 8.0}),
    ("stylized", {"max_coc_px": 8.0}), ("physical_lens", {})])
def test_a_lens_database_is_traced_without_a_medium(name, table):
    """A header that asks for fog (``medium``) is refused by a lens database, not rendered fog-free."""
    assert load_model(name, table).fingerprint()["medium"] is None


def test_a_physical_lens_fingerprint_is_its_paraxial_thin_lens():
    fp = load_model("physical_lens", {}).fingerprint()
    assert fp["focal_length_mm"] == pytest.approx(49.7, abs=0.05)   # R = +-50 mm N-BK7, 8 mm thick
    assert fp["focus_distance_m"] == 2.0 and fp["sensor_width_mm"] == 36.0
