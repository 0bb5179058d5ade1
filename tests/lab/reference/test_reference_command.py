"""`splatlab reference SCENE --workers N`: the serial render's bits, and no worker outlives the command."""
import numpy as np
from kill_support import sigkill_when_busy

from lab.cli import main
from lab.exr_io import read_rgb
from lab.paths import SCENES
from lab.reference.render import reference_job
from lab.scene import load_scene


def scene_file(tmp_path, reference_spp: int):
    """scenes/tiny.toml at 24 x 24 pixels with ``reference_spp`` samples (4 spp passes)."""
    text = (SCENES / "tiny.toml").read_text()
    text = text.replace("resolution = [64, 64]", "resolution = [24, 24]")
    text = text.replace("reference_spp = 256", f"reference_spp = {reference_spp}")
    path = tmp_path / "tiny24.toml"
    path.write_text(text)
    return path


def test_reference_on_workers_is_the_serial_render(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    path = scene_file(tmp_path, 16)
    assert main(["reference", str(path), "--workers", "2", "--quiet", "--out-dir", str(tmp_path / "out")]) == 0
    assert "reference:" in capsys.readouterr().out
    serial = reference_job(load_scene(path)).run(progress=False)
    assert read_rgb(tmp_path / "out" / "reference.exr").tobytes() == serial.tobytes()
    (renders,) = (tmp_path / "cache" / "renders").iterdir()
    assert (renders / "reference.exr").exists() and not (renders / "reference-passes").exists()


def test_killing_the_command_leaves_no_worker_process(tmp_path):
    """SIGKILL gives the command no chance to stop its pool: the workers notice and exit."""
    path = scene_file(tmp_path, 4096)  # 1024 passes: still rendering when killed
    cache = tmp_path / "cache"
    sigkill_when_busy(["reference", path, "--workers", "2", "--quiet", "--out-dir", tmp_path / "out"], cache,
                      "renders/*/reference-passes/pass*.npy")
    passes = sorted(cache.glob("renders/*/reference-passes/pass*.npy"))
    assert passes and all(np.load(p).shape == (24, 24, 3) for p in passes)  # whole files only


def test_unreachable_scheduler_exits_2_in_one_line(tmp_path, monkeypatch, capsys):
    import socket

    from lab import parallel

    monkeypatch.setattr(parallel, "DASK_TIMEOUT_S", 1.0)
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    code = main(["reference", str(scene_file(tmp_path, 16)), "--scheduler", address, "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert f"--scheduler {address}: cannot reach the Dask scheduler" in err and "dask scheduler" in err
