"""Expressive focus (LES10 5.2) from a scene or a --camera file: in-focus and out-of-focus ("blur this
point by r px") constraints, interpolated into the per-pixel focal surface with the DOF extent.

It has no physical reference, so it is tested by its properties, on labelled pixels made here and
rendered by the layered pass (lens rays, each pixel with its own focus). A pixel's blur is the disc
of the scene it averages: on a wall whose radiance is L(q) = |q - p|^2 (pixels from the pixel p
measured), p shows the mean of |q - p|^2 over its disc (about r^2 / 2 + 1/6 for a uniform disc of
radius r: each ray takes the radiance of the pixel it lands in; :func:`_table` integrates it). So one render measures each constrained pixel's blur radius: constrained
in-focus pixels are sharp, out-of-focus constrained pixels reach their asked radius, and the radius
grows monotonically as the wall moves away from the surface. The scene file's bad values exit 2 in one line naming the file and key."""
from dataclasses import replace

import numpy as np
import pytest

import runtime_cl
from lab.cameras.base import parse_camera
from lab.cli import main
from lab.errors import UserError
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from lab.focus import surface_from_depth
from lab.paths import SCENES

H, W = 48, 64
WALL_Z = 1.0                # metres: the wall every pixel sees
SHARP, BLURRED, FRONT = (16, 24), (48, 24), (32, 12)      # constrained pixels (x, y): one per channel
ASK = {SHARP: 0.0, BLURRED: 4.0, FRONT: -2.0}             # asked signed CoC radius, px
RAYS = 256
CAMERA = {"model": "thin", "position": [0, 0, 0], "look_at": [0, 0, 1], "focal_length_mm": 50.0, "f_number": 0.5,
          "focus_distance_m": 1.0, "sensor_width_mm": 36.0,
          "focal_surface": {"blur": [[x, y, r] for (x, y), r in ASK.items()], "beta": 2.0}}


def depth_map(z=WALL_Z) -> np.ndarray:
    return np.full((H, W), z)


def lens(**surface):
    table = dict(CAMERA, focal_surface=dict(CAMERA["focal_surface"], **surface))
    return surface_from_depth(parse_camera(table, "c.toml [camera]"), depth_map(), "c.toml [camera]").runtime_camera()


def wall() -> np.ndarray:
    """(H, W, 3): channel c holds |q - p_c|^2, p_c the c-th constrained pixel."""
    y, x = np.mgrid[0:H, 0:W]
    return np.stack([(x - px) ** 2 + (y - py) ** 2 for px, py in ASK], axis=-1).astype(np.float32)


def _table():
    """(r, mean of |round(u)|^2 over the uniform disc |u| <= r) for r in [0, 8] px: the disc as a
    321^2 grid of cell centres, scaled (each point rounded to its pixel, as a ray takes its texel's
    radiance). Grows with r from r = 0.5 (a smaller disc stays in its pixel: 0)."""
    t = (np.arange(321) + 0.5) / 321 * 2.0 - 1.0
    ux, uy = (v.ravel() for v in np.meshgrid(t, t))
    keep = ux * ux + uy * uy <= 1.0
    ux, uy = ux[keep], uy[keep]
    r = np.linspace(0.0, 8.0, 801)
    return r, np.array([(np.round(ux * x) ** 2 + np.round(uy * x) ** 2).mean() for x in r])


R_TABLE, MEAN_TABLE = _table()


def radius_of(mean: float) -> float:
    """The blur radius (>= 0.5 px, or 0) whose disc shows ``mean`` on the wall (the table inverted)."""
    if mean <= 0.0:
        return 0.0
    ok = R_TABLE >= 0.5
    return float(np.interp(mean, MEAN_TABLE[ok], R_TABLE[ok]))


def radii(image) -> np.ndarray:
    """The blur radius (px) each constrained pixel shows (module docstring)."""
    return np.array([radius_of(float(image[py, px, c])) for c, (px, py) in enumerate(ASK)])


def render(camera, z=WALL_Z) -> np.ndarray:
    out, _ = runtime_cl.render(wall(), depth_map(z).astype(np.float32), camera, method="layered", rays=RAYS, seed=3)
    return np.asarray(out, np.float64)


