"""Pose uncertainty: errors drawn as stated, never read by a controller; the open loop replays the grasp planned
for the nominal pose where the object really is; the study runs end to end."""

import json
import math

import numpy as np
import pytest

from graspmanifold.base.errors import InvalidInput
from graspmanifold.control.controller import BatchController
from graspmanifold.judging.plans import PREGRASP_BACK_OFF, open_loop_grasp
from graspmanifold.sim.hand import N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND
from graspmanifold.trials import pose_errors as uncertainty
from graspmanifold.trials.benchmark import OBJECTS, benchmark_split
from graspmanifold.trials.evaluation import evaluate
from graspmanifold.trials.grid import palm_pose_for, reachable
from graspmanifold.trials.pose_errors import (
    MAX_YAW_ERROR,
    POSITION_ERRORS,
    carried,
    open_loop,
    plan,
    pose_errors,
)

BOX = OBJECTS["box"].object
MARBLE = OBJECTS["marble"].object
#: a box near the palm: the plain heuristic holds it, and its grasp replays open loop to a hold
BOX_POSE = np.array([0.0, 0.0, 0.01, 0.0])


def test_every_nominal_pose_is_moved_by_exactly_each_level_in_the_palm_plane_and_turned_within_its_bound():
    nominal = benchmark_split()["test"][("marble", "fingertips")][:12]
    errors = pose_errors(MARBLE, nominal, seed=3)
    levels = len(POSITION_ERRORS)
    assert len(errors.kept) == len(nominal)  # every pose found clear draws: stratified, every level holds every pose
    assert np.array_equal(errors.nominal, np.repeat(nominal, levels, axis=0))
    assert np.array_equal(errors.level, np.tile(POSITION_ERRORS, len(nominal)))
    moved = errors.true - errors.nominal
    assert np.allclose(np.linalg.norm(moved[:, :2], axis=1), errors.level, atol=1e-12)  # exactly the level's distance
    assert np.all(moved[:, 2] == 0.0)  # the gap in front of the palm is kept
    assert np.all(np.abs(moved[:, 3]) <= MAX_YAW_ERROR * errors.level / POSITION_ERRORS[-1] + 1e-12)
    assert reachable(MARBLE, errors.true).all()  # no object starts inside the open hand
    directions = np.arctan2(moved[errors.level > 0, 1], moved[errors.level > 0, 0])
    assert np.ptp(directions) > math.pi  # drawn around the circle, not along one axis
    again = pose_errors(MARBLE, nominal, seed=3)
    assert np.array_equal(again.true, errors.true)  # the same seed, the same errors
    assert not np.array_equal(pose_errors(MARBLE, nominal, seed=4).true, errors.true)


@pytest.mark.parametrize("nominal, levels, word", [
    (np.zeros((3, 3)), POSITION_ERRORS, "nominal"), (np.full((2, 4), np.nan), POSITION_ERRORS, "nominal"),
    (np.zeros((2, 4)), (0.0, 0.05, 0.01), "levels"), (np.zeros((2, 4)), (0.0, -0.01), "levels")])
def test_bad_pose_errors_are_refused_by_name(nominal, levels, word):
    with pytest.raises(InvalidInput, match=word):
        pose_errors(BOX, nominal, levels)


def test_no_controller_is_given_the_pose_error(monkeypatch):
    """The trials take the true pose only: the controller is handed sensed joints and touch, and two nominal poses
    whose errors bring the object to the same true pose give the same inputs and the same trial."""
    seen = []
    original = BatchController.step

    def spy(self, *args, **kwargs):
        seen.append((len(args), tuple(kwargs), [np.array(a, copy=True) for a in args]))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(BatchController, "step", spy)
    true = BOX_POSE + np.array([0.01, 0.0, 0.0, 0.1])
    runs = []
    for nominal in (BOX_POSE, BOX_POSE + np.array([0.02, 0.0, 0.0, 0.2])):  # errors +1 cm and -1 cm: the same true pose
        seen.clear()
        trial = evaluate(BOX, None, true[None], workers=1, progress=False).trials[0]
        assert all(count == 2 and not keywords for count, keywords, _ in seen)  # step(joints, forces), nothing else
        assert all(a[0].shape == (1, N_FINGER_JOINTS) and a[1].shape == (1, len(SEGMENTS)) for _, _, a in seen)
        runs.append(([a for _, _, a in seen], trial))
        del nominal  # the nominal pose goes nowhere a trial could see it
    (inputs_a, trial_a), (inputs_b, trial_b) = runs
    assert len(inputs_a) == len(inputs_b) and all(
        np.array_equal(x, y) for a, b in zip(inputs_a, inputs_b) for x, y in zip(a, b))
    assert trial_a.hold == trial_b.hold and np.array_equal(trial_a.posture, trial_b.posture)


