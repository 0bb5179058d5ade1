"""LSR18 Table 3's pieces: the BM3D baseline's tonemap round trip and noise level, and the whole table on a tiny scene."""
import json

import numpy as np
import pytest

from lab.paths import SCENES
from lab.report.metrics import psnr, tonemap
from lab.report.table3 import bm3d_denoise, inverse_tonemap, main


def test_inverse_tonemap():
    x = np.linspace(0.0, 1.0, 1001)
    np.testing.assert_allclose(inverse_tonemap(tonemap(x)), x, atol=1e-6)   # float32 result


def test_bm3d_denoises_with_the_oracle_sigma():
    rng = np.random.default_rng(0)
    ys, xs = np.mgrid[0:64, 0:64] / 64.0
    clean = np.stack([0.2 + 0.5 * xs, 0.3 + 0.3 * ys, 0.4 * np.ones_like(xs)], axis=-1) ** 2.2
    shown = np.clip(tonemap(clean) + rng.normal(0, 0.08, clean.shape), 0, 1)
    noisy = inverse_tonemap(shown)
    denoised, sigma = bm3d_denoise(noisy, clean)
    assert sigma == pytest.approx(0.08, rel=0.1)       # clipping at 0 and 1 trims the tails a little
    assert psnr(denoised, clean) > psnr(noisy, clean) + 6.0


def test_sizing_image_keeps_the_frame_and_spans_every_input():
    """The databases are sized by the input's frame (a lens's PSFs depend on where a pixel lies)
    with the depth and motion ranges of the input and the stochastic images together."""
    from lab.exr_io import LabelledImage
    from lab.report.table3 import sizing_image

    rng = np.random.default_rng(1)

    def image(lo, hi, m):
        return LabelledImage(rng.random((6, 8, 3), dtype=np.float32), np.ones((6, 8), np.float32),
                             rng.uniform(lo, hi, (6, 8)).astype(np.float32), {"lens": "pinhole"},
                             {"motion.X": rng.uniform(-m, m, (6, 8)).astype(np.float32),
                              "motion.Y": np.zeros((6, 8), np.float32)})

    base, inputs = image(2.0, 3.0, 1.0), [image(1.0, 2.5, 4.0), image(2.5, 9.0, 0.5)]
    inputs[1].depth[0, 0] = np.inf   # a stochastic sample that saw no surface
    sized = sizing_image(base, inputs)
    assert sized.depth.shape == (6, 8) and sized.rgb is base.rgb
    far = inputs[1].depth[np.isfinite(inputs[1].depth)].max()
    assert sized.depth.min() == min(x.depth.min() for x in inputs) and sized.depth.max() == far
    mx = [x.extra["motion.X"] for x in [base] + inputs]
    assert sized.extra["motion.X"].min() == min(a.min() for a in mx) and sized.extra["motion.X"].max() == max(a.max() for a in mx)
    assert np.count_nonzero(sized.depth != base.depth) <= 2
    inputs[0].extra["Z.R"] = np.full((6, 8), 0.5, np.float32)   # a thick lens's red ray hit nearer
    assert sizing_image(base, inputs).depth.min() == 0.5


@pytest.mark.slow
def test_table3_on_a_tiny_scene(tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    assert main([str(SCENES / "tiny.toml"), "--size", "32", "--out", str(tmp_path / "t3")]) == 0
    data = json.loads((tmp_path / "t3" / "report.json").read_text())
    row = data["scenes"][0]
    assert {"stochastic_spreadlets@1", "stochastic_spreadlets+norm@1", "stochastic_spreadlets+fill@1",
            "stochastic_splat+fill@1", "bm3d@1", "input@1"} <= set(row["methods"])
    # reconstruction denoises: better than the 1-spp input it started from
    assert row["methods"]["stochastic_spreadlets@1"]["ssim"] > row["methods"]["input@1"]["ssim"]
    assert (tmp_path / "t3" / "index.html").exists()


@pytest.mark.slow
def test_table3_on_a_guarded_scene_reconstructs_the_frame(tmp_path, monkeypatch):
    """A scene with the guard band: Table 3 reconstructs the stochastic frame with the frame's own
    camera and databases (the passes re-centre what lies outside it themselves), so it renders the
    unguarded labelled input, not the guarded one, whose header is a wider sensor's."""
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    assert main([str(SCENES / "tiny_guard.toml"), "--no-4spp", "--out", str(tmp_path / "t3")]) == 0
    row = json.loads((tmp_path / "t3" / "report.json").read_text())["scenes"][0]
    assert row["size"] == [48, 48]
    assert row["methods"]["stochastic_spreadlets+norm@1"]["ssim"] > row["methods"]["input@1"]["ssim"] + 0.1
    rendered = {p.name for p in (tmp_path / "cache" / "renders").glob("*/*.exr")}
    assert "input.exr" in rendered and "input_guard.exr" not in rendered, rendered
