"""``splatlab render --integrator`` and ``splatlab bench integrate``'s measurements."""
import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.psf.synthetic import disc_database

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 1.4, "focus_distance_m": 0.25,
          "sensor_width_mm": 36.0}   # a 40-px-wide macro shot: the background's CoC is ~4 px


@pytest.fixture(scope="module")
def labelled(tmp_path_factory):
    rng = np.random.default_rng(0)
    h, w = 24, 40
    depth = np.where(np.arange(w)[None, :] < 20, 0.25, 2.0) * np.ones((h, 1))
    y, x = np.mgrid[0:h, 0:w]   # smooth colours (the pyramid is less exact on pixel-scale detail)
    rgb = np.stack([0.5 + 0.4 * np.sin(x / 7.0 + p) * np.cos(y / 5.0 - p) for p in rng.random(3) * 6], -1)
    image = LabelledImage(rgb=rgb.astype(np.float32),
                          alpha=np.ones((h, w), np.float32), depth=depth.astype(np.float32), camera=CAMERA)
    folder = tmp_path_factory.mktemp("integrator")
    write_labelled(folder / "input.exr", image)
    coc = np.abs(ThinLens.from_json(CAMERA).coc_radius_px(image.depth, w)).max()
    db = disc_database(float(np.ceil(coc)) + 1, samples=8, fast_track_below=0.5)
    db.save(folder / "discs.spdb")
    return folder


@pytest.mark.parametrize("args, says", [
    (["--integrator", "bogus"], "integrator = 'bogus': unknown; choose one of ['exact', 'fft32', 'pyramid']"),
    (["--integrator", "pyramid", "--method", "splat"], "--integrator pyramid: --method splat integrates no"),
])
def test_bad_integrator_exits_2_with_one_line(labelled, tmp_path, capsys, args, says):
    code = main(["render", str(labelled / "input.exr"), "--db", str(labelled / "discs.spdb"),
                 "--out", str(tmp_path / "x.exr"), *args])
    err = capsys.readouterr().err
    assert code == 2 and says in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.exr").exists()


def test_render_with_each_integrator(labelled, tmp_path, capsys):
    images = {}
    for name in ("exact", "fft32", "pyramid"):
        out = tmp_path / f"{name}.exr"
        assert main(["render", str(labelled / "input.exr"), "--db", str(labelled / "discs.spdb"),
                     "--integrator", name, "--out", str(out)]) == 0
        assert f"({name} integration)" in capsys.readouterr().out
        images[name] = read_rgb(out)
    default = tmp_path / "default.exr"
    assert main(["render", str(labelled / "input.exr"), "--db", str(labelled / "discs.spdb"),
                 "--out", str(default)]) == 0
    np.testing.assert_array_equal(read_rgb(default), images["fft32"])
    scale = np.abs(images["exact"]).max()
    assert np.abs(images["fft32"] - images["exact"]).max() <= 1e-4 * scale
    assert np.abs(images["pyramid"] - images["exact"]).max() <= 0.03 * scale


def test_bench_measures_errors_and_ratios():
    """One small case of ``bench integrate``: the errors are the measured ones, ratios per repeat."""
    from lab.bench.integrate import measure_case, random_canvas, relative_error
    from runtime_cl.integrate import get_integrator, integrator_names

    lap, image = random_canvas(96, seed=1)
    integrators = {n: get_integrator(n)() for n in integrator_names()}
    row = measure_case(lap, integrators, repeats=3, truth=image)
    assert row["canvas"] == [96, 96, 3] and row["floor"]["max"] < 1e-5
    exact = integrators["exact"](lap)[0]
    for name in ("fft32", "pyramid"):
        r = row["integrators"][name]
        assert r["error"] == relative_error(integrators[name](lap)[0], exact.astype(np.float64))
        assert r["exact_over_this"]["min"] <= r["exact_over_this"]["median"] <= r["exact_over_this"]["max"]
    assert row["integrators"]["exact"]["error"] == {"mean": 0.0, "max": 0.0}
    assert row["integrators"]["pyramid"]["device_ms"]["min"] > 0


def test_a_scenes_own_canvas_is_the_one_its_spreadlets_integrate(tmp_path, monkeypatch):
    """``bench integrate --scene``: the Laplacian canvas the spreadlets pass hands its integrator for
    tiny's input, on which the pyramid holds the issue's bound (<= 1 % mean, <= 3 % max)."""
    from lab.bench.integrate import relative_error, scene_canvas
    from lab.paths import SCENES
    from runtime_cl.integrate import get_integrator

    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    lap, name = scene_canvas(SCENES / "tiny.toml")
    assert name == "tiny" and lap.ndim == 3 and lap.shape[2] == 3 and np.abs(lap).max() > 0
    assert np.all(lap[0] == 0) and np.all(lap[:, -1] == 0)    # zero on its border ring
    exact = get_integrator("exact")()(lap)[0].astype(np.float64)
    assert exact.sum() > 0
    error = relative_error(get_integrator("pyramid")()(lap)[0], exact)
    assert error["mean"] <= 0.01 and error["max"] <= 0.03, error
