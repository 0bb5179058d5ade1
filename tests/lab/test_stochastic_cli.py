"""`splatlab render --method stochastic_*` on a stochastic EXR, and its bad inputs (exit 2, one line)."""
import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from runtime_cl.psf.synthetic import disc_database

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0,
        "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}


def _write(path, **channels):
    rng = np.random.default_rng(0)
    extra = {"lens.U": rng.random((12, 12), dtype=np.float32), "lens.V": rng.random((12, 12), dtype=np.float32),
             "time": rng.random((12, 12), dtype=np.float32)}
    if "Z.R" in channels:   # a thick lens's per-channel depth (the camera header here is a thin lens's)
        extra["Z.R"] = np.full((12, 12), 2.0, np.float32)
    for name in ("subpixel.X", "subpixel.Y"):
        if name in channels:
            extra[name] = np.full((12, 12), 0.5, np.float32)
    for name, value in channels.items():
        if value is None:
            del extra[name]
        else:
            extra[name][3, 5] = value
    write_labelled(path, LabelledImage(rng.random((12, 12, 3), dtype=np.float32), np.ones((12, 12), np.float32),
                                       rng.uniform(1, 9, (12, 12)).astype(np.float32), dict(THIN), extra))


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    disc_database(6.0, samples=6).save(tmp_path / "db.spdb")
    return tmp_path


@pytest.mark.parametrize("method", ["stochastic_spreadlets", "stochastic_splat"])
def test_render_a_stochastic_exr(work, method, capfd):
    _write(work / "in.exr")
    assert main(["render", str(work / "in.exr"), "--method", method, "--db", str(work / "db.spdb"),
                 "--out", str(work / "o.exr")]) == 0
    out = read_rgb(work / "o.exr")
    assert out.shape == (12, 12, 3) and np.isfinite(out).all() and out.sum() > 0


@pytest.mark.parametrize("channels, needles", [
    ({"lens.U": 1.5}, ["channel lens.U = 1.5", "pixel (x=5, y=3)", "outside [0, 1)", "lens sample"]),
    ({"lens.V": -0.25}, ["channel lens.V = -0.25", "outside [0, 1)"]),
    ({"time": None}, ["channel(s) ['time'] missing", "shutter time"]),
    ({"Z.R": -1.0}, ["channel Z.R = -1.0", "pixel (x=5, y=3)", "planar depth in metres"]),
    ({"Z.R": float("nan")}, ["channel Z.R = nan", "is no depth"]),
    ({"subpixel.X": 1.0, "subpixel.Y": 0.5}, ["channel subpixel.X = 1.0", "pixel (x=5, y=3)", "outside [0, 1)",
                                                "where in its pixel"]),
    ({"subpixel.Y": 0.25}, ["channel subpixel.X missing beside subpixel.Y", "write both", "or neither"]),
])
def test_bad_stochastic_exr(work, capfd, channels, needles):
    _write(work / "in.exr", **channels)
    code = main(["render", str(work / "in.exr"), "--method", "stochastic_spreadlets", "--db", str(work / "db.spdb"),
                 "--out", str(work / "o.exr")])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    assert not (work / "o.exr").exists()
    for needle in [str(work / "in.exr")] + needles:
        assert needle in err[0], (needle, err[0])


def test_set_gives_the_pass_its_options(work):
    """--set reaches the pass: the full reconstruction (Table 3's +fill) is the runtime pass run
    with those options, and differs from the default plain sum."""
    from lab.runtime_passes import frame_of, read_input, runtime_camera
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase

    _write(work / "in.exr")
    full = {"normalize": True, "footprint": "bilinear", "depth_layers": 4}
    sets = ["--set", "normalize=true", "--set", "footprint=bilinear", "--set", "depth_layers=4"]
    for name, extra in (("plain.exr", []), ("full.exr", sets)):
        assert main(["render", str(work / "in.exr"), "--method", "stochastic_spreadlets", "--db",
                     str(work / "db.spdb"), "--out", str(work / name)] + extra) == 0
    image, db = read_input(work / "in.exr", None), SpreadletDatabase.load(work / "db.spdb")
    frame = frame_of(image, str(work / "in.exr"), db, False, True)
    want, _ = run_pass("stochastic_spreadlets", frame, runtime_camera(image, "in.exr camera"), db, **full)
    np.testing.assert_array_equal(read_rgb(work / "full.exr"), want[..., :3])
    assert np.abs(read_rgb(work / "full.exr") - read_rgb(work / "plain.exr")).max() > 1e-3


