"""Reference passes on an executor: serial, local processes and Dask give the serial render's bits;
every pass is cached on its own and an interrupted render resumes.

Bitwise is the right bar: the passes are averaged in float64 in pass order, and each pass image
does not depend on the Dr.Jit thread count that rendered it (lab.reference.passes: power-of-two
passes, 4 spp each at this size, never split over two threads' work blocks). Here the serial
render runs with this process's threads and each worker with one.
"""
import socket

import numpy as np
import pytest

from lab.errors import UserError
from lab.parallel import Executor
from lab.reference.execute import run_job
from lab.reference.pass_files import pass_ok, pass_path
from lab.reference.render import reference_job

from job_helpers import ChannelJob, FlakyJob, PassFailed, small_scene


@pytest.fixture(scope="module")
def scene():
    return small_scene(24, 24)


@pytest.fixture(scope="module")
def serial(scene):
    """The reference rendered in this process, pass after pass, without any cache (RenderJob.run)."""
    job = reference_job(scene, spp=16)
    assert [p.spp for p in job.passes()] == [4] * 4
    return job.run(progress=False)


def assert_same_bits(a, b):
    assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


def pass_files(folder):
    return sorted(folder.glob("pass*.npy"))


def no_temporary_files(folder):
    return not [p for p in folder.iterdir() if p.name.endswith(".tmp")]


def test_serial_processes_and_dask_give_the_serial_bits(scene, serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    job = reference_job(scene, spp=16)
    here = run_job(job, Executor(), tmp_path / "here", progress=False)
    assert_same_bits(here, serial)
    assert len(pass_files(tmp_path / "here")) == 4  # kept for the caller to remove

    with Executor(workers=2) as local:
        assert_same_bits(run_job(job, local, tmp_path / "processes", progress=False), serial)
    for a, b in zip(pass_files(tmp_path / "here"), pass_files(tmp_path / "processes")):
        assert a.name == b.name and a.read_bytes() == b.read_bytes()  # every pass, not only the mean

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with Executor(scheduler=cluster.scheduler_address) as dask:
            assert_same_bits(run_job(job, dask, tmp_path / "dask", progress=False), serial)
    for folder in ("here", "processes", "dask"):
        assert no_temporary_files(tmp_path / folder)


def test_an_interrupted_render_resumes_with_the_missing_passes(scene, serial, tmp_path):
    folder = tmp_path / "passes"
    with pytest.raises(PassFailed, match="pass 2 interrupted"):
        run_job(FlakyJob(scene, 16, "reference", "scene", medium=True, fail_at=2), None, folder, progress=False)
    assert len(pass_files(folder)) == 2 and no_temporary_files(folder)

    job = FlakyJob(scene, 16, "reference", "scene", medium=True)
    assert [pass_ok(folder, job, p) for p in job.passes()] == [True, True, False, False]
    assert_same_bits(run_job(job, None, folder, progress=False), serial)
    assert job.rendered == [2, 3]  # only what was missing

    again = FlakyJob(scene, 16, "reference", "scene", medium=True)
    assert_same_bits(run_job(again, Executor(workers=2), folder, progress=False), serial)
    assert again.rendered == []    # everything cached: no worker started, no pass rendered


def test_a_failing_pass_on_workers_keeps_the_finished_ones(scene, serial, tmp_path):
    folder = tmp_path / "passes"
    with pytest.raises(PassFailed, match="pass 1 interrupted"):
        run_job(FlakyJob(scene, 16, "reference", "scene", medium=True, fail_at=1), Executor(workers=2),
                folder, progress=False)
    kept = len(pass_files(folder))
    assert 1 <= kept <= 3 and no_temporary_files(folder)  # pass 0 at least; the other worker's too
    job = FlakyJob(scene, 16, "reference", "scene", medium=True)
    assert_same_bits(run_job(job, None, folder, progress=False), serial)
    assert len(job.rendered) == 4 - kept


def test_torn_pass_is_rendered_again_and_stray_files_are_ignored(scene, serial, tmp_path):
    folder = tmp_path / "passes"
    job = FlakyJob(scene, 16, "reference", "scene", medium=True)
    run_job(job, None, folder, progress=False)
    torn = pass_path(folder, job, job.passes()[1])
    torn.write_bytes(torn.read_bytes()[:-100])
    (folder / ".pass00002-x.npy.abc.tmp").write_bytes(b"half a pass")
    np.save(folder / "pass00003-0000000000000000.npy", np.zeros((24, 24, 3), np.float32))  # another job's
    again = FlakyJob(scene, 16, "reference", "scene", medium=True)
    assert_same_bits(run_job(again, None, folder, progress=False), serial)
    assert again.rendered == [1]


def test_channels_are_averaged_by_their_own_weights(scene, tmp_path):
    job = ChannelJob(scene, 0, "reference", "scene", medium=True)
    images = [job.render(p) for p in job.passes()]
    total = sum(img.astype(np.float64) * np.asarray(p.weight) for p, img in zip(job.passes(), images))
    expected = (total / np.array([6.0, 6.0, 6.0])).astype(np.float32)
    here = run_job(job, None, tmp_path / "here", progress=False)
    np.testing.assert_allclose(here, expected, rtol=1e-6, atol=0)
    # red from passes 0 and 3 only: pass 1's red (another seed) would change it
    assert not np.allclose(here[..., 0], ((images[0][..., 0] * 4.0 + images[1][..., 0] * 2.0) / 6.0))
    with Executor(workers=2) as local:
        assert_same_bits(run_job(job, local, tmp_path / "processes", progress=False), here)


def test_unreachable_scheduler_is_one_user_error(scene, serial, tmp_path, monkeypatch):
    from lab import parallel

    monkeypatch.setattr(parallel, "DASK_TIMEOUT_S", 1.0)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    job = reference_job(scene, spp=16)
    with pytest.raises(UserError, match=rf"--scheduler {address}: cannot reach the Dask scheduler"):
        run_job(job, Executor(scheduler=address), tmp_path / "passes", progress=False)
    # nothing to render: no connection is tried
    run_job(job, None, tmp_path / "passes", progress=False)
    assert_same_bits(run_job(job, Executor(scheduler=address), tmp_path / "passes", progress=False), serial)


@pytest.mark.parametrize("workers, scheduler, match", [
    (0, None, "--workers 0: must be an integer >= 1"), ("two", None, "--workers 'two'"),
    (2, "tcp://127.0.0.1:1", "choose one"), (1, "localhost:8786", "--scheduler 'localhost:8786'")])
def test_bad_executor_options(workers, scheduler, match):
    with pytest.raises(UserError, match=match):
        Executor(workers, scheduler)


def test_a_worker_loads_the_job_once_per_run_and_refuses_other_code(scene):
    import pickle

    from lab.reference.execute import PassTask, _code_roots
    from lab.cache_key import code_digest

    job = reference_job(scene, spp=16)
    task = PassTask(job, "run-1", code_digest(_code_roots(job)), None)
    first, second = (pickle.loads(pickle.dumps(task)) for _ in range(2))
    assert first.job is second.job is not job and first.shipped and not task.shipped
    assert pickle.loads(pickle.dumps(PassTask(job, "run-2", task.code, None))).job is not first.job
    assert first(job.passes()[0]).tobytes() == job.render(job.passes()[0]).tobytes()
    with pytest.raises(UserError, match=r"code \(digest .*differs from the job's \(000000000000\)"):
        pickle.loads(pickle.dumps(PassTask(job, "run-3", "0" * 64, None)))(job.passes()[0])
