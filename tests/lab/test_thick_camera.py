"""``[camera] model = "thick"``: the scene keys, bad prescriptions (exit 2 naming file, key and fix),
the header (surfaces + paraxial figures, checked on read), the plan, the physical_lens settings
it derives and the database fingerprint a header must match."""
import dataclasses
import json
import math

import numpy as np
import pytest

from lab.cameras import parse_camera
from lab.cli import main
from lab.errors import UserError
from lab.exr_io import LabelledImage, validate_camera
from lab.optics.lenses import LENSES
from lab.plan import make_plan
from lab.psf_settings import model_table
from lab.scene import parse_scene
from runtime_cl.camera import from_header
from runtime_cl.errors import InputError
from runtime_cl.psf.fingerprint import check_header

PLACE = {"position": [0, 0, 0], "look_at": [0, 0, 1]}
SINGLET = {"model": "thick", "lens": "singlet", "focus_distance_m": 2.0, **PLACE}
ROWS = [[math.inf, 15.0, "air", 11.5], [0, 10.0, "air", 8.9], [50, 8, "N-BK7", 12], [-50, 0, "air", 12]]
BY_ROWS = {k: v for k, v in SINGLET.items() if k != "lens"} | {"surfaces": ROWS}
BLIND = [[math.inf, 40.0, "air", 2.0], [0, 10.0, "air", 8.9], [50, 8, "N-BK7", 12], [-50, 0, "air", 12]]


def scene(camera, psf=None, resolution=(32, 24), render=None):
    return parse_scene({"scene": {"name": "k", "resolution": list(resolution)}, "camera": camera,
                        "render": {"reference_spp": 16, "input_spp": 4, **(render or {})},
                        "emitters": [{"type": "constant", "radiance": [1, 1, 1]}], "psf": psf or {}}, "k.toml")


def _image(depth, w=32, h=24, camera=None):
    return LabelledImage(np.zeros((h, w, 3), np.float32), np.ones((h, w), np.float32),
                         np.asarray(np.broadcast_to(depth, (h, w)), np.float32), camera or {})


def test_a_named_lens_and_its_surfaces_are_the_same_camera():
    by_name = parse_camera(SINGLET, "c")
    by_rows = parse_camera(BY_ROWS, "c")
    assert by_rows.rows() == by_name.rows() == LENSES["singlet"]
    assert by_rows.runtime_camera() == by_name.runtime_camera()
    s = scene(BY_ROWS)
    assert parse_scene(s.to_dict(), "again") == s                         # the canonical form round-trips


def test_the_header_carries_the_lens_and_round_trips():
    cam = parse_camera(SINGLET, "c")
    header = json.loads(json.dumps(cam.camera_json()))
    assert header["lens"] == "thick" and header["surfaces"] == [list(r) for r in LENSES["singlet"]]
    assert header["focal_length_mm"] == pytest.approx(49.73, abs=0.01) and header["focus"] == "best"
    assert validate_camera(header, "h") == header
    twin = from_header(header, "h")
    assert twin == cam.runtime_camera() and twin.fov_x_deg() == pytest.approx(cam.fov_x_deg())
    # the paraxial CoC: entrance pupil radius a, chief-ray scale k: a k W / sensor (1/F - 1/z)
    z = np.array([0.5, 2.0, np.inf])
    want = 8.9 * twin.chief_scale_mm / 1000 * 1024 / 36.0 * (1 / 2.0 - 1 / z)
    np.testing.assert_allclose(twin.coc_radius_px(z, 1024), want, rtol=1e-12)


@pytest.mark.parametrize("key, value, said", [
    ("chief_scale_mm", 52.0, "chief_scale_mm = 52.0, but the header's surfaces give"),
    ("surfaces", [r[:2] + ["BK7"] + r[3:] if r[2] == "N-BK7" else r for r in ROWS], "glass = 'BK7'"),
    ("indices", [[1.0, 1.0, 1.6, 1.0]] * 3, "indices = [[1.0, 1.0, 1.6, 1.0]"),
    ("sensor_z_mm", 60.0, "sensor_z_mm = 60.0, but the header's surfaces give"),
    ("focus", "paraxial", "focus = 'paraxial'"),
    ("surfaces", [[50, 8, "N-BK7", 12]], "h.exr"),
])
def test_a_header_that_disagrees_with_its_surfaces_is_refused(key, value, said):
    header = dict(parse_camera(SINGLET, "c").camera_json(), **{key: value})
    with pytest.raises(UserError) as e:
        validate_camera(header, "h.exr")
    assert said in str(e.value) and str(e.value).startswith("h.exr")


