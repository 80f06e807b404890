"""The batched controller and the batched trials agree with the single-trial reference."""

import os

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.control.batch_controller import PHASES, BatchController
from graspmanifold.sim.posture import pcp_mask, pcp_masks
from graspmanifold.trials.grid import check_grid, palm_pose_for


@pytest.fixture(scope="module")
def experience():
    candidates = gm.generate_postures("cylinder", 60, seed=0, params=gm.GeneratorParams(job_size=15, verify=False))
    postures = gm.verify_postures(candidates, "cylinder").postures  # those of the 60 that hold
    return {"none": None, "database": gm.PostureDatabase(postures),
            "som": gm.SOM(6, 6, 22, seed=0).fit(postures, epochs=20)}


def reference_readings(obj, experience, poses, params=None, preshape=None, cycles=80):
    """Run the reference controller on real scenes; per pose the readings it got and what it did."""
    runs = []
    for pose in poses:
        scene = gm.Scene(obj, free_object=True)
        scene.set_object_support(2000.0, 30.0)
        controller = gm.GraspController(experience, params, preshape=preshape)
        scene.set_hand_pose(*palm_pose_for(gm.get_object(obj), pose))
        scene.set_posture(controller.initial)
        run = {"joints": [], "forces": [], "targets": [], "phase": [], "matches": [], "done": [], "winners": []}
        for _ in range(cycles):
            joints, forces = scene.posture(), scene.tactile().segment_forces
            target = controller.step(joints, forces)
            for key, value in zip(run, (joints, forces, target, controller.phase, controller.matches, controller.done,
                                        list(controller.winners))):
                run[key].append(value)
            scene.set_target(target)
            scene.run(controller.params.control_period)
        runs.append(run)
    return runs


@pytest.mark.parametrize("kind", ["none", "database", "som"])
def test_batched_controller_makes_the_references_decisions_cycle_by_cycle(experience, kind):
    _, poses = check_grid("quick", gm.get_object("cylinder"))
    poses = poses[::6][:5]
    runs = reference_readings("cylinder", experience[kind], poses)
    batch = BatchController(len(poses), experience[kind])
    for cycle in range(len(runs[0]["joints"])):
        targets = batch.step(np.array([r["joints"][cycle] for r in runs]), np.array([r["forces"][cycle] for r in runs]))
        for world, run in enumerate(runs):
            assert np.array_equal(targets[world], run["targets"][cycle]), (world, cycle)
            assert batch.done[world] == run["done"][cycle]
            assert batch.matches[world] == run["matches"][cycle]
            assert batch.winners[world] == run["winners"][cycle]  # the per-cycle best matches it used
            assert len(run["winners"][cycle]) == run["matches"][cycle]
            assert PHASES[batch.phase[world]] == run["phase"][cycle]
    assert batch.done.any() and (kind == "none" or batch.matches.sum() > 0)
    if kind != "none":  # the winners are rows of the experience's references, each the best match of its query
        assert all(0 <= w < len(experience[kind].references) for world in batch.winners for w in world)


def test_batched_controller_follows_the_switches_and_a_constant_preshape(experience):
    _, poses = check_grid("quick", gm.get_object("cylinder"))
    poses = poses[1::9][:3]
    preshape = gm.GraspController().initial.copy()
    preshape[[1, 5, 9]] += 0.3
    for params, shape in ((gm.ControllerParams(experience_steering=False), None),
                          (gm.ControllerParams(steered_joints="spread", max_match_distance=np.inf), None),
                          (gm.ControllerParams(restart_closure=True, steered_fingers=("th", "ff")), None),
                          (gm.ControllerParams(reach=0.03, max_match_distance=np.inf), None),
                          (gm.ControllerParams(), preshape)):
        runs = reference_readings("cylinder", experience["database"], poses, params, shape, cycles=60)
        batch = BatchController(len(poses), experience["database"], params, preshape=shape)
        for cycle in range(60):
            targets = batch.step(np.array([r["joints"][cycle] for r in runs]),
                                 np.array([r["forces"][cycle] for r in runs]))
            assert np.array_equal(targets, np.array([r["targets"][cycle] for r in runs])), (params, cycle)


def test_pcp_masks_agree_with_pcp_mask(rng):
    touching = rng.random((300, len(gm.SEGMENTS))) < 0.15
    expected = np.array([pcp_mask([s for s, t in zip(gm.SEGMENTS, row) if t]) for row in touching])
    assert np.array_equal(pcp_masks(touching), expected)
    with pytest.raises(ValueError, match="touching must have shape"):
        pcp_masks(touching[:, :5])


def test_batched_controller_rejects_bad_readings():
    batch = BatchController(3)
    with pytest.raises(ValueError, match="joints must be"):
        batch.step(np.zeros((2, 22)), np.zeros((3, len(gm.SEGMENTS))))
    with pytest.raises(ValueError, match="segment_forces must be"):
        batch.step(np.zeros((3, 22)), np.full((3, len(gm.SEGMENTS)), np.nan))
    with pytest.raises(ValueError, match="n \\(worlds\\)"):
        BatchController(0)


TRIAL_FIELDS = ("posture", "touching", "epsilon", "hold", "hold_displacement", "time_to_grasp", "matches", "margin",
                "penetration", "fault", "winners")


@pytest.mark.parametrize("kind,noise,params", [("database", gm.Noise(), None), ("som", gm.Noise(0.004, 0.08, 0.01), None),
                                               ("som", gm.Noise(), gm.ControllerParams(reach=0.03))])
def test_batched_trials_are_the_single_trials_bit_for_bit(experience, kind, noise, params):
    from graspmanifold.trials.batch_trials import run_trials
    from graspmanifold.trials.trial import TrialSetup, run_trial

    obj = gm.get_object("cylinder")
    _, poses = check_grid("quick", obj)
    poses = poses[::5]
    rngs = [np.random.default_rng([3, i]) for i in range(len(poses))]
    setup = TrialSetup(obj, experience[kind], noise, params)
    batched = run_trials(setup, poses, rngs)
    for i, (pose, trial) in enumerate(zip(poses, batched)):
        single = run_trial(setup, pose, np.random.default_rng([3, i]))
        for field in TRIAL_FIELDS:
            assert np.array_equal(getattr(single, field), getattr(trial, field)), (i, field)
    assert any(t.hold for t in batched) and any(t.margin > 0 for t in batched)


def test_evaluate_names_a_bad_backend_and_a_missing_gpu():
    with pytest.raises(ValueError, match="backend must be one of"):
        gm.evaluate("box", None, "quick", backend="gpu")
    with pytest.raises(ValueError, match="batch_size"):
        gm.evaluate("box", None, "quick", backend="warp", batch_size=0)
    try:  # without the gpu extra, or without a GPU, the warp backend says what is missing
        import warp

        has_gpu = bool(warp.get_cuda_device_count())
    except ImportError:
        has_gpu = False
    if not has_gpu and not os.environ.get("GRASPMANIFOLD_WARP_DEVICE"):
        with pytest.raises((ImportError, RuntimeError), match="graspmanifold\\[gpu\\]|NVIDIA GPU"):
            gm.evaluate("box", None, np.array([[0.0, 0.0, 0.01, 0.0]]), backend="warp")
