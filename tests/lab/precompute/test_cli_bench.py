"""`splatlab precompute MODEL` end to end, and `splatlab bench precompute` on a small model."""
import json
from pathlib import Path

import pytest

from lab.cli import main
from lab.errors import UserError
from lab.paths import SCENES
from runtime_cl.psf.database import SpreadletDatabase

from precompute_helpers import SMALL, assert_same_database, cli_sets


def test_precompute_model_by_name_with_out_and_atlas(reference, tmp_path, monkeypatch, capsys):
    ref, ref_cache = reference
    monkeypatch.setenv("SPLATLAB_CACHE", str(ref_cache))
    out, atlas = tmp_path / "copy.spdb", tmp_path / "atlas"
    code = main(["precompute", "simple_lens", *cli_sets(), "--quiet", "--out", str(out), "--atlas", str(atlas)])
    stdout, _ = capsys.readouterr()
    assert code == 0
    assert f"simple_lens: {ref.path} (reused)" in stdout and f"copied to {out}" in stdout
    assert_same_database(SpreadletDatabase.load(out), ref)
    assert (atlas / "simple_lens" / "atlas.png").stat().st_size > 1000
    assert "simple_lens (ours)" in (atlas / "simple_lens" / "table.md").read_text()


def test_precompute_prints_progress_and_pace(cache, capsys):
    code = main(["precompute", "simple_lens", *cli_sets(), "--set", "seed=3"])
    stdout, stderr = capsys.readouterr()
    assert code == 0
    assert "built in" in stdout and "M rays/s per worker" in stdout and "PSFs on serial" in stdout
    assert "precompute simple_lens" in stderr and "ray/s" in stderr and f"PSF 10/10" in stderr


def test_bench_precompute_small(cache, tmp_path, monkeypatch):
    from lab.bench import output, precompute as bench

    monkeypatch.setattr(output, "BENCH_DIR", tmp_path / "bench")
    path = bench.bench_precompute(1, models="simple_lens", tables={"simple_lens": SMALL})
    data = json.loads(path.read_text())
    entry = data["models"]["simple_lens"]
    assert entry["trace"]["mrays_per_second"] > 0 and entry["trace"]["n_rays"] == SMALL["rays_per_psf"]
    assert entry["build"]["seconds"] > 0 and entry["build"]["cells"] == entry["table1"]["samples"]
    assert entry["build"]["trace_seconds"] > 0 and entry["build"]["sparsify_seconds"] > 0
    assert (tmp_path / "bench" / "atlas" / "simple_lens" / "atlas.png").exists()
    assert "simple_lens (ours)" in (tmp_path / "bench" / "table1.md").read_text()
    assert json.loads((tmp_path / "bench" / "precompute-latest.json").read_text())["models"]


def test_bench_models_filter_is_validated(tmp_path, monkeypatch):
    from lab.bench import output, precompute as bench

    monkeypatch.setattr(output, "BENCH_DIR", tmp_path / "bench")
    with pytest.raises(UserError, match=r"--models 'simple_lens,nope'.*\['nope'\].*registered"):
        bench.bench_precompute(1, models="simple_lens,nope")
    with pytest.raises(UserError, match="--workers 0"):
        bench.bench_precompute(1, models="simple_lens", workers=0)
    assert not (tmp_path / "bench").exists()


def test_bench_records_a_model_that_needs_settings(cache, tmp_path, monkeypatch):
    """A model whose defaults are not enough is reported, not fatal to the other models."""
    from lab.bench import output, precompute as bench

    monkeypatch.setattr(output, "BENCH_DIR", tmp_path / "bench")
    path = bench.bench_precompute(1, models="simple_lens", build=False, tables={})
    entry = json.loads(path.read_text())["models"]["simple_lens"]
    assert "max_coc_px" in entry["error"]


def test_bench_without_build_times_the_largest_psf(cache, tmp_path, monkeypatch):
    from lab.bench import output, precompute as bench

    monkeypatch.setattr(output, "BENCH_DIR", tmp_path / "bench")
    path = bench.bench_precompute(1, models="simple_lens", build=False, tables={"simple_lens": SMALL})
    entry = json.loads(path.read_text())["models"]["simple_lens"]
    assert "build" not in entry and entry["trace"]["mrays_per_second"] > 0
    assert entry["sparsify_largest"]["seconds"] > 0 and entry["sparsify_largest"]["rays"] >= SMALL["rays_per_psf"]
    assert not list(Path(tmp_path / "bench").glob("table1.md"))


@pytest.mark.slow
def test_precompute_scene_with_workers_matches_serial(cache, tmp_path, capsys):
    """A scene target: its plan's models, configured from its labelled-pixel input, on 2 workers."""
    import shutil

    tiny = str(SCENES / "tiny.toml")
    assert main(["precompute", tiny, "--quiet", "--workers", "2"]) == 0
    (line,) = [s for s in capsys.readouterr().out.splitlines() if s.startswith("simple_lens:")]
    assert "PSFs on processes" in line
    parallel = tmp_path / "parallel.spdb"
    shutil.copyfile(line.split()[1], parallel)
    assert main(["precompute", tiny, "--quiet", "--force"]) == 0
    (line,) = [s for s in capsys.readouterr().out.splitlines() if s.startswith("simple_lens:")]
    assert "PSFs on serial" in line
    assert_same_database(SpreadletDatabase.load(line.split()[1]), SpreadletDatabase.load(parallel))
