"""The sweep's lens-rays knob on the peeled foreground scene: more rays, closer to the reference."""
import pytest

from lab.paths import SCENES
from lab.report.knobs import select_knobs

pytestmark = pytest.mark.slow    # peeling, the reference, a database and eight layered renders: ~1 min


def test_lens_rays_move_ssim_up(tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    from lab.pipeline import run_report

    report = run_report(SCENES / "tiny_foreground.toml", tmp_path / "out", progress=False,
                        sweep=select_knobs(["lens_rays", "layers", "traced_layers"]))
    rays = [p for p in report["sweep"]["points"] if p["method"] == "layered" and p["knob"] == "lens_rays"]
    assert [p["value"] for p in rays] == [8, 32, 64, 128]       # the scene's 64 rays, 1/8x .. 2x
    print("lens rays -> SSIM, ms:", [(p["value"], round(p["ssim"], 4), round(p["time_ms"], 2)) for p in rays])
    # 8 jittered lens rays leave the bokeh grainy; 128 average it out (each pixel's mean over N rays has
    # variance ~1/N). Measured SSIM in `sweep_foreground` of the closing note; the gap is several times
    # the .01 seed jitter of the reference.
    assert rays[-1]["ssim"] > rays[0]["ssim"] + 0.02
    assert rays[-1]["time_ms"] > rays[0]["time_ms"]             # more rays cost more time
    # the layered pass traces the input's own layers: their count is its knob, not `layers`
    traced = [p for p in report["sweep"]["points"] if p["knob"] == "traced_layers"]
    assert [p["value"] for p in traced] == [1, 2, 4, 8] and {p["method"] for p in traced} == {"layered"}
    skipped = {(s["method"], s["knob"]): s["reason"] for s in report["sweep"]["skipped"]}
    assert "renders no depth layers of its own" in skipped[("layered", "layers")]
