"""The `splatlab` command line: render contract and bad input (exit 2, one line, nothing left behind)."""
import dataclasses

import numpy as np
import pytest

from lab.cli import build_parser, main
from lab.exr_io import LabelledImage, read_labelled, read_rgb, write_labelled
from lab.paths import SCENES
from runtime_cl.psf.database import SpreadletDatabase

TINY = SCENES / "tiny.toml"


def run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("command", ["plan", "precompute", "reference", "render", "report", "demo", "bench",
                                     "db", "doctor"])
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args([command, "--help"])
    assert exc.value.code == 0
    assert len(capsys.readouterr().out) > 100


def test_plan_lists_what_runs(capsys):
    code, out, _ = run(["plan", TINY], capsys)
    assert code == 0 and "simple_lens" in out and "spreadlets -> splat -> filter" in out


@pytest.mark.parametrize("method", ["spreadlets", "splat", "filter"])
def test_render_contract(method, tiny_input, tiny_db, tmp_path, capsys):
    out = tmp_path / f"{method}.exr"
    code, stdout, _ = run(["render", tiny_input, "--db", tiny_db, "--method", method, "--out", out], capsys)
    assert code == 0 and method in stdout
    img = read_rgb(out)
    src = read_labelled(tiny_input)
    assert img.shape == src.rgb.shape and np.all(np.isfinite(img))
    # splatting normalised PSFs conserves the image's total energy (up to light blurred off-frame)
    assert 0.85 < img.sum() / src.rgb.sum() < 1.05


def test_db_info(tiny_db, capsys):
    code, out, _ = run(["db", "info", tiny_db], capsys)
    assert code == 0 and '"model": "simple_lens"' in out


def _expect_user_error(argv, capsys, *needles):
    code, out, err = run(argv, capsys)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in err, (needle, err)
    return err


def test_scene_with_a_typo(tmp_path, capsys):
    bad = tmp_path / "typo.toml"
    bad.write_text(TINY.read_text().replace("focus_distance_m", "focus_distanse_m"))
    _expect_user_error(["plan", bad], capsys, str(bad), "[camera]", "focus_distanse_m")


def test_negative_aperture(tmp_path, capsys):
    bad = tmp_path / "neg.toml"
    bad.write_text(TINY.read_text().replace("f_number = 0.5", "f_number = -0.5"))
    _expect_user_error(["plan", bad], capsys, str(bad), "f_number", "-0.5")


def _edited_input(src, tmp_path, name, **change):
    img = read_labelled(src)
    fields = dict(rgb=img.rgb, alpha=img.alpha, depth=img.depth, camera=img.camera)
    fields.update(change)
    path = tmp_path / name
    write_labelled(path, LabelledImage(**fields))
    return path


def test_exr_without_z(tiny_input, tiny_db, tmp_path, capsys):
    import OpenEXR

    with OpenEXR.File(str(tiny_input)) as f:
        header = dict(f.header())
        channels = {k: v.pixels for k, v in f.channels().items() if k != "Z"}
    no_z = tmp_path / "noz.exr"
    with OpenEXR.File(header, channels) as f:
        f.write(str(no_z))
    out = tmp_path / "out.exr"
    _expect_user_error(["render", no_z, "--db", tiny_db, "--out", out], capsys, str(no_z), "Z")
    assert not out.exists() and list(tmp_path.iterdir()) == [no_z]


def test_nan_depth(tiny_input, tiny_db, tmp_path, capsys):
    z = read_labelled(tiny_input).depth.copy()
    z[3, 5] = np.nan
    bad = _edited_input(tiny_input, tmp_path, "nan.exr", depth=z)
    out = tmp_path / "out.exr"
    _expect_user_error(["render", bad, "--db", tiny_db, "--out", out], capsys, "nan", str(bad))
    assert not out.exists()


def test_coc_beyond_the_database(tiny_input, tiny_db, tmp_path, capsys):
    """A camera opened further than the database was built for: say the radius needed."""
    img = read_labelled(tiny_input)
    bad = _edited_input(tiny_input, tmp_path, "wide.exr", camera=dict(img.camera, f_number=0.1))
    out = tmp_path / "out.exr"
    _expect_user_error(["render", bad, "--db", tiny_db, "--out", out], capsys, "database range", "rebuild")
    assert not out.exists()


