"""The plan: which effects, PSF models, references and runtime passes a scene calls for."""
import pytest

from lab.errors import UserError
from lab.paths import SCENES
from lab.plan import make_plan
from lab.scene import load_scene, parse_scene


def scene(camera, psf=None):
    return parse_scene({"scene": {"name": "p", "resolution": [16, 8]},
                        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **camera},
                        "render": {"reference_spp": 32, "input_spp": 8},
                        "emitters": [{"type": "constant", "radiance": [1, 1, 1]}],
                        "psf": psf or {}}, "p.toml")


THIN = {"model": "thin", "focal_length_mm": 50, "f_number": 2, "focus_distance_m": 3}
PINHOLE = {"model": "pinhole", "fov_deg": 40}


def test_thin_lens_plan():
    plan = make_plan(scene(THIN))
    assert plan.effects["dof"].startswith("thin (50 mm f/2")
    assert plan.psf_models == ("simple_lens",)
    assert [r.name for r in plan.references] == ["mitsuba_thinlens"]
    assert "32 spp" in plan.references[0].detail
    assert [i.name for i in plan.inputs] == ["pinhole_labelled"] and "8 spp" in plan.inputs[0].detail
    assert plan.runtime_passes == ("spreadlets", "splat", "filter")
    skipped = {s.name for s in plan.skipped}
    assert {"motion blur", "participating medium", "chromatic aberration", "polygonal bokeh (MHU21)"} <= skipped
    assert not any("PSF precompute" in s for s in skipped)


def test_pinhole_plan_is_identity():
    plan = make_plan(scene(PINHOLE, psf={"simple_lens": {}}))
    assert plan.effects["dof"] == "none"
    assert plan.psf_models == ()
    assert [r.name for r in plan.references] == ["pinhole"]
    assert plan.runtime_passes == ("identity",)
    reasons = {s.name: s.detail for s in plan.skipped}
    assert "delta" in reasons["PSF precompute and sparsify"]
    assert "not needed" in reasons["[psf.simple_lens]"]  # given, but unused: said so, not silently dropped


def test_describe_lists_everything():
    text = make_plan(load_scene(SCENES / "demo.toml")).describe()
    lines = text.splitlines()
    assert lines[0] == "plan for scene 'demo' (" + str(SCENES / "demo.toml") + "), 1024x1024"
    assert "PSF models to precompute: simple_lens" in lines
    assert "runtime passes: spreadlets -> splat -> filter" in lines
    assert any(line.strip().startswith("dof") and "85 mm f/1.2" in line for line in lines)
    assert any("mitsuba_thinlens" in line and "512 spp" in line for line in lines)
    assert any(line.startswith("  motion blur:") for line in lines)
    assert "PSF models to precompute: none" in make_plan(scene(PINHOLE)).describe()


def test_polygon_iris_plan():
    plan = make_plan(scene({**THIN, "aperture": {"blades": 5, "rotation_deg": 10}}))
    assert plan.effects["aperture"] == "polygon (5 blades, rotation 10 deg, rounding 0)"
    assert plan.psf_models == ()
    assert [r.name for r in plan.references] == ["mitsuba_polygon_lens"] and "5-blade" in plan.references[0].detail
    assert plan.runtime_passes == ("polygon", "polygon_layers")
    assert [i.name for i in plan.inputs] == ["pinhole_labelled"]
    reasons = {s.name: s.detail for s in plan.skipped}
    assert "exact" in reasons["PSF precompute and sparsify"]
    assert "round aperture" in reasons["spreadlets, splat, filter"]
    assert "not point-symmetric" in reasons["180-degree turn of the bokeh in front of the focus plane"]
    assert "layer key" in reasons["polygon_layered_input"]
    assert "polygonal bokeh (MHU21)" not in reasons


def test_occlusion_scene_plan_uses_its_layers():
    plan = make_plan(load_scene(SCENES / "occlusion.toml"))
    assert plan.runtime_passes == ("polygon", "polygon_layers", "polygon_layered_input")
    assert [i.name for i in plan.inputs] == ["pinhole_labelled", "layered_labelled"]
    assert "layer0..2" in plan.inputs[1].detail
    assert not any("180-degree" in s.name for s in plan.skipped)     # 6 blades: point-symmetric


def test_a_stylized_aperture_plans_the_stylized_model_through_its_own_sensor():
    plan = make_plan(scene(dict(THIN, aperture={"shape": "star"})))
    assert plan.psf_models == ("stylized",) and plan.effects["aperture"] == "star (stylized)"
    assert [r.name for r in plan.references] == ["mitsuba_aperture_lens"]
    assert plan.runtime_passes == ("spreadlets", "splat", "filter")
    assert scene(dict(THIN, aperture={"shape": "star"})).camera.camera_json()["aperture"] == {"shape": "star"}


def test_bad_stylized_apertures_are_errors_naming_the_key():
    import pytest

    from lab.errors import UserError

    with pytest.raises(UserError, match=r"aperture shape = 'moon'.*\['star', 'heart', 'image'\]"):
        scene(dict(THIN, aperture={"shape": "moon"}))
    with pytest.raises(UserError, match="needs path"):
        scene(dict(THIN, aperture={"shape": "image"}))
    with pytest.raises(UserError, match="unknown key"):
        scene(dict(THIN, aperture={"shape": "star", "blades": 6}))