@pytest.mark.parametrize("item, needles", [
    ("normalise=true", ["--set normalise=True", "no option 'normalise'", "normalize, min_density, footprint"]),
    ("integrator=exact", ["--set integrator='exact'", "give it as --integrator NAME"]),
    ("footprint=round", ["footprint = 'round'", "'nearest'", "'bilinear'"]),
    ("normalize", ["--set 'normalize'", "expected KEY=VALUE"]),
])
def test_bad_set(work, capfd, item, needles):
    _write(work / "in.exr")
    code = main(["render", str(work / "in.exr"), "--method", "stochastic_spreadlets", "--db", str(work / "db.spdb"),
                 "--set", item, "--out", str(work / "o.exr")])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    assert not (work / "o.exr").exists()
    for needle in needles:
        assert needle in err[0], (needle, err[0])


@pytest.mark.parametrize("args, needles", [
    (["--index", "-1"], ["--index -1", "integer in [0,"]),
    (["--shading-spp", "0"], ["--shading-spp 0", "integer in [1, 4096]"]),
    (["--shading-spp", "many"], ["--shading-spp many"]),
    (["--out", "SCENE"], ["this command's input", "choose another output name"]),
])
def test_bad_stochastic_command(work, capfd, args, needles):
    from lab.paths import SCENES

    scene = str(SCENES / "tiny.toml")
    code = main(["stochastic", scene, "--quiet"] + [scene if a == "SCENE" else a for a in args])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    for needle in needles:
        assert needle in err[0], (needle, err[0])


def test_stochastic_command_writes_a_thick_lens_input(work):
    """Through a thick lens: the exit-pupil box samples as lens.U, lens.V, the lens header, and
    dark pixels only where the lens's rays are all blocked or see nothing."""
    from lab.exr_io import read_labelled
    from lab.paths import SCENES

    assert main(["stochastic", str(SCENES / "tiny_rain.toml"), "--out", str(work / "s.exr"), "--quiet"]) == 0
    image = read_labelled(work / "s.exr")
    assert image.camera["lens"] == "thick" and image.rgb.shape == (48, 64, 3)
    for name in ("lens.U", "lens.V", "time"):
        assert 0.0 <= image.extra[name].min() and image.extra[name].max() < 1.0
    assert image.alpha.mean() > 0.5 and np.isfinite(image.rgb).all() and image.rgb.max() > 0
    for name in ("Z.R", "Z.B"):   # each dispersed ray's own hit: mostly the middle ray's, not everywhere
        same = np.isclose(image.extra[name], image.depth, rtol=0.05)
        assert image.extra[name].min() > 0 and 0.5 < same.mean() < 1.0, (name, same.mean())


def test_stochastic_command_on_a_moving_scene(work):
    """A moving scene's sub-frames follow its input's longest motion: the input renders first, and
    the stochastic EXR carries the motion and every shutter time's share."""
    from lab.exr_io import read_labelled
    from lab.paths import SCENES

    assert main(["stochastic", str(SCENES / "tiny_motion.toml"), "--out", str(work / "s.exr"), "--quiet"]) == 0
    image = read_labelled(work / "s.exr")
    assert {"motion.X", "motion.Y", "time"} <= set(image.extra)
    assert np.abs(image.extra["motion.X"]).max() > 1.0 and len(np.unique(image.extra["time"])) > 2
