"""A stylized camera from scene file to report: ``scenes/tiny_heart.toml`` (heart-shaped bokeh)."""
import json

import pytest

from lab.paths import SCENES
from lab.pipeline import run_report


@pytest.fixture(scope="module")
def heart_report(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("SPLATLAB_CACHE", str(tmp_path_factory.mktemp("cache")))
    out = tmp_path_factory.mktemp("heart")
    yield run_report(SCENES / "tiny_heart.toml", out, progress=False, noise=False), out
    mp.undo()


def test_the_heart_runs_the_stylized_model_against_its_own_reference(heart_report):
    report, out = heart_report
    assert report["plan"]["psf_models"] == ["stylized"] and report["plan"]["effects"]["aperture"] == "heart (stylized)"
    assert report["scene"]["camera"]["aperture"] == {"shape": "heart"}
    db = report["database"]["stylized"]
    assert db["model"] == "stylized" and db["params"]["config"]["aperture"] == "heart"
    assert db["params"]["config"]["channel_scale"] == [1.0, 1.0, 1.0]           # a thin lens: no fringes
    assert db["params"]["fingerprint"] == {"medium": None, "aperture": {"shape": "heart"}}
    methods = report["methods"]
    assert set(methods) == {"spreadlets", "splat", "filter"}
    assert abs(methods["spreadlets"]["ssim"] - methods["splat"]["ssim"]) < 0.02
    assert methods["spreadlets"]["ssim"] > 0.78       # 0.825 measured against the 256-spp reference
    saved = json.loads((out / "report.json").read_text())
    assert saved["methods"]["spreadlets"]["ssim"] == methods["spreadlets"]["ssim"]


def test_a_stochastic_input_through_the_heart_is_reconstructed(heart_report, tmp_path):
    """`splatlab stochastic` traces the heart-shaped lens (its lens samples are points of the
    heart) and `splatlab render --method stochastic_spreadlets` with the stylized database
    re-centres and splats them: the grain of the 1-spp lens sampling is gone (SSIM against the
    path-traced reference 0.28 -> 0.78 measured)."""
    import os
    from pathlib import Path

    from lab.cli import main
    from lab.exr_io import read_labelled, read_rgb
    from lab.report.metrics import ssim

    report, _ = heart_report
    stochastic, out = tmp_path / "stochastic.exr", tmp_path / "reconstructed.exr"
    assert main(["stochastic", str(SCENES / "tiny_heart.toml"), "--shading-spp", "16", "--out", str(stochastic),
                 "--quiet"]) == 0
    image = read_labelled(stochastic)
    assert {"lens.U", "lens.V", "time"} <= set(image.extra)
    assert main(["render", str(stochastic), "--method", "stochastic_spreadlets", "--db",
                 report["database"]["stylized"]["path"], "--set", "normalize=true", "--set", "footprint=bilinear",
                 "--set", "depth_layers=4", "--out", str(out)]) == 0
    (reference,) = Path(os.environ["SPLATLAB_CACHE"]).glob("renders/*/reference.exr")
    reference = read_rgb(reference)
    before, after = ssim(image.rgb, reference), ssim(read_rgb(out), reference)
    assert after > 0.7 and after > before + 0.3, (before, after)
