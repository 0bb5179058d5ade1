"""A moving scene from scene file to report: ``scenes/tiny_motion.toml`` (depth of field + motion)."""
from pathlib import Path

import numpy as np
import pytest

from lab.exr_io import read_labelled
from lab.paths import SCENES
from lab.pipeline import run_report


@pytest.fixture(scope="module")
def motion_report(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    cache = tmp_path_factory.mktemp("cache")
    mp.setenv("SPLATLAB_CACHE", str(cache))
    out = tmp_path_factory.mktemp("motion")
    yield run_report(SCENES / "tiny_motion.toml", out, progress=False), cache
    mp.undo()


def test_the_moving_scene_runs_combined_against_subframes(motion_report):
    report, cache = motion_report
    assert report["plan"]["psf_models"] == ["combined"]
    assert report["plan"]["effects"]["motion"].startswith("linear per pixel (5 moving shape(s), 2 turning")
    (path,) = cache.glob("renders/*/input.exr")
    image = read_labelled(path)
    longest = float(np.hypot(image.extra["motion.X"], image.extra["motion.Y"]).max())
    config = report["database"]["combined"]["params"]["config"]
    assert config["max_motion_px"] == 8 * np.ceil(longest / 8) and config["aperture"] == "circle"
    assert image.camera["shutter"] == [0.0, 1.0]
    methods = report["methods"]
    assert set(methods) == {"spreadlets", "splat", "filter"}
    assert abs(methods["spreadlets"]["ssim"] - methods["splat"]["ssim"]) < 0.02
    assert methods["spreadlets"]["ssim"] > 0.68      # 0.724 measured against the 256-spp reference


def test_without_its_motion_the_same_render_scores_worse(motion_report, tmp_path):
    """The motion vectors matter: rendering the same input with the motion zeroed (defocus
    alone) falls below the combined render against the sub-frame reference."""
    from lab.exr_io import read_rgb
    from lab.report.metrics import ssim
    from runtime_cl.camera import from_header
    from runtime_cl.frame import Frame
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase

    report, cache = motion_report
    (folder,) = cache.glob("renders/*")
    image, reference = read_labelled(folder / "input.exr"), read_rgb(folder / "reference.exr")
    db = SpreadletDatabase.load(report["database"]["combined"]["path"])
    camera = from_header(image.camera, "input")
    motion = np.stack([image.extra["motion.X"], image.extra["motion.Y"]], axis=-1)
    scores = {}
    for name, m in (("moving", motion), ("still", np.zeros_like(motion))):
        out, _ = run_pass("spreadlets", Frame(image.rgb, image.depth, alpha=image.alpha, motion=m), camera, db, runs=1)
        scores[name] = ssim(out, reference)
    assert scores["moving"] > scores["still"] + 0.01, scores


def test_report_over_several_scenes_writes_lsr18_table2(motion_report, tmp_path, capsys):
    """`splatlab report A B --noise-floor`: each scene's report, then Table 2 linking to them,
    with each reference's noise floor (two seeds) beside the methods."""
    import json

    from lab.cli import main

    assert main(["report", str(SCENES / "tiny_motion.toml"), str(SCENES / "tiny_heart.toml"),
                 "--out-dir", str(tmp_path), "--noise-floor"]) == 0
    table = json.loads((tmp_path / "report.json").read_text())
    assert [row["scene"] for row in table["scenes"]] == ["tiny_motion", "tiny_heart"]
    for row in table["scenes"]:
        report = json.loads((tmp_path / row["scene"] / "report.json").read_text())
        assert row["spreadlets"]["ssim"] == report["methods"]["spreadlets"]["ssim"]
        assert row["speedup_vs_splat"] == pytest.approx(report["methods"]["splat"]["time_ms"]
                                                         / report["methods"]["spreadlets"]["time_ms"])
        assert 0.5 < row["noise_floor"]["ssim"] < 1.0 and row["paper"] is None
        for m in report["methods"].values():  # the reference's own noise taken out of the error
            plain_mse = 10.0 ** (-m["psnr"] / 10.0)
            assert 0.0 < m["noise_corrected_mse"] < plain_mse
        scene_page = (tmp_path / row["scene"] / "index.html").read_text()
        assert "noise-corrected PSNR" in scene_page
        # the tiny scenes' references are far from converged, and both pages say so
        assert row["noise_floor"]["ssim"] < 0.98 and "Not converged enough to validate" in scene_page
    page = (tmp_path / "index.html").read_text()
    assert page.count("below 0.98: not converged enough to validate") == 2
    assert "href='tiny_motion/index.html'" in page and "LSR18 Table 2" in page
    said = capsys.readouterr().out
    assert "noise floor: two reference seeds agree" in said and "not converged enough to validate" in said


def test_table2_puts_the_papers_row_beside_a_scene_of_the_paper(motion_report, tmp_path):
    from lab.report.table2 import LSR18_TABLE2, write_summary

    report, _ = motion_report
    renamed = dict(report, scene=dict(report["scene"], name="whirl"))
    write_summary([renamed], [tmp_path / "whirl"], tmp_path)
    page = (tmp_path / "index.html").read_text()
    assert "LSR18 Table 2" in page and f"{LSR18_TABLE2['whirl']['splat'][0]:.1f}" in page
    assert "8.2&times;" in page          # the paper's Splat / spreadlets: 722.8 / 88.0 ms


def test_a_moving_scene_through_a_pinhole_blurs_motion_alone(motion_report, tmp_path):
    """tiny_motion seen through a pinhole: the combined model with CoC 0 (max_coc_px 1), against
    sub-frames through the pinhole; the spreadlets bring the input closer to the reference."""
    import tomllib

    from lab.report.metrics import ssim

    text = (SCENES / "tiny_motion.toml").read_text()
    data = tomllib.loads(text)
    cam = data["camera"]
    start, end = text.index("[camera]"), text.index("[render]")
    pinhole = (f'[camera]\nmodel = "pinhole"\nposition = {cam["position"]}\nlook_at = {cam["look_at"]}\n'
               f'fov_deg = 24.0\n\n')
    path = tmp_path / "pinhole_motion.toml"
    path.write_text(text[:start].replace('name = "tiny_motion"', 'name = "pinhole_motion"') + pinhole + text[end:])
    report = run_report(path, tmp_path / "out", progress=False)
    assert report["plan"]["psf_models"] == ["combined"] and report["plan"]["effects"]["dof"] == "none"
    assert report["database"]["combined"]["params"]["config"]["max_coc_px"] == 1.0
    (folder,) = [p for p in Path(report["reference"]["cache"]).parent.glob("pinhole_motion-*")]
    image = read_labelled(folder / "input.exr")
    from lab.exr_io import read_rgb

    reference = read_rgb(folder / "reference.exr")
    assert report["methods"]["spreadlets"]["ssim"] > ssim(image.rgb, reference) + 0.01


def test_report_set_gives_the_passes_an_option(motion_report, tmp_path):
    """`splatlab report --set spreadlet_rotation=bank`: the passes that take it draw from the
    angle bank (the same image to the bank's angle rounding), and the report says so."""
    import json

    from lab.cli import main

    report, _ = motion_report
    assert main(["report", str(SCENES / "tiny_motion.toml"), "--set", "spreadlet_rotation=bank",
                 "--out-dir", str(tmp_path)]) == 0
    banked = json.loads((tmp_path / "report.json").read_text())
    options = banked["plan"]["pass_options"]
    assert options["spreadlets"] == {"spreadlet_rotation": "bank"} and "pass_options" in report["plan"]
    assert report["plan"]["pass_options"] == {}
    assert abs(banked["methods"]["spreadlets"]["ssim"] - report["methods"]["spreadlets"]["ssim"]) < 0.005
    assert banked["methods"]["splat"]["ssim"] == report["methods"]["splat"]["ssim"]   # dense: no bank
    assert "spreadlet_rotation = bank" in (tmp_path / "index.html").read_text()


def test_a_moving_scene_through_an_iris_sweeps_the_hexagon(tmp_path, monkeypatch):
    """``scenes/tiny_motion_iris.toml``: the same motion through a six-blade iris. The combined
    database is traced for the camera's iris with the motion angle in 6 bins, and the spreadlets
    score against sub-frames rendered through that iris as they do through the round lens."""
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    report = run_report(SCENES / "tiny_motion_iris.toml", tmp_path / "out", progress=False)
    assert report["plan"]["effects"]["aperture"].startswith("polygon (6 blades")
    db = report["database"]["combined"]["params"]
    assert db["config"]["aperture"] == "polygon" and db["config"]["aperture_blades"] == 6
    assert db["config"]["angle_bins"] == 6 and db["symmetries"] == ["motion_angle", "coc_sign"]
    methods = report["methods"]
    assert abs(methods["spreadlets"]["ssim"] - methods["splat"]["ssim"]) < 0.02
    assert methods["spreadlets"]["ssim"] > 0.68      # 0.718 measured against the 256-spp reference (floor 0.75)