def test_truncated_database(tiny_input, tiny_db, tmp_path, capsys):
    cut = tmp_path / "cut.spdb"
    cut.write_bytes(tiny_db.read_bytes()[: tiny_db.stat().st_size // 2])
    out = tmp_path / "out.exr"
    _expect_user_error(["render", tiny_input, "--db", cut, "--out", out], capsys, str(cut), "precompute")
    assert not out.exists()


def test_database_for_another_model(tiny_input, tiny_db, tmp_path, capsys):
    db = SpreadletDatabase.load(tiny_db)
    other = tmp_path / "other.spdb"
    fields = {k: getattr(db, k) for k in ("params", "grid", "channels", "psf_resolution", "C", "P", "V",
                                          "fast_track", "dense_radius", "dense_offsets", "dense_values",
                                          "stats")}
    SpreadletDatabase(model="volume", **fields).save(other)
    out = tmp_path / "out.exr"
    # a volume database has a coordinate map, but not these coordinates
    _expect_user_error(["render", tiny_input, "--db", other, "--out", out], capsys, "volume", "distance_m")
    assert not out.exists()


def test_missing_scene_file(tmp_path, capsys):
    _expect_user_error(["plan", tmp_path / "nope.toml"], capsys, "scene file", "nope.toml: no such file")


def test_a_database_for_another_aperture(tiny_input, tiny_db, tmp_path, capsys):
    """The tiny database traced a round aperture; an input whose camera has an iris is refused."""
    image = read_labelled(tiny_input)
    iris = tmp_path / "iris.exr"
    write_labelled(iris, dataclasses.replace(image, camera=dict(image.camera, aperture={
        "blades": 6, "rotation_deg": 0.0, "rounding": 0.0})))
    out = tmp_path / "out.exr"
    _expect_user_error(["render", iris, "--db", tiny_db, "--out", out], capsys, str(iris), "aperture",
                       "traced for aperture = None")
    assert not out.exists()


def test_a_database_without_the_inputs_medium(tiny_input, tiny_db, tmp_path, capsys):
    """An input that asks for fog is refused by a lens database, which would drop the fog silently."""
    image = read_labelled(tiny_input)
    fog = tmp_path / "fog.exr"   # a pinhole's input, as a fog scene writes it
    write_labelled(fog, dataclasses.replace(image, camera={"lens": "pinhole", "fov_x_deg": 20.0, "medium": {
        "sigma_t": 0.25, "albedo": [0.9, 0.9, 0.9], "g": 0.6}}))
    out = tmp_path / "out.exr"
    _expect_user_error(["render", fog, "--db", tiny_db, "--out", out], capsys, str(fog), "medium = {", "'sigma_t': 0.25",
                       "traced for medium = None")
    assert not out.exists()


@pytest.mark.parametrize("command", ["reference", "report"])
@pytest.mark.parametrize("option, needles", [
    (["--workers", "0"], ["--workers 0", "integer >= 1"]),
    (["--workers", "two"], ["--workers 'two'", "integer >= 1"]),
    (["--scheduler", "localhost:8786"], ["--scheduler 'localhost:8786'", "tcp://"])])
def test_bad_workers_or_scheduler(command, option, needles, tmp_path, capsys, monkeypatch):
    """Refused in one line before anything renders (the cache stays empty)."""
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    _expect_user_error([command, TINY, *option], capsys, *needles)
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("command", ["reference", "report"])
def test_help_explains_where_passes_run(command, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--workers N" in text and "--scheduler tcp://HOST:PORT" in text and "Dask" in text


def test_bench_runtime_without_reference(tiny_report, e2e_cache, tmp_path, monkeypatch, capsys):
    """`bench runtime --no-build --passes ...`: the plan's passes named, timed against the first,
    with no reference rendered (the warm cache has the input and database; a reference render
    would add a reference.exr); an unknown pass exits 2 naming the plan's."""
    import json

    from lab.bench import output

    monkeypatch.setenv("SPLATLAB_CACHE", str(e2e_cache))
    monkeypatch.setattr(output, "BENCH_DIR", tmp_path / "bench")
    (ref,) = sorted(e2e_cache.glob("renders/*/reference.exr"))
    ref.rename(ref.with_suffix(".kept"))   # a bench that wanted the reference would render it again
    try:
        code, stdout, _ = run(["bench", "runtime", "--scene", TINY, "--repeats", 1, "--no-build",
                               "--passes", "spreadlets,splat"], capsys)
        assert code == 0 and not ref.exists()
    finally:
        ref.with_suffix(".kept").rename(ref)
    data = json.loads((tmp_path / "bench" / "runtime-latest.json").read_text())
    assert list(data["methods"]) == ["spreadlets", "splat"]
    assert data["methods"]["splat"]["ssim"] is None and data["ratios"]["splat_time_over_spreadlets"] > 0
    code, _, err = run(["bench", "runtime", "--scene", TINY, "--no-build", "--passes", "spreadlets,nope"], capsys)
    assert code == 2 and "['nope'] not in the plan" in err and "'filter'" in err


def test_report_layers_renders_the_spreadlet_passes_in_depth_layers(tiny_report, e2e_cache, tmp_path, capsys,
                                                                      monkeypatch):
    """`splatlab report SCENE --layers 2`: the spreadlet passes again in 2 depth layers, beside one."""
    import json

    monkeypatch.setenv("SPLATLAB_CACHE", str(e2e_cache))
    code, out, _ = run(["report", TINY, "--layers", "2", "--no-noise-floor", "--out-dir", tmp_path], capsys)
    assert code == 0, out
    methods = json.loads((tmp_path / "report.json").read_text())["methods"]
    assert {"spreadlets_layers", "splat_layers", "filter_layers"} <= set(methods)
    one, _ = tiny_report
    assert "spreadlets_layers" not in one["methods"]
    assert abs(methods["spreadlets_layers"]["ssim"] - one["methods"]["spreadlets"]["ssim"]) < 0.05
    assert "spreadlets_layers" in out


@pytest.mark.parametrize("layers", ["0", "17"])
def test_report_layers_out_of_range(layers, tmp_path, capsys):
    _expect_user_error(["report", TINY, "--layers", layers, "--out-dir", tmp_path], capsys, f"--layers {layers}",
                       "between 1 and 16")
