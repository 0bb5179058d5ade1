"""`splatlab precompute MODEL|SCENE`: targets, --set parsing, and bad input refused before tracing."""
from pathlib import Path

import pytest

from lab.cli import main
from lab.errors import UserError
from lab.paths import SCENES
from lab.precompute.target import load_target_model, parse_sets, resolve_target

from precompute_helpers import SMALL, small_sets


def test_set_values_are_toml_literals_or_bare_strings():
    table = parse_sets(["a=64", "b=2.5", "c=true", "d=[2.0, 1]", "e=hexagon", 'f="x y"', "g = 3"])
    assert table == {"a": 64, "b": 2.5, "c": True, "d": [2.0, 1], "e": "hexagon", "f": "x y", "g": 3}
    assert isinstance(table["a"], int) and isinstance(table["b"], float)


@pytest.mark.parametrize("items, needle", [
    (["max_coc_px"], "expected KEY=VALUE"),
    (["=3"], "expected KEY=VALUE"),
    (["9x=3"], "expected KEY=VALUE"),
    (["seed=1", "seed=2"], "given twice"),
])
def test_bad_set_items(items, needle):
    with pytest.raises(UserError, match=needle):
        parse_sets(items)


def test_targets():
    assert resolve_target("simple_lens").kind == "model"
    scene = resolve_target(str(SCENES / "tiny.toml"))
    assert scene.kind == "scene" and scene.path.name == "tiny.toml"
    assert resolve_target("missing.toml").kind == "scene"  # the scene loader names the missing file
    with pytest.raises(UserError, match=r"'simple_lense'.*not a registered PSF model.*simple_lens"):
        resolve_target("simple_lense")


def test_model_settings_are_validated():
    model = load_target_model("simple_lens", small_sets() + ["seed=5", "aperture=circle"])
    assert model.config.seed == 5 and model.config.max_coc_px == SMALL["max_coc_px"]
    with pytest.raises(UserError, match=r"unknown key\(s\) \['max_coc'\].*known keys.*max_coc_px"):
        load_target_model("simple_lens", ["max_coc=8"])
    with pytest.raises(UserError, match=r"missing key\(s\) \['max_coc_px'\]"):
        load_target_model("simple_lens", [])
    with pytest.raises(UserError, match=r"max_coc_px = -3.0.*> 0"):
        load_target_model("simple_lens", ["max_coc_px=-3"])
    with pytest.raises(UserError, match=r"psf_resolution = 9 cannot hold.*psf_resolution >= 17"):
        load_target_model("simple_lens", ["max_coc_px=6", "psf_resolution=9"])


@pytest.mark.parametrize("argv, needles", [
    (["simple_lens", "--set", "max_coc_px=-3"], ["max_coc_px = -3.0"]),
    (["simple_lens", "--set", "max_coc_px=6", "--set", "bogus=1"], ["bogus"]),
    (["nope"], ["'nope'", "simple_lens"]),
    (["simple_lens", "--set", "max_coc_px=6", "--workers", "0"], ["--workers 0"]),
    (["simple_lens", "--set", "max_coc_px=6", "--scheduler", "localhost:8786"], ["tcp://"]),
    (["simple_lens", "--set", "max_coc_px=6", "--threads", "0"], ["--threads 0"]),
    ([str(SCENES / "tiny.toml"), "--set", "seed=1"], ["--set", "[psf.<model>]"]),
    ([str(SCENES / "no-such-scene.toml")], ["no-such-scene.toml"]),
])
def test_bad_input_exits_2_before_tracing(argv, needles, cache, capsys):
    code = main(["precompute", *argv, "--quiet"])
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert len(err.strip().splitlines()) == 1, err
    for needle in needles:
        assert needle in err, (needle, err)
    assert not Path(cache).exists()  # nothing traced, rendered or cached


def test_a_scene_target_renders_its_input_and_not_its_reference(cache, capsys):
    """`splatlab precompute SCENE` needs the scene's labelled-pixel input (its CoC range); the
    reference is for `splatlab reference|report` (whirl_iris's took 11 minutes)."""
    tiny = SCENES / "tiny.toml"
    assert main(["precompute", str(tiny), "--quiet"]) == 0
    assert [s for s in capsys.readouterr().out.splitlines() if s.startswith("simple_lens:")]
    rendered = sorted(p.name for p in Path(cache).glob("renders/*/*"))
    assert rendered == ["input.exr"], rendered
