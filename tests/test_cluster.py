"""The same trials and postures on a Dask cluster (a LocalCluster here) as in this process."""

import contextlib

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.base.workers import cluster_executor, parallel_map
from graspmanifold.cli import main as cli

distributed = pytest.importorskip("distributed")

GRID = np.array([[0.0, 0.0, 0.01, 0.0], [0.01, 0.0, 0.02, 0.1], [-0.01, 0.01, 0.01, -0.1]])


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local, \
            distributed.Client(local) as client:
        yield local, client.get_executor()


def test_evaluation_and_generation_on_a_cluster_equal_the_local_run(cluster):
    _, executor = cluster
    postures = gm.generate_postures("cylinder", 12, seed=0, params=gm.GeneratorParams(job_size=3, verify=False))
    remote = gm.generate_postures("cylinder", 12, seed=0, params=gm.GeneratorParams(job_size=3, verify=False),
                                  workers=executor)
    assert remote.postures.tobytes() == postures.postures.tobytes()
    here = gm.evaluate("cylinder", postures, GRID, seed=0)
    there = gm.evaluate("cylinder", postures, GRID, seed=0, workers=executor)
    assert [t.grid_pose.tolist() for t in there.trials] == [t.grid_pose.tolist() for t in here.trials]
    assert there.summary == here.summary
    for a, b in zip(here.trials, there.trials):
        assert a.posture.tobytes() == b.posture.tobytes() and a.epsilon == b.epsilon and a.hold == b.hold


def test_the_cli_takes_a_scheduler_address(cluster, tmp_path):
    local, _ = cluster
    out = tmp_path / "cylinder.npz"
    assert cli(["generate", "--object", "cylinder", "--n", "4", "--no-verify", "--out", str(out),
                "--executor", f"dask://{local.scheduler_address}"]) == 0
    assert len(gm.PostureSet.load(out)) == 4


def test_bad_executors_are_refused(monkeypatch, tmp_path):
    from graspmanifold.base import workers

    monkeypatch.setattr(workers, "CONNECT_SECONDS", 1)  # nothing listens there: no need to wait 10 s
    with pytest.raises(TypeError, match="concurrent.futures.Executor"):
        parallel_map(abs, [1, 2], executor="dask://local")
    with pytest.raises(ValueError, match="executor address"):
        cluster_executor("")
    with pytest.raises(SystemExit, match="--executor"):
        cli(["generate", "--object", "cylinder", "--n", "4", "--out", str(tmp_path / "x.npz"), "--executor",
             "dask://tcp://127.0.0.1:1"])


def test_generator_checkpoints_are_written_by_this_process_not_on_the_workers_disks(cluster, tmp_path, monkeypatch):
    """With an external scheduler the workers wrote the job checkpoints on their own disks: after Ctrl-C the
    client's folder was empty, and a rerun redid the jobs."""
    from graspmanifold.synthesis import generator

    _, executor = cluster
    written, real = [], generator.save_npz
    monkeypatch.setattr(generator, "save_npz", lambda path, *a, **k: written.append(path) or real(path, *a, **k))
    parts = tmp_path / "parts"
    gm.generate_postures("cylinder", 8, params=gm.GeneratorParams(job_size=2, verify=False), workers=executor,
                         checkpoint_dir=parts)
    assert written and sorted(written) == sorted(parts.glob("job_*.npz"))  # every job file, written here


def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.parametrize("lost", ["workers", "scheduler"])
def test_a_cluster_that_loses_its_workers_or_scheduler_ends_the_job_with_one_message(lost, monkeypatch, capfd):
    """A killed scheduler ended in a `FutureCancelledError` traceback; with every worker gone the job waited
    without a word, for ever."""
    import subprocess
    import sys
    import time

    from graspmanifold.base import workers

    monkeypatch.setattr(workers, "CLUSTER_PATIENCE", 3.0)
    monkeypatch.setattr(workers, "CLUSTER_LOOK_SECONDS", 0.5)
    address = f"tcp://127.0.0.1:{_free_port()}"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                  "--port", address.rsplit(":", 1)[1], "--no-dashboard"], **quiet)
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                               "--no-nanny", "--no-dashboard"], **quiet)
    try:
        executor = cluster_executor(address)
        executor.client.wait_for_workers(1, timeout=60)
        done = []

        def kill_after_two(index: int, _) -> None:
            done.append(index)
            if index == 1:
                (worker if lost == "workers" else scheduler).kill()

        start = time.monotonic()
        with pytest.warns(UserWarning, match="no worker") if lost == "workers" else _nothing():
            with pytest.raises(workers.WorkersLost, match="finished work is kept") as raised:
                parallel_map(time.sleep, [0.5 + i * 1e-6 for i in range(40)], executor=executor,  # distinct keys
                             on_result=kill_after_two)
        assert time.monotonic() - start < 30 and len(done) < 40
        expected = "no worker for 3 s" if lost == "workers" else "scheduler"
        assert expected in str(raised.value)
        executor.shutdown()
        assert "Traceback" not in capfd.readouterr().err  # nor distributed's log of its reconnection
    finally:
        for process in (worker, scheduler):
            process.kill()
            process.wait()


@contextlib.contextmanager
def _nothing():
    yield
