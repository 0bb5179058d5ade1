"""The occlusion scene end to end (slow): Mitsuba polygon-iris reference, flat and layered input,
the three polygon passes, SSIM and PNGs in the report; at 96 px wide instead of 256."""
import json

import pytest

from lab.paths import SCENES

SCENE = SCENES / "occlusion.toml"


@pytest.mark.slow
def test_occlusion_report(tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    from lab.pipeline import run_report

    text = SCENE.read_text()
    for old, new in (("resolution = [256, 256]", "resolution = [96, 96]"),
                     ("reference_spp = 1024", "reference_spp = 256"), ("input_spp = 64", "input_spp = 32")):
        assert old in text
        text = text.replace(old, new)
    scene = tmp_path / "occlusion.toml"
    scene.write_text(text)
    out = tmp_path / "report"
    report = run_report(scene, out, progress=False)
    methods = report["methods"]
    assert list(methods) == ["polygon", "polygon_layers", "polygon_layered_input"]
    for name, m in methods.items():
        assert (out / m["image"]).stat().st_size > 0 and (out / m["error_image"]).stat().st_size > 0
        assert m["time_ms"] > 0 and 0.5 < m["ssim"] <= 1
    assert methods["polygon_layered_input"]["counts"]["input_layers"] == 3
    # occlusion helps: layers from the flat image, more so with what the foreground hides
    assert methods["polygon_layers"]["ssim"] > methods["polygon"]["ssim"]
    assert methods["polygon_layered_input"]["ssim"] > methods["polygon_layers"]["ssim"]
    saved = json.loads((out / "report.json").read_text())
    assert saved["plan"]["effects"]["aperture"].startswith("polygon (6 blades")
    assert saved["database"] == {}
