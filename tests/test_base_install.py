"""The base install (numpy, pyopencl, PoCL, OpenEXR) renders an EXR; lab commands ask for the extra.

A fresh venv gets ``pip install <repo>`` without extras (pip's local cache may serve the wheels),
then its ``splatlab render`` and ``splatlab db info`` run on a labelled EXR and a database made
here, and a lab command fails in one line naming the ``lab`` extra.
"""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lab.exr_io import LabelledImage, read_rgb, write_labelled
from runtime_cl.psf.synthetic import disc_database

ROOT = Path(__file__).resolve().parents[1]
CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 0.5,
          "sensor_width_mm": 36.0}


@pytest.mark.slow
def test_the_base_install_renders_an_exr(tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py, splatlab = venv / "bin" / "python", venv / "bin" / "splatlab"
    source = tmp_path / "src"        # a copy: pip builds in the source tree (build/)
    for item in ("lab", "runtime_cl", "scenes"):
        shutil.copytree(ROOT / item, source / item, ignore=shutil.ignore_patterns("__pycache__"))
    for item in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / item, source / item)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", str(source)], check=True, cwd=tmp_path)
    extra = subprocess.run([str(py), "-c", "import drjit"], capture_output=True)
    assert extra.returncode != 0                                   # the lab extra is not installed

    rng = np.random.default_rng(0)
    h, w = 24, 32
    depth = np.where(np.arange(w)[None, :] < 16, 0.5, 0.3) * np.ones((h, 1))
    image = LabelledImage(rng.random((h, w, 3)).astype(np.float32), np.ones((h, w), np.float32),
                          depth.astype(np.float32), CAMERA)
    write_labelled(tmp_path / "in.exr", image)
    disc_database(8.0, samples=10).save(tmp_path / "disc.spdb")
    env = dict(os.environ, POCL_CACHE_DIR=str(tmp_path / "pocl"))

    def run(*args):
        return subprocess.run([str(splatlab), *args], capture_output=True, text=True, cwd=tmp_path, env=env)

    done = run("render", "in.exr", "--db", "disc.spdb", "--out", "out.exr")
    assert done.returncode == 0, done.stderr
    import runtime_cl

    want, _ = runtime_cl.render(image.rgb, image.depth, runtime_cl.ThinLens.from_json(CAMERA),
                                runtime_cl.load_database(tmp_path / "disc.spdb"))
    # numpy's FFT stands in for scipy's in the base install: the same solve to float rounding
    np.testing.assert_allclose(read_rgb(tmp_path / "out.exr"), want, atol=1e-5)
    info = run("db", "info", "disc.spdb")
    assert info.returncode == 0 and '"model": "simple_lens"' in info.stdout
    lab = run("precompute", "simple_lens")
    assert lab.returncode == 2 and len(lab.stderr.splitlines()) == 1 and "splatlab[lab]" in lab.stderr
