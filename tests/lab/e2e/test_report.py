"""Scene file -> Dr.Jit PSFs -> spreadlets -> OpenCL runtime -> report, at 64x64."""
import json

import numpy as np

from lab.exr_io import read_rgb
from lab.paths import SCENES

TINY = SCENES / "tiny.toml"


def test_report_files_and_fields(tiny_report):
    report, out = tiny_report
    for name in ("index.html", "report.json", "reference.png", "input.png", "accuracy_vs_time.png"):
        assert (out / name).stat().st_size > 0, name
    saved = json.loads((out / "report.json").read_text())
    assert set(saved["methods"]) == {"spreadlets", "splat", "filter"}
    for m in saved["methods"].values():
        assert m["time_ms"] > 0 and 0 < m["ssim"] <= 1 and (out / m["image"]).exists()
        assert m["compile_ms"] >= 0 and m["counts"]["pixels"] == 64 * 64
    assert saved["machine"]["packages"]["drjit"] == "1.5.0"
    assert saved["database"]["simple_lens"]["samples"] == 100
    html = (out / "index.html").read_text()
    assert "spreadlets" in html and "reference.png" in html


def test_methods_agree_with_the_reference(tiny_report):
    """The blur is right: every method is far closer to the thin-lens reference than the pinhole input."""
    report, _ = tiny_report
    methods = report["methods"]
    sp, splat = methods["spreadlets"], methods["splat"]
    assert abs(sp["ssim"] - splat["ssim"]) < 0.02  # LSR18: spreadlets match dense splatting
    assert sp["counts"]["spreadlets"] > 0
    assert splat["counts"]["dense_pixels"] > sp["counts"]["spreadlets"]


def test_spreadlets_beat_the_pinhole_input(tiny_report, tiny_input):
    from lab.exr_io import read_labelled
    from lab.report.metrics import ssim

    report, out = tiny_report
    reference = read_rgb(next(tiny_input.parent.glob("reference.exr")))
    pinhole = ssim(read_labelled(tiny_input).rgb, reference)
    assert report["methods"]["spreadlets"]["ssim"] > pinhole + 0.05


def test_warm_run_reuses_everything(tiny_report, e2e_cache, tmp_path, monkeypatch):
    monkeypatch.setenv("SPLATLAB_CACHE", str(e2e_cache))
    from lab.pipeline import run_report

    report = run_report(TINY, tmp_path, progress=False)
    assert report["database"]["simple_lens"]["reused"] is True
    assert report["reference"]["reference_s"] == "cached"
    first, _ = tiny_report
    for name in ("spreadlets", "splat", "filter"):
        assert np.isclose(report["methods"][name]["ssim"], first["methods"][name]["ssim"], atol=1e-6)


def test_every_page_states_its_noise_floor(tiny_report, e2e_cache, tmp_path, monkeypatch):
    """By default a report renders the reference's independent-seed twin: the page states the floor
    (SSIM, PSNR of the two) and each method's noise-corrected MSE, seen in headless Chromium;
    ``noise=False`` (``--no-noise-floor``) says on the page that it was skipped."""
    from lab.pipeline import run_report
    from lab.report.browser import Chromium

    report, out = tiny_report
    floor = report["reference"]["noise_floor"]
    assert 0.3 < floor["ssim"] < 1.0 and floor["seeds"][0] != floor["seeds"][1]
    assert all("noise_corrected_mse" in m for m in report["methods"].values())
    monkeypatch.setenv("SPLATLAB_CACHE", str(e2e_cache))
    skipped = run_report(TINY, tmp_path / "skipped", progress=False, noise=False)
    assert "noise_floor" not in skipped["reference"] and "no-noise-floor" in skipped["reference"]["noise_floor_skipped"]
    with Chromium() as browser:
        check = browser.load(out / "index.html")
        text = browser.evaluate("document.body.innerText")
        assert not check.broken and check["errors"] == []
        assert f"agree at SSIM {floor['ssim']:.3f}" in text and "noise-corrected MSE" in text
        browser.load(tmp_path / "skipped" / "index.html")
        text = browser.evaluate("document.body.innerText")
        assert "noise floor was not measured: skipped (--no-noise-floor)" in text
