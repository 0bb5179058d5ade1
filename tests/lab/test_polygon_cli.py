"""``splatlab render --method polygon`` and ``splatlab bench polygon`` (the lab side of the runtime)."""
import json

import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from lab.polygon_aperture import coc_radius, polygon_aperture

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 1.4, "focus_distance_m": 0.25,
          "sensor_width_mm": 36.0}   # a 40-px-wide macro shot: the background's CoC is ~4 px


@pytest.fixture(scope="module")
def labelled(tmp_path_factory):
    rng = np.random.default_rng(0)
    h, w = 24, 40
    depth = np.where(np.arange(w)[None, :] < 20, 0.25, 2.0) * np.ones((h, 1))  # in focus | behind
    image = LabelledImage(rgb=rng.random((h, w, 3)).astype(np.float32),
                          alpha=np.ones((h, w), np.float32), depth=depth.astype(np.float32),
                          camera=CAMERA)
    path = tmp_path_factory.mktemp("polygon") / "input.exr"
    write_labelled(path, image)
    return path, image


def test_render_polygon_matches_the_runtime(labelled, tmp_path, capsys):
    path, image = labelled
    out = tmp_path / "out.exr"
    assert main(["render", str(path), "--method", "polygon", "--aperture", "octagon",
                 "--out", str(out)]) == 0
    assert "polygon (octagon" in capsys.readouterr().out
    radius = coc_radius(image)
    assert radius[:, :20].max() == 0 and radius[:, 20:].min() > 2    # left half in focus
    want, _ = polygon_aperture("octagon").splatter.render(image.rgb, radius)
    got = read_rgb(out)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got[:, :10], image.rgb[:, :10])   # far from the blur: untouched


def test_render_errors_name_the_option(labelled, tmp_path, capsys):
    path, _ = labelled
    assert main(["render", str(path), "--method", "polygon", "--aperture", "circle",
                 "--out", str(tmp_path / "x.exr")]) == 2
    assert "--aperture 'circle'" in capsys.readouterr().err
    assert main(["render", str(path), "--method", "spreadlets", "--out", str(tmp_path / "x.exr")]) == 2
    assert "--db" in capsys.readouterr().err
    assert main(["render", str(path), "--method", "polygon", "--edges", "2",
                 "--out", str(tmp_path / "x.exr")]) == 2
    assert "max_edges" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_polygon_quick(monkeypatch, tmp_path):
    import lab.bench as bench

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["bench", "polygon", "--quick", "--repeats", "1"]) == 0
    data = json.loads((tmp_path / "polygon-latest.json").read_text())
    assert data["b_methods"]["rows"][0]["dense"]["bit_identical_to_polygon"]
    assert data["b_methods"]["rows"][0]["dxdy"]["bit_identical_to_polygon"]
    for shape in data["c_uniform_vs_fft"].values():
        assert all(row["max_abs_diff_vs_fft"] < 1e-5 for row in shape["rows"])