@pytest.mark.parametrize("change, needles", [
    ({"lens": "telephoto"}, ["lens = 'telephoto' is not a built-in lens", "['achromat', 'singlet']"]),
    ({"surfaces": ROWS}, ["exactly one of lens", "surfaces"]),
    ({"lens": None, "surfaces": [r[:2] + ["BK7"] + r[3:] if r[2] == "N-BK7" else r for r in ROWS]},
     ["surfaces[2]: glass = 'BK7' is not in the catalog", "N-BK7"]),
    ({"lens": None, "surfaces": [r if r[2] != "N-BK7" else [50, 2.0, "N-BK7", 12] for r in ROWS]},
     ["surfaces: lens surfaces 2 and 3 intersect", "raise thickness_mm of surface 2"]),
    ({"lens": None, "surfaces": [[0, 5.0, "air", 5], [-50, 3, "N-BK7", 12], [50, 0, "air", 12]]},
     ["surfaces: the lens's focal length is -", "no ray reaches a sensor", "converging"]),
    ({"lens": None, "surfaces": [[0, 5.0, "air", 5], [50, 8, "N-BK7", 12], [-50, 0, "air", 12]] + [[1, 2]]},
     ["surfaces[3] = [1, 2]", "[radius_mm, thickness_mm, glass, semi_aperture_mm]"]),
    ({"focus_distance_m": 0.03}, ["lens = 'singlet', focus_distance_m = 0.03", "cannot focus"]),
    ({"f_number": 2.0}, ["['f_number']", "follow from its surfaces", "model = 'thin'"]),
    ({"aperture": {"blades": 2}}, ["blades = 2", "3 to 64"]),
    ({"aperture": {"shape": "moon"}}, ["shape = 'moon'", "star"]),
    ({"aperture": {"blades": 7}, "sensor_tilt_deg": [2.0, 0.0]}, ["tilted sensor", "round stop"]),
    ({"focus_distance_m": None}, ["needs focus_distance_m"]),
])
def test_bad_prescriptions_name_the_key_and_the_fix(change, needles):
    table = {k: v for k, v in dict(SINGLET, **change).items() if v is not None}
    with pytest.raises(UserError) as e:
        scene(table)
    msg = str(e.value)
    assert msg.startswith("k.toml [camera]: "), msg
    for needle in needles:
        assert needle in msg, msg


@pytest.mark.parametrize("aperture, says, keys", [
    ({"blades": 7}, "polygon (7 blades", {"aperture": "polygon", "aperture_blades": 7}),
    ({"shape": "star"}, "star (stylized)", {"aperture": "star"}),
])
def test_a_shaped_stop_is_planned_into_the_physical_lens_database_and_the_header(aperture, says, keys):
    s = scene(dict(SINGLET, aperture=aperture))
    plan = make_plan(s)
    assert plan.psf_models == ("physical_lens",) and plan.effects["aperture"].startswith(says)
    assert keys.items() <= s.camera.aperture_keys().items()
    header = s.camera.camera_json()
    assert header["aperture"] == s.camera.header_aperture()["aperture"]
    validate_camera(header, "h.exr")      # the runtime twin and the lab both read it back
    assert s.camera.optics().stop_shape.turn_period_deg == (360 / 7 if "blades" in aperture else 72.0)
    with pytest.raises(UserError, match="peel_layers"):
        make_plan(scene(dict(SINGLET, aperture=aperture), render={"peel_layers": 2}))
    from lab.reference.stochastic import trace_samples

    with pytest.raises(UserError, match="stochastic input re-traces the thick lens's round stop"):
        trace_samples(s)


def test_a_lens_blind_at_the_image_corners_is_refused_by_the_plan():
    s = scene({k: v for k, v in SINGLET.items() if k != "lens"} | {"surfaces": BLIND})   # the axis sees through
    with pytest.raises(UserError, match=r"k.toml \[camera\] surfaces: no ray from the sensor .* gets through"):
        make_plan(s)


def test_a_moving_scene_is_refused_naming_the_fix():
    s = parse_scene({"scene": {"name": "k", "resolution": [32, 24]}, "camera": SINGLET,
                     "shapes": [{"type": "sphere", "center": [0, 0, 2], "radius": 0.1, "velocity": [0.1, 0, 0],
                                 "emitter": {"radiance": [1, 1, 1]}}]}, "k.toml")
    with pytest.raises(UserError, match=r"k.toml \[camera\] model = \"thick\": the scene moves.*model = \"thin\""):
        make_plan(s)


