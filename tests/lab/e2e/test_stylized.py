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
    assert db["params"]["fingerprint"] == {"aperture": {"shape": "heart"}}
    methods = report["methods"]
    assert set(methods) == {"spreadlets", "splat", "filter"}
    assert abs(methods["spreadlets"]["ssim"] - methods["splat"]["ssim"]) < 0.02
    assert methods["spreadlets"]["ssim"] > 0.78       # 0.825 measured against the 256-spp reference
    saved = json.loads((out / "report.json").read_text())
    assert saved["methods"]["spreadlets"]["ssim"] == methods["spreadlets"]["ssim"]
