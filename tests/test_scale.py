"""Trials at GPU scale (issue 71): a set-up that does not grow with the worlds, and its Warp worlds, checked on
Warp's CPU device where the gpu extra is installed (skipped without it)."""

import os

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.sim.worlds import WorldStarts
from graspmanifold.trials.grid import check_grid
from graspmanifold.trials.episode import trial_scene, trial_starts
from graspmanifold.trials.setup import Noise, TrialSetup

FIELDS = ("qpos", "ctrl", "mocap_pos", "mocap_quat")


def _starts_both_ways(setup: TrialSetup, poses: np.ndarray) -> tuple[WorldStarts, WorldStarts]:
    initial = gm.open_posture()
    scenes = [trial_scene(setup, pose, np.random.default_rng([7, k]), initial) for k, pose in enumerate(poses)]
    _, batched = trial_starts(setup, poses, [np.random.default_rng([7, k]) for k in range(len(poses))], initial)
    return WorldStarts.of_scenes(scenes), batched


@pytest.mark.parametrize("name, noise", [("cylinder", Noise()), ("box", Noise(position=0.004, yaw=0.1))])
def test_one_scene_gives_every_world_the_start_a_scene_of_its_own_gives(name, noise):
    """World by world, the batched start (one scene, what differs worked out for all worlds at once) is the per-world
    scene's: the same joint positions, controls and hand mount, the pose noise drawn from the same streams."""
    setup = TrialSetup(object=name, noise=noise)
    poses = check_grid("quick", setup.object)[1][:6]
    alone, batched = _starts_both_ways(setup, poses)
    assert batched.n == len(poses)
    for field in FIELDS:  # the mounts' poses in array arithmetic: the same but for the last bits
        assert np.allclose(getattr(alone, field), getattr(batched, field), rtol=0.0, atol=1e-12), field
    assert len({tuple(row) for row in batched.mocap_pos.reshape(len(poses), -1)}) == len(poses)  # placed apart


def test_a_planned_grasp_starts_the_same_way_batched_or_a_scene_each():
    """With a plan (its pregrasp placed for the nominal object, the object displaced by the grid pose) the batched
    start is the per-world scene's too."""
    from graspmanifold.judging.plans import open_loop_grasp
    from graspmanifold.trials.grid import palm_pose_for

    obj = gm.get_object("cylinder")
    posture = gm.open_posture() * 0.5 + gm.closed_posture() * 0.2
    plan = open_loop_grasp(np.concatenate(palm_pose_for(obj, np.array([0.0, 0.0, 0.01, 0.0]))), posture)
    displacements = np.array([[0.0, 0.0, 0.0, 0.0], [0.01, -0.005, 0.004, 0.1], [-0.01, 0.0, 0.0, -0.1]])
    alone, batched = _starts_both_ways(TrialSetup(object=obj, plan=plan), displacements)
    for field in FIELDS:
        assert np.allclose(getattr(alone, field), getattr(batched, field), rtol=0.0, atol=1e-12), field


def test_warp_worlds_of_one_scene_and_starts_are_the_worlds_of_their_scenes(monkeypatch):
    """On Warp's CPU device: the worlds made from one scene and the starts hold, world by world, what the worlds
    made from a scene per world hold (joints, object positions, controls), and both refuse bad starts by name."""
    pytest.importorskip("mujoco_warp")
    monkeypatch.setenv("GRASPMANIFOLD_WARP_DEVICE", os.environ.get("GRASPMANIFOLD_WARP_DEVICE", "cpu"))
    from graspmanifold.sim.warp_worlds import WarpWorlds

    setup = TrialSetup(object="sphere", noise=Noise(position=0.003, yaw=0.05), backend="warp")
    poses = check_grid("quick", setup.object)[1][:4]
    initial = gm.open_posture()
    scenes = [trial_scene(setup, pose, np.random.default_rng([7, k]), initial) for k, pose in enumerate(poses)]
    old = WarpWorlds.from_scenes(scenes)
    new = WarpWorlds(*trial_starts(setup, poses, [np.random.default_rng([7, k]) for k in range(len(poses))], initial))
    everyone = np.arange(len(poses))
    assert np.allclose(old.joints(everyone), new.joints(everyone), rtol=0.0, atol=1e-6)  # single precision
    assert np.allclose(old.object_positions(), new.object_positions(), rtol=0.0, atol=1e-6)
    assert np.array_equal(old.scene.data.ctrl, scenes[0].data.ctrl)
    bad = WorldStarts(np.zeros((2, 3)), np.zeros((2, 1)), np.zeros((2, 1, 3)), np.zeros((2, 1, 4)))
    with pytest.raises(gm.InvalidInput, match="starts must hold"):
        WarpWorlds(scenes[0], bad)


def test_the_device_checks_dry_run_writes_its_one_json(tmp_path):
    """`scripts/gpu_check.sh --dry-run`: the lent machine's check at a few worlds on Warp's CPU device, its JSON
    holding the speeds, the agreement with the CPU per paper object and what made it."""
    pytest.importorskip("mujoco_warp")
    import json
    import subprocess
    from pathlib import Path

    out = tmp_path / "gpu_check.json"
    script = Path(__file__).resolve().parents[1] / "scripts" / "gpu_check.sh"
    env = {**os.environ, "GRASPMANIFOLD_WARP_DEVICE": "cpu", "OUT": str(tmp_path)}
    subprocess.run(["bash", str(script), "--dry-run", "--json", str(out)], check=True, env=env, timeout=1500)
    record = json.loads(out.read_text())
    assert [r["worlds"] for r in record["speed"]] == [4, 8] and not record["skipped"]
    assert all(r["trials_per_minute"] > 0 and r["world_steps_per_s"] > 0 for r in record["speed"])
    assert [r["object"] for r in record["agreement"]] == list(gm.PAPER_OBJECTS)
    assert all(0 < r["trials"] <= 2 and 0 <= r["same_hold"] <= r["trials"] for r in record["agreement"])
    assert sum(r["same_hold"] for r in record["agreement"]) >= 5  # 6 of 6 when it was written
    assert record["device"] == "cpu" and not record["cuda_graphs"] and record["buffers_per_world"]["contacts"] > 0