def test_bad_prescriptions_exit_2_through_the_cli(tmp_path, capsys):
    rows = "[[inf, 15.0, \"air\", 11.5], [0.0, 10.0, \"air\", 8.9], [50.0, 8.0, \"N-BK8\", 12.0], [-50.0, 0.0, \"air\", 12.0]]"
    path = tmp_path / "bad.toml"
    path.write_text(f'[scene]\nname = "b"\nresolution = [8, 8]\n[camera]\nmodel = "thick"\nposition = [0, 0, 0]\n'
                    f'look_at = [0, 0, 1]\nfocus_distance_m = 2.0\nsurfaces = {rows}\n'
                    '[[emitters]]\ntype = "constant"\nradiance = [1, 1, 1]\n')
    assert main(["plan", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{path} [camera]: surfaces[2]: glass = 'N-BK8'" in err and "N-BK7" in err


def test_the_plan_runs_the_physical_lens_against_the_thick_reference():
    plan = make_plan(scene(SINGLET))
    assert plan.effects["dof"].startswith("thick (singlet, 4 surfaces, EFL 49.7 mm, f/2.8, focus 2 m")
    assert plan.effects["chromatic"] == "sellmeier (650/510/475 nm)"
    assert plan.psf_models == ("physical_lens",) and plan.runtime_passes == ("spreadlets", "splat", "filter")
    assert [r.name for r in plan.references] == ["mitsuba_thick_lens"] and "650/510/475 nm" in plan.references[0].detail
    assert "chromatic aberration" not in {s.name for s in plan.skipped}
    from lab.reference.references import REFERENCES

    assert "mitsuba_thick_lens" in REFERENCES


def test_the_scene_decides_the_physical_lens_settings():
    s = scene(SINGLET)
    table = model_table(s, "physical_lens", _image(np.linspace(0.73, 6.2, 32)))
    assert table["surfaces"] == LENSES["singlet"] and table["focus_distance_m"] == 2.0 and table["focus"] == "best"
    assert table["wavelengths_nm"] == (650.0, 510.0, 475.0) and table["width_px"] == 32
    assert table["sensor_height_mm"] == pytest.approx(27.0)
    assert (table["near_m"], table["far_m"]) == (0.7, 6.5)
    assert 3 <= table["psf_resolution"] <= 21 and table["psf_resolution"] % 2 == 1


@pytest.mark.parametrize("override, said", [
    ({"surfaces": [list(r) for r in LENSES["achromat"]]}, "[psf.physical_lens] surfaces = "),
    ({"focus_distance_m": 3.0}, "focus_distance_m = 3.0: the scene's [camera] asks for focus_distance_m = 2.0"),
    ({"focus": "paraxial"}, "focus = 'paraxial'"),
    ({"wavelengths_nm": [600.0, 550.0, 450.0]}, "wavelengths_nm"),
])
def test_a_physical_lens_table_that_contradicts_the_camera_names_both(override, said):
    with pytest.raises(UserError) as e:
        model_table(scene(SINGLET, {"physical_lens": override}), "physical_lens", _image(1.0))
    assert "k.toml [psf.physical_lens]" in str(e.value) and said in str(e.value)
    same = {"surfaces": [list(r) for r in LENSES["singlet"]], "near_m": 0.5}
    assert model_table(scene(SINGLET, {"physical_lens": same}), "physical_lens", _image(1.0))["near_m"] == 0.5


def test_the_sky_is_refused():
    with pytest.raises(UserError, match=r"k.toml \[camera\]: 768 pixel\(s\) see no surface"):
        model_table(scene(SINGLET), "physical_lens", _image(np.inf))


def test_the_database_fingerprint_matches_the_header_of_its_lens_only():
    from lab.psf_tracing.models import load_model
    from runtime_cl.psf.synthetic import disc_database

    s = scene(SINGLET)
    fingerprint = load_model("physical_lens", model_table(s, "physical_lens", _image(1.0))).fingerprint()
    db = disc_database(4.0, samples=4)
    db = dataclasses.replace(db, params=dict(db.params, fingerprint=json.loads(json.dumps(fingerprint))))
    check_header(db, json.loads(json.dumps(s.camera.camera_json())))
    other = scene(dict(SINGLET, lens="achromat")).camera.camera_json()
    with pytest.raises(InputError) as e:
        check_header(db, other, "in.exr camera")
    msg = str(e.value)
    assert msg.startswith("in.exr camera: surfaces = [[inf, 12.0") and "was traced for surfaces = [[inf, 15.0" in msg
    for key, value in (("focus_distance_m", 3.0), ("sensor_width_mm", 24.0)):
        with pytest.raises(InputError, match=f"{key} = {value}"):
            check_header(db, dict(s.camera.camera_json(), **{key: value}))
