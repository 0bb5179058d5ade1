"""``splatlab render --method polygon`` and ``splatlab bench polygon`` (the lab side of the runtime)."""
import json

import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from lab.polygon_aperture import polygon_aperture
from runtime_cl.camera.thin_lens import ThinLens

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
    radius = np.abs(ThinLens.from_json(CAMERA).coc_radius_px(image.depth, image.width)).astype(np.float32)
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
    assert "--edges 2: the rectified aperture" in capsys.readouterr().err


def test_bench_dof_scene_radius_map():
    """The Fig. 13 scene: depths where the geometry puts them, f-number scaled to the largest R."""
    from lab.bench.polygon import dof_scene_depth, scene_radius

    h, w, fov = 270, 480, 40.0
    z = dof_scene_depth(h, w, fov)
    f = 0.5 * w / np.tan(np.radians(fov) / 2)
    cx, cy, cz, r = 0.1, -0.25, 3.0, 0.35          # the subject in focus, seen through its centre
    col, row = int(w / 2 + f * cx / cz), int(h / 2 - f * cy / cz)
    assert z[row, col] == pytest.approx(cz - r * cz / np.sqrt(cx * cx + cy * cy + cz * cz), rel=0.01)
    assert z[0, 0] == 30.0 and z.min() > 0.9     # the wall in a corner; nothing nearer than 0.9 m
    radius = scene_radius(z, 50.0)
    assert radius.max() == pytest.approx(50.0) and radius[row, col] < 0.1 * 50


@pytest.mark.slow
def test_bench_polygon_quick(monkeypatch, tmp_path):
    import lab.bench.output as bench

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["bench", "polygon", "--quick", "--repeats", "1"]) == 0
    data = json.loads((tmp_path / "polygon-latest.json").read_text())
    assert data["b_methods"]["rows"][0]["dense"]["bit_identical_to_polygon"]
    assert data["b_methods"]["rows"][0]["dxdy"]["bit_identical_to_polygon"]
    for shape in data["c_uniform_vs_fft"].values():
        assert all(row["max_abs_diff_vs_fft"] < 1e-5 for row in shape["rows"])


@pytest.fixture(scope="module")
def layered_exr(tmp_path_factory):
    """A camera with a 6-blade iris; layer 0 a defocused foreground square, layer 1 the background."""
    rng = np.random.default_rng(1)
    h, w = 24, 40
    fg = np.zeros((h, w), np.float32)
    fg[6:18, 8:20] = 1.0
    bg_rgb = rng.random((h, w, 3)).astype(np.float32)
    fg_rgb = np.float32([0.9, 0.1, 0.1]) * fg[..., None]
    extra = {"layer0.R": fg_rgb[..., 0], "layer0.G": fg_rgb[..., 1], "layer0.B": fg_rgb[..., 2], "layer0.A": fg,
             "layer0.Z": np.where(fg > 0, 0.2, np.inf).astype(np.float32),
             "layer1.R": bg_rgb[..., 0], "layer1.G": bg_rgb[..., 1], "layer1.B": bg_rgb[..., 2],
             "layer1.A": np.ones((h, w), np.float32), "layer1.Z": np.full((h, w), 0.25, np.float32)}
    flat = fg_rgb + (1 - fg[..., None]) * bg_rgb
    image = LabelledImage(rgb=flat, alpha=np.ones((h, w), np.float32),
                          depth=np.where(fg > 0, 0.2, 0.25).astype(np.float32),
                          camera=dict(CAMERA, aperture={"blades": 6, "rotation_deg": 0.0, "rounding": 0.0}),
                          extra=extra)
    path = tmp_path_factory.mktemp("layered") / "layered.exr"
    write_labelled(path, image)
    return path, image


def test_render_layers_uses_the_layered_input_and_the_header_iris(layered_exr, tmp_path, capsys):
    from lab.optics.iris import Iris
    from lab.polygon_aperture import iris_aperture
    from runtime_cl.layers.composite import PixelLayer, render_layers
    from runtime_cl.polygon.layers import PolygonLayerSplatter

    path, image = layered_exr
    out = tmp_path / "out.exr"
    assert main(["render", str(path), "--method", "polygon", "--layers", "3", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "polygon (iris6" in said and "of 3 depth layers used (layered input)" in said
    lens, splatter = ThinLens.from_json(image.camera), iris_aperture(Iris(6)).splatter
    coc = [lens.coc_radius_px(x.depth, image.width).astype(np.float32) for x in image.layers()]
    want, info = render_layers(PolygonLayerSplatter(splatter),
                               [PixelLayer(x.rgb, x.alpha, c) for x, c in zip(image.layers(), coc)], 3)
    np.testing.assert_array_equal(read_rgb(out), want)
    assert [x["index"] for x in info["layers"]] == [0, 2]           # foreground and background only
    flat, _ = render_layers(PolygonLayerSplatter(splatter), PixelLayer(
        image.rgb, image.alpha, lens.coc_radius_px(image.depth, image.width).astype(np.float32)), 3)
    assert np.abs(flat - want).max() > 0.05                           # the layers matter
    assert main(["render", str(path), "--method", "polygon", "--out", str(out)]) == 0
    assert "depth layers" not in capsys.readouterr().out


def test_render_layers_errors_name_the_option(layered_exr, tmp_path, capsys):
    path, _ = layered_exr
    out = str(tmp_path / "x.exr")
    assert main(["render", str(path), "--method", "polygon", "--layers", "0", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "--layers 0" in err and ">= 1" in err and len(err.splitlines()) == 1
    assert main(["render", str(path), "--method", "identity", "--layers", "2", "--out", out]) == 2
    assert "--layers 2: depth layers are for --method spreadlets / splat / filter / polygon" in \
        capsys.readouterr().err
    assert not (tmp_path / "x.exr").exists()
