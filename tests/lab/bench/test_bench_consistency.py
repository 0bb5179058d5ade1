"""The throughput benchmark's figures hold together (issue 14: a bench test must be able to fail):
counts match the work the scene asks for, each rate is its count over its time, the times add up
to the method's time, ratios are the ratios of the reported times and lie within their bounds,
every field the JSON promises is there and finite."""
import json
import math

import numpy as np
import pytest

from lab.bench.spreadlet_throughput import run
from runtime_cl.psf.synthetic import defocus_scene, disc_database

FIELDS = {"pixels", "upload_ms", "compile_ms", "kernel_ms", "download_ms", "integrate_ms", "spreadlets",
          "dense_pixels", "total_ms", "M_spreadlets_per_s", "M_dense_pixels_per_s", "method_ms"}


@pytest.fixture(scope="module")
def bench():
    return run(40, 48, spreadlets=None, r_max=10.0, layout="defocus", repeats=1, samples=16, edge=1.0)


def _numbers(tree, path=""):
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _numbers(v, f"{path}.{k}")
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        yield path, float(tree)


def test_every_field_is_present_finite_and_json(bench):
    assert set(bench["methods"]) == {"spreadlets", "splat", "filter"}
    for name, m in bench["methods"].items():
        assert FIELDS <= set(m), (name, FIELDS - set(m))
        assert m["pixels"] == 40 * 48
    for path, value in _numbers(bench):
        assert math.isfinite(value) and value >= 0, path
    assert json.loads(json.dumps(bench)) == bench                     # plain JSON, round trips


def test_counts_match_the_work_the_scene_asks_for(bench):
    """Spreadlets: every pixel splats its cell's exact Laplacian (all of it); the filter gathers a
    full (2r + 1)^2 window per pixel; the splat at least the disc's pixels of each."""
    db = disc_database(10.0, samples=16, edge=1.0)
    _, coc = defocus_scene(40, 48, 10.0)
    cell = db.grid.index(coc.astype(np.float64))
    sp, splat, gather = (bench["methods"][k] for k in ("spreadlets", "splat", "filter"))
    assert sp["spreadlets"] == np.diff(db.C)[cell].sum() and sp["dense_pixels"] == 0
    nonzero = np.array([np.count_nonzero(np.any(db.dense_psf(i) != 0, axis=-1)) for i in range(db.n_samples)])
    assert splat["dense_pixels"] >= nonzero[cell].sum() and splat["spreadlets"] == 0
    window = (2 * db.dense_radius[cell].astype(np.int64) + 1) ** 2
    assert splat["dense_pixels"] <= window.sum()
    assert gather["dense_pixels"] <= window.sum() and gather["dense_pixels"] >= nonzero[cell].sum()


def test_rates_are_counts_over_times_and_times_add_up(bench):
    for name, m in bench["methods"].items():
        assert m["method_ms"] == pytest.approx(m["kernel_ms"] + m["integrate_ms"] + m["upload_ms"] + m["download_ms"],
                                               rel=1e-12)
        # the call's wall clock holds its event-profiled parts (10 %: two clocks, read apart)
        assert m["total_ms"] >= 0.9 * m["method_ms"]
        if m["dense_pixels"]:
            assert m["M_dense_pixels_per_s"] == pytest.approx(m["dense_pixels"] / m["kernel_ms"] / 1e3, rel=1e-12)
    sp = bench["methods"]["spreadlets"]
    assert sp["kernel_ms"] == pytest.approx(sp["splat_ms"] + sp["merge_ms"], rel=1e-9)
    assert sp["M_spreadlets_per_s"] == pytest.approx(sp["spreadlets"] / sp["splat_ms"] / 1e3, rel=1e-12)
    # a CPU device cannot beat 1e5 M items per second (2 cores at a few GHz, a few items per clock)
    for m in bench["methods"].values():
        assert m["M_spreadlets_per_s"] < 1e5 and m["M_dense_pixels_per_s"] < 1e5


def test_ratios_are_the_ratios_of_the_reported_times(bench):
    sp, splat = bench["methods"]["spreadlets"], bench["methods"]["splat"]
    r = bench["ratios"]
    assert r["splat_over_spreadlets_kernel"] == pytest.approx(splat["kernel_ms"] / sp["kernel_ms"], rel=1e-12)
    assert r["splat_over_spreadlets_method"] == pytest.approx(splat["method_ms"] / sp["method_ms"], rel=1e-12)
    assert r["integrate_share_of_spreadlets"] == pytest.approx(sp["integrate_ms"] / sp["method_ms"], rel=1e-12)
    assert 0 < r["integrate_share_of_spreadlets"] < 1           # a share of a sum of positive parts