def test_a_grasp_carried_to_the_true_pose_keeps_the_hand_where_the_plan_sent_it():
    posture = np.zeros(N_FINGER_JOINTS)
    grasp = open_loop_grasp(np.concatenate(palm_pose_for(BOX, BOX_POSE)), posture)
    same = carried(BOX, grasp, BOX_POSE, BOX_POSE)
    assert np.allclose(same.poses, grasp.poses) and np.array_equal(same.postures, grasp.postures)
    true = BOX_POSE + np.array([0.02, -0.01, 0.0, 0.3])
    moved = carried(BOX, grasp, BOX_POSE, true)
    # the grasp's palm, in the true object's frame, is where the palm stands for an object at the true grid pose
    position, quat = palm_pose_for(BOX, true)
    assert np.allclose(moved.poses[1, :3], position, atol=1e-9)
    assert np.isclose(abs(np.dot(moved.poses[1, 3:], quat)), 1.0, atol=1e-9)
    # the pregrasp moved with it, rigidly: still 2 cm back from the grasp's palm; the postures are the plan's
    assert np.isclose(np.linalg.norm(moved.poses[0, :3] - moved.poses[1, :3]), PREGRASP_BACK_OFF)
    assert np.array_equal(moved.postures, grasp.postures)


def test_the_open_loop_replays_the_nominal_plan_at_the_true_pose(monkeypatch):
    held = evaluate(BOX, None, BOX_POSE[None], workers=1, progress=False).trials[0]
    assert held.hold
    candidates = np.stack([np.full((1, N_FINGER_JOINTS), np.nan), held.posture[None]])  # the first: no candidate
    planned = plan(BOX, BOX_POSE[None], candidates)
    limits = SHADOW_HAND.limits()
    assert np.allclose(planned[0], np.clip(held.posture, limits[:, 0], limits[:, 1]))  # verified where planned
    replayed = []
    real = uncertainty.replay

    def spy(obj, grasps, protocol="hold-test", hand="shadow-primitives"):
        replayed.extend(grasps)
        return real(obj, grasps, protocol, hand)

    monkeypatch.setattr(uncertainty, "replay", spy)
    true = np.array([BOX_POSE, BOX_POSE + np.array([0.05, 0.0, 0.0, 0.0])])
    ok, faults = open_loop(BOX, np.repeat(planned, 2, axis=0), np.repeat(BOX_POSE[None], 2, axis=0), true)
    assert ok[0] and faults == ["", ""]  # at the nominal pose the plan holds: it was verified there
    for grasp, pose in zip(replayed, true):  # each replay: the plan's postures, the palm where the nominal put it
        assert np.allclose(grasp.postures[1], planned[0])
        assert np.allclose(grasp.poses[1, :3], palm_pose_for(BOX, pose)[0], atol=1e-9)
    with pytest.raises(InvalidInput, match="finite"):
        open_loop(BOX, np.full((1, N_FINGER_JOINTS), np.nan), BOX_POSE[None], BOX_POSE[None])
    with pytest.raises(InvalidInput, match="candidates"):
        plan(BOX, BOX_POSE[None], np.zeros((1, 2, N_FINGER_JOINTS)))


def test_the_uncertainty_study_runs_and_reports_every_method_at_every_level(tmp_path):
    from graspmanifold.studies.uncertainty import (
        UncertaintyStudy,
        UncertaintyStudyConfig,
    )

    config = UncertaintyStudyConfig(quick=True, workers=1, every=80, postures=3, out=str(tmp_path / "out"))
    info = UncertaintyStudy(config).run()
    stored = json.loads((tmp_path / "out" / "study.json").read_text())
    assert stored["verdict"] == info["verdict"] and (tmp_path / "out" / "uncertainty_study.png").stat().st_size > 0
    assert stored["run"]["wall_seconds"] > 0 and stored["run"]["results_computed"] > 0  # how long it ran, recorded
    report = (tmp_path / "out" / "uncertainty_study.md").read_text()
    assert "## Verdict" in report and "uncertainty_study.png" in report
    levels = [f"{v:.0f}" for v in info["levels_cm"]]
    nominal = info["nominal_poses"]["test"]
    for method, counts in info["curve"].items():
        assert list(counts) == levels
        for held, n in counts.values():
            assert 0 <= held <= n <= nominal
        assert all(n <= info["plans"]["with_plan"] for _, n in counts.values())  # one denominator: the planned poses
        if method.startswith("open_loop"):  # over the poses with a plan, at every level alike
            assert {n for _, n in counts.values()} <= {info["plans"]["with_plan"]}
    assert info["selected"]["chosen"] in info["curve"] and info["null"] == info["selected"]["chosen"] + "_null"
    assert info["null"] in info["curve"] and not any(m.startswith("open_loop") for m in info["every_pose"])
    assert all(info["covered_curve"][m][lv][1] <= info["curve"][m][lv][1] for m in info["curve"] for lv in levels)
    assert "null map" in report and "covered" in report

