"""`splatlab report --sweep` on the tiny scene, end to end, and its page in headless Chromium.

The sweep turns the spreadlet basis (spreadlets only; the integrator, which a database of row
differences does not take, is skipped with the reason), the lens rays (no pass of this plan
traces any: skipped too) and the reference's samples (the path tracer against the reference). The page is then opened in Debian's Chromium over the DevTools Protocol: every image
must load, the console must stay clean, the tables must sort, and a screenshot is saved.
"""
import json

import numpy as np
import pytest
from PIL import Image

from lab.paths import SCENES
from lab.report.browser import Chromium
from lab.report.knobs import REFERENCE, select_knobs


@pytest.fixture(scope="module")
def sweep_report(e2e_cache, tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("SPLATLAB_CACHE", str(e2e_cache))   # the session's tiny database and renders, shared
    from lab.pipeline import run_report

    out = tmp_path_factory.mktemp("sweep")
    report = run_report(SCENES / "tiny.toml", out, progress=False, noise=True,
                        sweep=select_knobs(["basis", "integrator", "lens_rays", "reference_spp"]))
    yield report, out
    mp.undo()


def points(report, method, knob):
    return [p for p in report["sweep"]["points"] if p["method"] == method and p["knob"] == knob]


def test_more_reference_samples_agree_better_with_the_reference(sweep_report):
    report, _ = sweep_report
    spp = points(report, REFERENCE, "reference_spp")
    assert [p["value"] for p in spp] == [32, 64, 128, 256]
    # Independent seeds: the error is the two renders' noise, which falls as 1/sqrt(spp); measured
    # SSIM .49 / .57 / .66 / .71 (2026-12-02), steps far above the seed-to-seed jitter of ~.01.
    assert all(b["ssim"] > a["ssim"] + 0.02 for a, b in zip(spp, spp[1:]))
    assert all(b["psnr"] > a["psnr"] + 0.5 for a, b in zip(spp, spp[1:]))
    assert spp[-1]["base"] and all(p["time_ms"] > 0 for p in spp)


def test_bases_sweep_the_spreadlets_and_the_base_is_the_report(sweep_report):
    report, _ = sweep_report
    runs = points(report, "spreadlets", "basis")
    assert [p["value"] for p in runs] == ["laplacian", "rows"]
    base, = [p for p in runs if p["base"]]
    assert base["value"] == "rows"
    assert abs(base["ssim"] - report["methods"]["spreadlets"]["ssim"]) < 1e-9   # the report's own render
    # two representations of the same traced PSFs: close, neither better by much
    assert abs(runs[0]["ssim"] - runs[1]["ssim"]) < 0.01
    assert all(p["noise_corrected_psnr"] is not None for p in runs)


def test_inapplicable_knobs_are_listed_with_the_reason(sweep_report):
    report, out = sweep_report
    skipped = {(s["method"], s["knob"]): s["reason"] for s in report["sweep"]["skipped"]}
    assert skipped[("spreadlets", "lens_rays")] == "the 'spreadlets' pass takes no option 'rays'"
    assert ("splat", "integrator") in skipped and ("filter", "lens_rays") in skipped
    assert "row differences" in skipped[("spreadlets", "integrator")]
    assert "dense PSFs" in skipped[("splat", "basis")]
    saved = json.loads((out / "report.json").read_text())
    assert "_images" not in saved["sweep"] and len(saved["sweep"]["points"]) == len(report["sweep"]["points"])
    assert any(p["on_front"]["ssim"] for p in saved["sweep"]["points"])
    assert (out / saved["sweep"]["plot"]).stat().st_size > 10_000
    assert saved["sweep"]["sentences"]["ssim"].split()[0] in {"The", *report["methods"], REFERENCE.split()[0]}


def test_the_page_in_headless_chromium(sweep_report, tmp_path):
    report, out = sweep_report
    with Chromium() as browser:
        check = browser.load(out / "index.html")
        srcs = {i["src"] for i in check["images"]}
        assert {"sweep_accuracy_vs_time.png", "reference.png", "insets_overview.png",
                "spreadlets_error.png", "inset1_reference.png"} <= srcs
        assert not check.broken, check.broken
        assert check["errors"] == []
        # a click on a header sorts its table: the sweep table by SSIM, ascending then descending
        column = ("(() => { const t = document.getElementById('sweep-table');"
                  " const i = Array.from(t.tHead.rows[0].cells).findIndex(c => c.textContent.startsWith('SSIM'));"
                  " t.tHead.rows[0].cells[i].click();"
                  " return Array.from(t.tBodies[0].rows).map(r => parseFloat(r.cells[i].textContent)); })()")
        up = browser.evaluate(column)
        down = browser.evaluate(column)
        assert up == sorted(up) and down == sorted(up, reverse=True) and len(up) == len(report["sweep"]["points"])
        shot = browser.screenshot(out / "screenshot.png")
        # the checker sees what it is for: a missing image and a console error on a page of its own
        (tmp_path / "bad.html").write_text("<img src='missing.png'><script>console.error('boom')</script>")
        bad = browser.load(tmp_path / "bad.html")
    assert [i["src"] for i in bad.broken] == ["missing.png"]
    assert any("boom" in e for e in bad["errors"]) and any("missing.png" in e for e in bad["errors"])
    png = np.asarray(Image.open(shot))
    assert png.shape[1] == 1280 and png.shape[0] > 3000   # the whole page, not one screenful
    print(f"screenshot: {shot}")
