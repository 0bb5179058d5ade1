"""--workers N and Dask give bitwise the database of the serial run.

Bitwise is the right bar: the tracer seeds each launch from (seed, cell, launch) and counts hits
in integers (thread count and scheduling cannot change a count), and the sparsifier's generator
is seeded per cell, so a cell's shard does not depend on where or when it is computed.
"""
import pytest

from lab.errors import UserError
from lab.precompute import precompute, source_digest
from lab.precompute.cell import CellJob, run_cell
from lab.parallel import check_scheduler, dask_threads, usable_cores
from runtime_cl.psf.database import SpreadletDatabase

from precompute_helpers import assert_same_database, small_cells, small_model


def test_local_worker_processes_match_the_serial_run(reference, cache):
    result = precompute(small_model(), progress=False, workers=2)
    assert result.executor == "processes" and result.cells == small_cells()
    assert result.rays > 0 and result.trace_seconds > 0
    assert_same_database(SpreadletDatabase.load(result.path), reference[0])


def test_dask_local_cluster_matches_the_serial_run(reference, cache):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster.scheduler_address) as client:
            threads = dask_threads(client)
            assert len(threads) == 2 and all(t >= 1 for t in threads.values())
            # 2 task slots on this host: each worker process gets half its cores for Dr.Jit
            assert set(threads.values()) == {max(1, usable_cores() // 2)}
        result = precompute(small_model(), progress=False, scheduler=cluster.scheduler_address)
    assert result.executor == "dask" and result.cells == small_cells()
    assert_same_database(SpreadletDatabase.load(result.path), reference[0])


def test_unreachable_scheduler_is_a_user_error(cache, monkeypatch):
    import socket

    from lab import parallel

    monkeypatch.setattr(parallel, "DASK_TIMEOUT_S", 1.0)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(UserError, match=rf"tcp://127.0.0.1:{port}: cannot reach the Dask scheduler"):
        precompute(small_model(), progress=False, scheduler=f"tcp://127.0.0.1:{port}")


@pytest.mark.parametrize("address", ["localhost:8786", "tcp://", "http://host:1", "tcp://a b:1", 8786])
def test_bad_scheduler_address(address):
    with pytest.raises(UserError, match="--scheduler"):
        check_scheduler(address)


def test_workers_and_scheduler_together_are_refused(cache):
    with pytest.raises(UserError, match="choose one"):
        precompute(small_model(), progress=False, workers=2, scheduler="tcp://127.0.0.1:1")


def test_worker_with_other_code_refuses_the_task():
    model = small_model()
    job = CellJob(model.name, model.config, "0" * 64)
    with pytest.raises(UserError, match=r"code \(digest .*differs from the job's \(000000000000\)"):
        run_cell(job, 0)
    shard = run_cell(CellJob(model.name, model.config, source_digest(model.name)), 0)
    assert int(shard["cell"]) == 0 and shard["dense"].shape[2] == 1