def test_constraint_pixels_get_exactly_the_asked_blur():
    """The per-pixel CoC map at each constraint pixel is the asked signed radius (the MLS
    interpolates its constraints exactly), with the DOF extent too (it scales the lens's blur, and
    the constraint is met in the scaled blur)."""
    for extent in (1.0, 0.5):
        cam = lens(dof_extent=extent)
        coc = cam.coc_radius_px(depth_map(), W)
        for (x, y), r in ASK.items():
            assert coc[y, x] == pytest.approx(r, abs=1e-9)            # float64 algebra only
        assert cam.surface()["dof_extent"] == extent


def test_rendered_pixels_reach_their_asked_blur():
    """The in-focus constrained pixel sees only its own texel; the others average discs of the asked
    radii |r|. Tolerance 0.05 px: 256 Halton lens rays estimate the disc's mean |q - p|^2 within a
    fraction of a percent (measured: < 0.02 px off)."""
    got = radii(render(lens())[..., :3])
    np.testing.assert_allclose(got, [abs(r) for r in ASK.values()], atol=0.05)
    assert render(lens())[SHARP[1], SHARP[0], 0] == 0.0                # sharp: nothing but its own texel


def test_blur_grows_monotonically_away_from_the_surface():
    """The wall moved off each constrained pixel's focal surface in steps of one pixel of CoC (1/S
    dioptre), behind it and in front: each pixel's radius grows at every step, a pixel per step
    (0.05 px, as above). Behind stops before infinity (the front pixel's surface at 1.7 m leaves
    two steps)."""
    cam = lens()
    w_f = cam.inverse_focus_map(H, W)
    step = 1.0 / cam.coc_scale_px(W)
    for c, (px, py) in enumerate(ASK):
        for sign in (+1, -1):                                         # +1: the wall farther (behind), -1: nearer
            ws = [w for w in (w_f[py, px] - sign * k * step for k in range(4)) if w > 0.05]
            got = [radii(render(cam, 1.0 / w))[c] for w in ws]
            assert len(got) >= 3 and np.all(np.diff(got) > 0.9), ((px, py), sign, got)
            np.testing.assert_allclose(got, np.arange(len(got)), atol=0.05)


def test_a_camera_file_with_blur_constraints_renders(tmp_path):
    """``splatlab render --camera`` resolves blur constraints from the input's own Z."""
    write_labelled(tmp_path / "in.exr", LabelledImage(wall(), np.ones((H, W), np.float32), depth_map().astype(np.float32),
                                                      {"lens": "thin", "focal_length_mm": 50.0, "f_number": 0.5,
                                                       "focus_distance_m": 1.0, "sensor_width_mm": 36.0}))
    (tmp_path / "cam.toml").write_text(
        "[camera]\nmodel = \"thin\"\nposition = [0, 0, 0]\nlook_at = [0, 0, 1]\nfocal_length_mm = 50.0\n"
        "f_number = 0.5\nfocus_distance_m = 1.0\nfocal_surface = { blur = [[16, 24, 0.0], [48, 24, 4.0], "
        "[32, 12, -2.0]] }\n")
    assert main(["render", str(tmp_path / "in.exr"), "--method", "layered", "--rays", str(RAYS), "--camera",
                 str(tmp_path / "cam.toml"), "--out", str(tmp_path / "o.exr")]) == 0
    np.testing.assert_allclose(radii(read_rgb(tmp_path / "o.exr")), [0.0, 4.0, 2.0], atol=0.05)


def test_a_blur_in_front_needs_a_focus_beyond_infinity():
    with pytest.raises(UserError, match=r"blur \[48, 24, -30\]: the pixel sees depth 1 m, .* needs focus beyond "
                                        r"infinity; ask for at most 4.6\d px in front"):
        surface_from_depth(parse_camera(dict(CAMERA, focal_surface={"blur": [[48, 24, -30.0]]}), "c"),
                           depth_map(), "c.toml [camera]")


# ---- the scene file -------------------------------------------------------------------------------

TINY = (SCENES / "tiny_expressive.toml").read_text()
SURFACE = "focal_surface = { blur = [[60, 27, 0.0], [39, 56, 0.0], [20, 20, 6.0]], beta = 2, dof_extent = 1 }"


