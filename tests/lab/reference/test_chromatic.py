"""ChromaticJob: one pass set per channel wavelength, averaged by the generic accumulator; and the
thick-lens sensor through it renormalises vignetting (a uniform sky images to its radiance)."""
import pickle

import numpy as np

from lab.cameras.thick import WAVELENGTHS_NM
from lab.reference.chromatic import ChromaticJob
from lab.reference.passes import average
from lab.scene import parse_scene

CAMERA = {"model": "thick", "position": [0, 0, 0], "look_at": [0, 0, 1], "lens": "singlet", "focus_distance_m": 2.0}


def _scene(width=16, height=12, sky=(0.5, 0.5, 0.5)):
    return parse_scene({"scene": {"name": "sky", "resolution": [width, height]}, "camera": CAMERA,
                        "render": {"max_depth": 1, "seed": 3},
                        "emitters": [{"type": "constant", "radiance": list(sky)}]}, "sky.toml")


def test_passes_are_one_per_channel_with_shared_seeds():
    job = ChromaticJob(_scene(1024, 1024), 40, wavelengths_nm=WAVELENGTHS_NM)
    passes = job.passes()
    assert [p.spp for p in passes] == [16] * 6 + [8] * 3 and [p.index for p in passes] == list(range(9))
    assert [p.get("wavelength_nm") for p in passes] == list(WAVELENGTHS_NM) * 3
    assert [p.weight for p in passes[:3]] == [(16.0, 0.0, 0.0), (0.0, 16.0, 0.0), (0.0, 0.0, 16.0)]
    seeds = [p.seed for p in passes]
    assert seeds[0] == seeds[1] == seeds[2] != seeds[3] == seeds[5] and len(set(seeds)) == 3
    # each channel is the spp-weighted mean of its own wavelength's passes
    images = [np.full((2, 2, 3), p.get("wavelength_nm") + p.index, np.float32) for p in passes]
    want = [(16 * (nm + c) + 16 * (nm + c + 3) + 8 * (nm + c + 6)) / 40 for c, nm in enumerate(WAVELENGTHS_NM)]
    np.testing.assert_allclose(average(passes, images)[0, 0], want, rtol=1e-6)


def test_the_job_pickles_without_its_scenes():
    job = ChromaticJob(_scene(), 4)
    job.mitsuba_scene(650.0)
    again = pickle.loads(pickle.dumps(job))
    assert again._scenes == {} and again.passes() == job.passes() and len(job._scenes) == 1


def test_a_uniform_sky_images_to_its_radiance_in_every_channel_to_the_corners():
    img = ChromaticJob(_scene(sky=(0.5, 0.25, 1.0)), 256, wavelengths_nm=WAVELENGTHS_NM).run(progress=False)
    want = np.array([0.5, 0.25, 1.0])
    np.testing.assert_allclose(img.mean(axis=(0, 1)), want, rtol=0.01)
    corners = img[[0, 0, -1, -1], [0, -1, 0, -1]]             # A(r) there is half the centre's
    np.testing.assert_allclose(corners.mean(axis=0), want, rtol=0.05)
    assert np.all(img.std(axis=(0, 1)) < 0.08 * want)                # noise only, no vignetting falloff


def test_local_worker_processes_give_the_serial_bits(tmp_path):
    """The executors only call passes() and render(p): a worker loads the thick-lens sensor itself,
    one scene per wavelength, and the mean is bitwise the serial one."""
    from lab.parallel import Executor
    from lab.reference.execute import run_job

    job = ChromaticJob(_scene(sky=(0.5, 0.25, 1.0)), 16, wavelengths_nm=WAVELENGTHS_NM)
    serial = job.run(progress=False)
    with Executor(workers=2) as local:
        spread = run_job(job, local, tmp_path / "passes", progress=False)
    assert spread.dtype == serial.dtype and spread.tobytes() == serial.tobytes()
    assert len(list((tmp_path / "passes").glob("pass*.npy"))) == len(job.passes()) == 12
