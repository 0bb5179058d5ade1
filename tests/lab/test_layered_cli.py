"""``splatlab render --method layered``: lens rays through an EXR's layerN.* layers, bad input in one line."""
import numpy as np
import pytest

import runtime_cl
from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.frame import Frame

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 1.0, "focus_distance_m": 1.0,
          "sensor_width_mm": 36.0}   # 96 px wide: 3.5 px per dioptre


@pytest.fixture(scope="module")
def layered_exr(tmp_path_factory):
    """A grey bar at 0.4 m over a blue wall at 10 m that is red behind the bar (layer 1)."""
    h, w = 24, 96
    bar = np.zeros((h, w), bool)
    bar[:, 46:50] = True
    wall = np.zeros((h, w, 3), np.float32)
    wall[..., 2] = 1.0
    wall[bar] = (1.0, 0.0, 0.0)
    flat = np.where(bar[..., None], np.float32(0.2), wall)
    z = np.where(bar, 0.4, 10.0).astype(np.float32)
    extra = {}
    for k, (rgb, alpha, depth) in enumerate(((flat, np.ones((h, w)), z),
                                             (wall * bar[..., None], bar * 1.0, np.where(bar, 10.0, np.inf)))):
        extra.update({f"layer{k}.{c}": np.asarray(rgb[..., i], np.float32) for i, c in enumerate("RGB")})
        extra[f"layer{k}.A"], extra[f"layer{k}.Z"] = np.asarray(alpha, np.float32), np.asarray(depth, np.float32)
    image = LabelledImage(flat, np.ones((h, w), np.float32), z, CAMERA, extra)
    path = tmp_path_factory.mktemp("layered") / "input.exr"
    write_labelled(path, image)
    return path, image


def test_render_layered_traces_the_exr_layers(layered_exr, tmp_path, capsys):
    path, image = layered_exr
    out = tmp_path / "out.exr"
    assert main(["render", str(path), "--method", "layered", "--rays", "32", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "32 rays per pixel through 2 layer(s)" in said
    layers = [Frame(x.rgb, x.depth, alpha=x.alpha) for x in image.layers()]
    want, _ = runtime_cl.render(image.rgb, image.depth, ThinLens.from_json(CAMERA), method="layered", rays=32,
                                layered_input=True, input_layers=layers)
    got = read_rgb(out)
    np.testing.assert_array_equal(got, want)
    assert (got[:, 46:50, 0] - got[:, 46:50, 1]).mean() > 0.05     # the red hidden behind the bar
    assert main(["render", str(path), "--method", "layered", "--layers", "1", "--out", str(out)]) == 0
    assert "through 1 layer(s)" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--method", "layered", "--rays", "0"], "rays = 0: the number of lens rays per pixel must be an integer >= 1"),
    (["--method", "layered", "--rays", "many"], "rays = 'many'"),
    (["--method", "polygon", "--rays", "8"], "--rays 8: --method polygon traces no lens rays"),
])
def test_bad_rays_exit_2_in_one_line(layered_exr, tmp_path, capsys, args, message):
    path, _ = layered_exr
    assert main(["render", str(path), *args, "--out", str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