def plan_fails(tmp_path, capfd, new, *needles, old=SURFACE, argv=("plan",)):
    assert old in TINY
    path = tmp_path / "s.toml"
    path.write_text(TINY.replace(old, new))
    code = main([*argv, str(path)])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    for needle in (str(path), *needles):
        assert needle in err[0], (needle, err[0])


@pytest.mark.parametrize("new, needles", [
    ("focal_surface = { blur = [[60, 27, 0.0]], sharpness = 3 }", ["focal_surface: unknown key(s) ['sharpness']",
                                                                   "known keys are"]),
    ("focal_surface = { blur = [[60, 27, 1e5]] }", ["focal_surface blur = [[60, 27, 100000.0]]", "|radius| <= 4096"]),
    ("focal_surface = { blur = [[60, 27, 2.0]], dof_extent = 1000 }", ["dof_extent = 1000", "0.01 to 100"]),
    ("focal_surface = { blur = [[60, 27, 2.0]], alpha = [0] }", ["alpha = [0]", "(0, 1e+06]"]),
    ("focal_surface = { points = [[60, 27, 1e9]] }", ["focal_surface points = [[60, 27, 1000000000.0]]",
                                                      "0 < depth <= 1e+06 m"]),
    ("focal_surface = { blur = [[600, 27, 2.0]] }", ["focal_surface blur [600, 27, ...] is outside the 96 x 72 image"]),
    ("focal_surface = { blur = [[60, 27, nan]] }", ["camera.focal_surface.blur[0][2] = nan", "finite"]),
    ("focal_surface = { }", ["0 points and 0 blur constraints", "give 1 to 256"]),
    ("focal_surface = [1, 2]", ["[camera]: focal_surface = [1, 2] has the wrong type; expected dict"]),
    (SURFACE + "\nsensor_tilt_deg = [3.0, 0.0]", ["sensor_tilt_deg = [3.0, 0.0] with a focal_surface", "remove one"]),
])
def test_bad_focal_surface_in_a_scene(tmp_path, capfd, new, needles):
    plan_fails(tmp_path, capfd, new, *needles)


def test_a_scene_needs_a_focus_distance_with_its_surface(tmp_path, capfd):
    plan_fails(tmp_path, capfd, "", "[camera]: a thin lens needs focal_length_mm and focus_distance_m",
               old="focus_distance_m = 0.45\n")


def test_no_reference_means_no_noise_floor_and_no_table(tmp_path, capfd):
    """--noise-floor (and --sweep, --baseline, several scenes) score against a reference: refused
    before any render, naming the scene and why it has none."""
    plan_fails(tmp_path, capfd, SURFACE, "--noise-floor scores against a reference", "has no physical reference",
               argv=("report", "--noise-floor"))


def test_the_plan_runs_every_thin_lens_pass_and_no_reference():
    """scenes/tiny_expressive.toml: blur 0 on two house fronts and 6 px on a far corner, resolved from the
    depths the pixels' pinhole rays see (Mitsuba); the plan runs the passes that read the per-pixel
    focus against no reference, and says why."""
    from lab.focus import pixel_depths
    from lab.pipeline import load_scene_and_plan

    scene, plan = load_scene_and_plan(SCENES / "tiny_expressive.toml")
    assert not plan.scored and plan.references[0].name == "none"
    assert plan.runtime_passes == ("spreadlets", "splat", "filter", "layered")
    text = plan.describe()
    assert "has no physical reference" in text and "scores against mitsuba_thinlens" in text
    assert "expressive focal surface from 3 constraints" in plan.effects["dof"]
    cam = scene.camera.runtime_camera()
    pixels = [(60, 27), (39, 56), (20, 20)]
    z = pixel_depths(replace(scene, camera=replace(scene.camera, focal_surface=None)), pixels)
    w_f = cam.inverse_focus_map(scene.height, scene.width)
    coc = [cam.coc_scale_px(scene.width) * (w_f[y, x] - 1.0 / d) for (x, y), d in zip(pixels, z)]
    np.testing.assert_allclose(coc, [0.0, 0.0, 6.0], atol=1e-9)


def test_benches_refuse_a_scene_without_reference(tmp_path, capfd):
    plan_fails(tmp_path, capfd, SURFACE, "--scene", "the benches score against a reference", "bench another scene",
               argv=("bench", "layered", "--scene"))
