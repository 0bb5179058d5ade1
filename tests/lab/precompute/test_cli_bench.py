"""`splatlab precompute MODEL` end to end, and `splatlab bench precompute` on a small model."""
import json

import pytest

from lab.cli import main
from lab.errors import UserError
from runtime_cl.database import SpreadletDatabase

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
    from lab import bench

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path / "bench")
    path = bench.bench_precompute(1, models="simple_lens", tables={"simple_lens": SMALL})
    data = json.loads(path.read_text())
    entry = data["models"]["simple_lens"]
    assert entry["trace"]["mrays_per_second"] > 0 and entry["trace"]["n_rays"] == SMALL["rays_per_psf"]
    assert entry["build"]["seconds"] > 0 and entry["build"]["cells"] == entry["table1"]["samples"]
    assert entry["sparsify_largest"]["seconds"] > 0
    assert (tmp_path / "bench" / "atlas" / "simple_lens" / "atlas.png").exists()
    assert "simple_lens (ours)" in (tmp_path / "bench" / "table1.md").read_text()
    assert json.loads((tmp_path / "bench" / "precompute-latest.json").read_text())["models"]


def test_bench_models_filter_is_validated(tmp_path, monkeypatch):
    from lab import bench

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path / "bench")
    with pytest.raises(UserError, match=r"--models 'simple_lens,nope'.*\['nope'\].*registered"):
        bench.bench_precompute(1, models="simple_lens,nope")
    with pytest.raises(UserError, match="--workers 0"):
        bench.bench_precompute(1, models="simple_lens", workers=0)
    assert not (tmp_path / "bench").exists()


def test_bench_records_a_model_that_needs_settings(cache, tmp_path, monkeypatch):
    """A model whose defaults are not enough is reported, not fatal to the other models."""
    from lab import bench

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path / "bench")
    path = bench.bench_precompute(1, models="simple_lens", build=False, tables={})
    entry = json.loads(path.read_text())["models"]["simple_lens"]
    assert "max_coc_px" in entry["error"]