def test_a_medium_with_a_pinhole_plans_the_volume_model_and_volpath():
    s = parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                     "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **PINHOLE},
                     "medium": {"sigma_t": 0.5, "albedo": [1, 1, 0.9], "g": 0.7},
                     "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    plan = make_plan(s)
    assert plan.psf_models == ("volume",) and [r.name for r in plan.references] == ["volume_path_trace"]
    assert plan.effects["medium"].startswith("homogeneous (sigma_t 0.5 /m")
    assert "participating medium" not in {x.name for x in plan.skipped}
    assert "volume_far" in {x.name for x in plan.skipped}                  # the window covers 16 x 8 px
    wide = parse_scene({"scene": {"name": "f", "resolution": [400, 300]},
                        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **PINHOLE},
                        "medium": {"sigma_t": 0.5}, "psf": {"volume": {"psf_resolution": 101}},
                        "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    assert make_plan(wide).psf_models == ("volume", "volume_far")           # halos beyond +-48 px


def test_a_medium_in_a_box_plans_the_volume_box_model_and_its_reference_cube():
    """A box: the volume_box model (no far field) against volpath; the Mitsuba scene holds the box as a
    null-BSDF cube whose interior is the medium, the sensor outside it keeps no medium."""
    from lab.reference.mitsuba_scene import scene_dict

    s = parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                     "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **PINHOLE},
                     "medium": {"sigma_t": 0.5, "box": {"center": [0, 0, 3], "size": [1, 1, 1]}},
                     "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    plan = make_plan(s)
    assert plan.psf_models == ("volume_box",) and [r.name for r in plan.references] == ["volume_path_trace"]
    assert "in a box centred at [0.0, 0.0, 3.0] m" in plan.effects["medium"]
    assert "volume_far" in {x.name for x in plan.skipped}
    d = scene_dict(s, medium=True)
    assert d["integrator"]["type"] == "volpath" and "medium" not in d["sensor"]
    assert d["medium_box"]["type"] == "cube" and d["medium_box"]["bsdf"] == {"type": "null"}
    assert d["medium_box"]["interior"] == {"type": "ref", "id": "medium"}


def test_a_medium_is_validated_and_a_thin_lens_cannot_carry_it():
    import pytest

    from lab.errors import UserError

    for medium, match in (({"sigma_t": -1.0}, "sigma_t = -1.0"), ({"sigma_t": 1.0, "g": 1.0}, r"g = 1.0.*\(-1, 1\)"),
                          ({"sigma_t": 1.0, "albedo": [1, 2, 0]}, "albedo"), ({"sigma": 1.0}, "unknown key")):
        with pytest.raises(UserError, match=match):
            parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                         "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **PINHOLE}, "medium": medium,
                         "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    thin = parse_scene({"scene": {"name": "f", "resolution": [16, 8]},
                        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **THIN}, "medium": {"sigma_t": 1.0},
                        "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "f.toml")
    with pytest.raises(UserError, match=r"f.toml \[medium\]: a medium with a thin lens"):
        make_plan(thin)


def test_a_peeling_scene_plans_lens_rays_through_its_peeled_layers():
    plan = make_plan(load_scene(SCENES / "foreground.toml"))
    assert plan.runtime_passes == ("spreadlets", "splat", "filter", "layered")
    assert plan.pass_run("layered") == ("layered", {"rays": 100, "layered_input": True})
    assert [i.name for i in plan.inputs] == ["pinhole_labelled", "peeled_layers"]
    assert "layer0..7" in plan.inputs[1].detail and "layer 0: the input; behind it 64 spp" in plan.inputs[1].detail
    tiny = make_plan(load_scene(SCENES / "tiny_foreground.toml"))
    assert tiny.pass_run("layered")[1]["rays"] == 64
    default = make_plan(parse_scene({"scene": {"name": "p", "resolution": [16, 8]}, "camera": {
        "position": [0, 0, 0], "look_at": [0, 0, 1], **THIN}, "render": {"peel_layers": 4},
        "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "p.toml"))
    assert default.pass_run("layered")[1]["rays"] == 100
    iris = make_plan(parse_scene({"scene": {"name": "p", "resolution": [16, 8]}, "camera": {
        "position": [0, 0, 0], "look_at": [0, 0, 1], **THIN, "aperture": {"blades": 6}},
        "render": {"peel_layers": 4}, "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}, "p.toml"))
    assert "layered" not in iris.runtime_passes
    assert any(s.name.startswith("layered") for s in iris.skipped)


def test_peeling_settings_are_checked():
    base = {"scene": {"name": "p", "resolution": [16, 8]},
            "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], **THIN},
            "emitters": [{"type": "constant", "radiance": [1, 1, 1]}]}
    for render, message in (({"peel_layers": 0}, "peel_layers = 0 must be between 1 and 64"),
                            ({"lens_rays": 100000, "peel_layers": 2}, "lens_rays = 100000 must be between 1 and 4096"),
                            ({"lens_rays": 32}, "lens_rays = 32: lens rays trace peeled layers"),
                            ({"peel_spp": 0, "peel_layers": 2}, "peel_spp = 0 must be between 1 and 65536"),
                            ({"peel_spp": 8}, "peel_spp = 8: the samples of peeled layers; add peel_layers")):
        with pytest.raises(UserError, match=message):
            parse_scene({**base, "render": render}, "p.toml")
    with pytest.raises(UserError, match="layer keys and \\[render\\] peel_layers"):
        parse_scene({**base, "render": {"peel_layers": 2}, "materials": {"m": {"reflectance": [0.5, 0.5, 0.5]}},
                     "shapes": [{"type": "sphere", "material": "m", "center": [0, 0, 2], "radius": 0.1,
                                 "layer": 0}]}, "p.toml")
