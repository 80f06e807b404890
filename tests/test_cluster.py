"""The same trials and postures on a Dask cluster (a LocalCluster here) as in this process."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.cli import main as cli
from graspmanifold.workers import cluster_executor, parallel_map

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
                                  executor=executor)
    assert remote.postures.tobytes() == postures.postures.tobytes()
    here = gm.evaluate("cylinder", postures, GRID, seed=0)
    there = gm.evaluate("cylinder", postures, GRID, seed=0, executor=executor)
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


def test_bad_executors_are_refused():
    with pytest.raises(TypeError, match="concurrent.futures.Executor"):
        parallel_map(abs, [1, 2], executor="dask://local")
    with pytest.raises(ValueError, match="executor address"):
        cluster_executor("")
    with pytest.raises(SystemExit, match="--executor"):
        cli(["generate", "--object", "cylinder", "--n", "4", "--out", "x.npz", "--executor", "dask://tcp://127.0.0.1:1"])


def test_generator_checkpoints_are_written_by_this_process_not_on_the_workers_disks(cluster, tmp_path, monkeypatch):
    """With an external scheduler the workers wrote the job checkpoints on their own disks: after Ctrl-C the
    client's folder was empty, and a rerun redid the jobs."""
    from graspmanifold import generator

    _, executor = cluster
    written, real = [], generator.save_npz
    monkeypatch.setattr(generator, "save_npz", lambda path, *a, **k: written.append(path) or real(path, *a, **k))
    parts = tmp_path / "parts"
    gm.generate_postures("cylinder", 8, params=gm.GeneratorParams(job_size=2, verify=False), executor=executor,
                         checkpoint_dir=parts)
    assert written and sorted(written) == sorted(parts.glob("job_*.npz"))  # every job file, written here
