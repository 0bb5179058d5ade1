"""A medium from scene file to report: ``scenes/tiny_fog.toml`` (small lights in fog)."""
import math

import pytest

from lab.exr_io import read_labelled, read_rgb
from lab.paths import SCENES
from lab.pipeline import run_report
from lab.report.metrics import psnr, ssim


@pytest.fixture(scope="module")
def fog_report(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("SPLATLAB_CACHE", str(tmp_path_factory.mktemp("cache")))
    yield run_report(SCENES / "tiny_fog.toml", tmp_path_factory.mktemp("fog"), progress=False, noise=False)
    mp.undo()


def test_the_fog_runs_the_volume_model(fog_report):
    report = fog_report
    assert report["plan"]["psf_models"] == ["volume", "volume_far"] and "sigma_t 0.25" in report["plan"]["effects"]["medium"]
    config = report["database"]["volume"]["params"]["config"]
    assert (config["medium_density"], config["g"], config["albedo"]) == (0.25, 0.6, [0.9, 0.9, 0.85])
    # the PSFs are the camera's pinhole images: 64 px across a 40-degree field of view
    assert config["width_px"] == 64
    assert math.degrees(2 * math.atan(config["sensor_width_mm"] / 2 / config["focal_length_mm"])) == \
        pytest.approx(40.0)
    assert config["min_distance_m"] <= 1.5 and config["max_distance_m"] >= 7.0
    # the input's header names the fog the runtime adds, and the database records the same
    assert report["scene"]["camera"]["medium"] == {"sigma_t": 0.25, "albedo": [0.9, 0.9, 0.85], "g": 0.6}
    assert report["database"]["volume"]["params"]["fingerprint"]["medium"] == report["scene"]["camera"]["medium"]
    methods = report["methods"]
    assert set(methods) == {"spreadlets", "splat", "filter"}
    assert abs(methods["spreadlets"]["psnr"] - methods["splat"]["psnr"]) < 0.5


def test_the_volume_pass_brings_the_input_close_to_the_fog(fog_report):
    """The input is rendered without the medium; the runtime adds it. Measured against the
    equi-angular reference: PSNR 15.1 -> 26.1 dB, SSIM 0.53 -> 0.84 (against volpath's, whose own
    noise capped the SSIM: 14.9 -> 23.0 dB, 0.39 -> 0.52)."""
    folder = fog_report["reference"]["cache"]
    image, reference = read_labelled(f"{folder}/input.exr"), read_rgb(f"{folder}/reference.exr")
    sp = fog_report["methods"]["spreadlets"]
    assert sp["psnr"] > psnr(image.rgb, reference) + 5.0
    assert sp["ssim"] > ssim(image.rgb, reference) + 0.05


@pytest.fixture(scope="module")
def narrow(fog_report):
    """tiny_fog with a volume window of +-14 px: its input, reference and databases (with the far
    field's, which the plan now adds)."""
    import dataclasses

    from lab.pipeline import build_databases, load_scene_and_plan
    from lab.plan import make_plan

    scene, _ = load_scene_and_plan(SCENES / "tiny_fog.toml")
    scene = dataclasses.replace(scene, psf={**scene.psf, "volume": {**scene.psf["volume"], "psf_resolution": 33}})
    plan = make_plan(scene)
    assert plan.psf_models == ("volume", "volume_far")
    folder = fog_report["reference"]["cache"]
    image, reference = read_labelled(f"{folder}/input.exr"), read_rgb(f"{folder}/reference.exr")
    paths = {k: r.path for k, r in build_databases(scene, plan, image, progress=False).items()}
    return folder, image, reference, paths


def test_the_far_field_completes_a_narrow_volume_window(fog_report, narrow):
    """A volume window of +-14 px on the 64^2 fog crops every light's halo to a square; the
    volume_far database adds the rest in 8 x 8 px bins and restores it: the render comes much
    closer to the reference than the window alone, and as close as the full window's."""
    import numpy as np

    from lab.runtime_passes import frame_of, runtime_camera
    from runtime_cl.passes import run_pass
    from runtime_cl.psf.database import SpreadletDatabase

    _, image, reference, paths = narrow
    dbs = {k: SpreadletDatabase.load(p) for k, p in paths.items()}
    assert dbs["volume_far"].params["config"]["hole_half_px"] == 14
    frame, camera = frame_of(image, db=dbs["volume"]), runtime_camera(image)
    cropped, _ = run_pass("spreadlets", frame, camera, dbs["volume"])
    completed, _ = run_pass("spreadlets", frame, camera, dbs["volume"], far_field=dbs["volume_far"])
    full = fog_report["methods"]["spreadlets"]["psnr"]
    assert psnr(completed, reference) > psnr(cropped, reference) + 3.0
    assert psnr(completed, reference) > full - 1.0
    assert np.all(completed >= cropped - 1e-6)          # the far field only adds light


def test_render_adds_the_far_field_from_the_command_line(fog_report, narrow, tmp_path, capsys):
    from lab.cli import main

    folder, _, reference, db = narrow
    args = ["render", f"{folder}/input.exr", "--db", str(db["volume"]), "--out"]
    assert main(args + [str(tmp_path / "near.exr")]) == 0
    assert main(args + [str(tmp_path / "both.exr"), "--far-db", str(db["volume_far"])]) == 0
    near, both = read_rgb(tmp_path / "near.exr"), read_rgb(tmp_path / "both.exr")
    assert psnr(both, reference) > psnr(near, reference) + 3.0
    capsys.readouterr()
    assert main(["render", f"{folder}/input.exr", "--method", "identity", "--far-db", str(db["volume_far"]),
                 "--out", str(tmp_path / "x.exr")]) == 2
    assert "--far-db" in capsys.readouterr().err and not (tmp_path / "x.exr").exists()
    # a far field that does not complete this volume database: the pair is refused, naming both
    full_window = fog_report["database"]["volume"]["path"]         # keeps +-62 px, not 14
    assert main(["render", f"{folder}/input.exr", "--db", full_window, "--far-db", str(db["volume_far"]),
                 "--out", str(tmp_path / "y.exr")]) == 2
    assert "does not complete the volume database" in capsys.readouterr().err

