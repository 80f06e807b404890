"""The fair planned-grasp benchmark (issue 84): plans verified under the study's own protocol, displaced plans drawn
and recorded, the squeeze an experience carries (saved, loaded, pressed by the controller, part of the trials' key)."""

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
import pytest

from graspmanifold.base.errors import InvalidInput
from graspmanifold.control.controller import APPROACH, BatchController
from graspmanifold.control.recall import ApproachRecall
from graspmanifold.manifold.experience import PostureDatabase, carried_values
from graspmanifold.manifold.som import SOM
from graspmanifold.sim.hand import N_FINGER_JOINTS
from graspmanifold.studies.planned_grasps import drawn_plans
from graspmanifold.trials import planned
from graspmanifold.trials.planned import run_plan, verify_plans
from graspmanifold.trials.episode import run_trials
from graspmanifold.trials.setup import TrialSetup


def test_the_open_loop_at_0_cm_holds_every_plan_the_studys_verification_passed(box_plans):
    _, plans = box_plans
    verified = verify_plans("box", plans)
    assert verified.dtype == bool and verified.shape == (len(plans),)
    for plan, ok in zip(plans, verified):
        if ok:  # the benchmark's own open-loop trial of it at 0 cm: the same protocol and physics
            result = run_plan(plan, planned.get_object("box"), ("open-loop",), {}, np.zeros((1, 4)))
            assert result.held("open-loop").tolist() == [True]
    with pytest.raises(InvalidInput, match="open-loop arm"):
        verify_plans("box", plans, arm="oracle-correction")


def test_the_displaced_plans_are_drawn_among_the_verified_ones_and_two_draws_differ():
    verified = np.ones(30, dtype=bool)
    verified[[0, 5, 17]] = False
    first, second = drawn_plans(verified, 3, 0, 2, "box"), drawn_plans(verified, 3, 1, 2, "box")
    assert len(first) == len(second) == 3 and not np.array_equal(first, second)
    assert verified[first].all() and verified[second].all() and list(first) == sorted(first)
    assert np.array_equal(first, drawn_plans(verified, 3, 0, 2, "box"))  # recorded by its seed: the same again
    assert not np.array_equal(first, drawn_plans(verified, 3, 0, 3, "box"))  # each seed's own draw
    assert len(drawn_plans(verified[:2], 3, 0, 2, "box")) == 1  # fewer verified than asked: all of them


def test_a_small_study_records_its_verification_and_its_draw(box_plans, tmp_path, monkeypatch):
    """The study's own pipeline on a small family (four arms, the box's two plans, one displaced at 2 cm): the
    plans verified under its protocol, the draw and each plan's design kept in what it reports."""
    from graspmanifold.studies import planned_grasps
    from graspmanifold.studies.runner import run_study

    postures, _ = box_plans
    questions = planned_grasps.QUESTIONS[:2]
    small = replace(planned_grasps.EXECUTION, name="small", arms=("open-loop", "approach-recall",
                                                                   "approach-recall-fixed", "approach"),
                    questions=questions, verdict=lambda info: "")
    monkeypatch.setitem(planned_grasps.FAMILIES, "small", small)
    monkeypatch.setattr(planned_grasps, "LEVELS", (0.0, 0.02))
    monkeypatch.setattr(planned_grasps, "generate", lambda *args: postures)
    monkeypatch.setattr(planned_grasps.PlannedStudyConfig, "objects", property(lambda self: ("box",)))
    config = planned_grasps.PlannedStudyConfig(workers=1, seeds=(2,), plans=2, displaced=1, family="small", draw=5)
    infos = []
    run_study(tmp_path / "study", 1, lambda study: infos.append(planned_grasps.run(config, study)))
    info = infos[0]
    chosen = info["selection"]
    assert chosen["generated"] == {"box seed 2": 2} and chosen["drawn"]["box seed 2"] == drawn_plans(
        verify_plans("box", box_plans[1]), 1, 5, 2, "box").tolist()
    verified = chosen["verified"]["box seed 2"]
    assert info["ceiling"]["open-loop"] == [verified, verified]  # the open loop holds every verified plan at 0 cm
    assert info["ceiling"]["approach-recall-fixed"][1] == verified and info["by_level"]["approach-recall-fixed"][1] == [0, 0]
    assert info["by_level"]["approach"][1][1] > 0  # the displaced plan's 2 cm trials
    assert info["config"]["draw"] == 5 and {"low", "high", "clusters"} <= set(info["comparisons"][0]["bootstrap"])
    assert sum(cell["plans"] for cell in info["by_design"].values()) == verified
    assert info["noise_floor"]["trials"] == info["by_level"]["open-loop"][1][1]  # the rerun paired trial by trial
    assert -1.0 <= info["noise_floor"]["low"] <= info["noise_floor"]["high"] <= 1.0
    share = info["headroom"]["approach-recall"]  # the recalled squeeze's share of the fixed press's headroom
    assert share["clusters"] == verified and share["trials"] == verified
    text = planned_grasps.report(info)
    assert "## The plans" in text and "The noise floor" in text
    assert "(arm - approach-recall-fixed) / (ceiling - approach-recall-fixed) at 0 cm (every plan)" in text


def test_the_squeeze_survives_saving_and_loading_a_database_and_a_map(tmp_path):
    rng = np.random.default_rng(0)
    postures = rng.uniform(0.0, 1.0, (12, N_FINGER_JOINTS))
    squeezes = rng.uniform(-0.1, 0.1, (12, N_FINGER_JOINTS))
    database = PostureDatabase(postures, squeezes=squeezes)
    database.save(tmp_path / "database.npz")
    assert np.array_equal(PostureDatabase.load(tmp_path / "database.npz").squeezes, squeezes)
    som = SOM(2, 3, seed=0, epochs=5).fit(postures, progress=False)
    som.carry_squeezes(postures, squeezes)
    nearest = np.argmin(((som.references[:, None] - postures[None]) ** 2).sum(-1), axis=1)
    assert np.array_equal(som.squeezes, squeezes[nearest])  # each node its nearest posture's
    som.save(tmp_path / "map.npz")
    assert np.array_equal(SOM.load(tmp_path / "map.npz").squeezes, som.squeezes)
    assert set(carried_values(som)) == {"squeezes"}
    with pytest.raises(InvalidInput, match="squeezes must be"):
        PostureDatabase(postures, squeezes=squeezes[:, :3])
    with pytest.raises(InvalidInput, match=r"within \+-3.14"):
        PostureDatabase(postures, squeezes=np.full_like(squeezes, 50.0))
    with pytest.raises(InvalidInput, match="not real numbers"):
        PostureDatabase(postures, squeezes=np.full(squeezes.shape, 1j))


@dataclass(frozen=True)
class _SpyingApproach(ApproachRecall):
    """The approach execution, recording what its press gets and gives."""

    seen: ClassVar[list] = []

    def pressed(self, c, amount):
        out = super().pressed(c, amount)
        _SpyingApproach.seen.append((carried_values(c.experience).get("squeezes"), c.state.held.copy(),
                                     c.state.held_posture.copy(), c.state.heading.copy(), np.array(amount), out))
        return out


def test_the_recalled_squeeze_reaches_the_controller_and_is_pressed(box_plans):
    from graspmanifold.control.state import JOINT_FINGER

    _, plans = box_plans
    plan = plans[0]
    experience = PostureDatabase(plan.postures[1][None], squeezes=plan.squeeze_offset[None])
    _SpyingApproach.seen.clear()
    setup = TrialSetup(object="box", experience=experience, params=replace(APPROACH, recall=_SpyingApproach()),
                       plan=plan)
    run_trials(setup, np.zeros((1, 4)), [np.random.default_rng(0)])
    pressing = [seen for seen in _SpyingApproach.seen if seen[1].any() and (seen[3] > 0).any()]
    assert pressing, "no finger held a recalled grasp"
    squeezes, held, held_posture, heading, amount, out = pressing[-1]
    assert np.array_equal(squeezes, experience.squeezes)  # the experience's own squeeze, as given
    joints = held[0][JOINT_FINGER] & (heading[0][JOINT_FINGER] == 1)
    expected = held_posture[0] + amount.ravel()[0] / APPROACH.squeeze * plan.squeeze_offset
    limits = BatchController(1).limits
    assert np.allclose(out[0][joints], np.clip(expected, limits[:, 0], limits[:, 1])[joints])


def test_what_an_experience_carries_is_part_of_the_trials_key(box_plans):
    _, plans = box_plans
    posture = plans[0].postures[1][None]
    poses = np.zeros((1, 4))
    plain = TrialSetup(object="box", experience=PostureDatabase(posture), params=APPROACH)
    pressed = TrialSetup(object="box", experience=PostureDatabase(posture, squeezes=plans[0].squeeze_offset[None]),
                         params=APPROACH)
    placed = TrialSetup(object="box", experience=PostureDatabase(posture, places=[[0.0, -0.05, 0.08]]),
                        params=APPROACH)
    moved = TrialSetup(object="box", experience=PostureDatabase(posture, places=[[0.03, -0.05, 0.08]]),
                       params=APPROACH)
    keys = {setup.key(poses, 0) for setup in (plain, pressed, placed, moved)}
    assert len(keys) == 4
    assert pressed.provenance(0)["experience"]["squeezes_digest"] != ""
    assert "squeezes_digest" not in plain.provenance(0)["experience"]


def test_the_open_loop_given_two_attempts_executes_the_plan_again_from_its_pregrasp(box_plans):
    from graspmanifold.trials.open_loop import OpenLoopController

    _, plans = box_plans
    controller = OpenLoopController(3, plans[0])
    first = [controller.step(None, None) for _ in range(400)][-1]
    assert controller.done.all() and np.allclose(first, plans[0].postures[2])  # at the squeeze
    controller.restart(np.array([1]), np.zeros((1, N_FINGER_JOINTS)), np.zeros((1, 1)))
    assert controller.attempt.tolist() == [1, 2, 1] and controller.done.tolist() == [True, False, True]
    again = controller.step(None, None)
    t = 1 / controller.targets  # the first interpolated target from the pregrasp, as the first attempt's was
    assert np.allclose(again[1], (1 - t) * plans[0].postures[0] + t * plans[0].postures[1])
    assert np.allclose(again[[0, 2]], plans[0].postures[2])  # the others keep their squeeze
    result = run_plan(plans[0], planned.get_object("box"), ("flange-open-loop-x2",), {},
                      np.array([[0.0, 0.0, 0.0, 0.0], [0.05, 0.0, 0.0, 0.0]]))
    trials = result.trials["flange-open-loop-x2"]
    assert all(not t.fault and t.attempts in (1, 2) for t in trials) and trials[0].hold


def test_the_translation_only_oracle_moves_the_palm_without_turning_it(box_plans):
    from graspmanifold.base.poses import compose, invert
    from graspmanifold.sim.flange import FlangeLimits
    from graspmanifold.trials.grid import displaced_palm_pose

    _, plans = box_plans
    plan = plans[0]
    moves = np.array([[0.02, 0.0, 0.0, 0.2], [0.0, -0.01, 0.0, 0.0]])
    setup = TrialSetup(object="box", plan=plan, controller=planned.OpenLoop(plan), method="oracle translation",
                       palm=FlangeLimits(), oracle="translation")
    seen = []
    run_trials(setup, moves, [np.random.default_rng(i) for i in range(len(moves))], observer=lambda worlds: seen.append(
        [compose(*invert(*scene.object_pose()), *scene.hand_pose()) for scene in worlds.scenes]))
    for (position, quat), move in zip(seen[30], moves):  # once the correction has arrived, before the grasp
        start = displaced_palm_pose(plan.poses[0], move)
        assert abs(np.dot(quat, start[1])) > np.cos(0.01 / 2)  # not turned: as the displaced start was
    assert np.linalg.norm(seen[30][1][0] - plan.poses[0, :3]) < 0.003  # no yaw: moved back to the plan's palm
    with pytest.raises(InvalidInput, match="oracle must be"):
        TrialSetup(object="box", plan=plan, palm=FlangeLimits(), oracle="rotation", method="oracle")
    keys = {TrialSetup(object="box", plan=plan, palm=FlangeLimits(), oracle=o, method="oracle").key(moves, 0)
            for o in (True, "translation")}
    assert len(keys) == 2


RULE = '''
from dataclasses import dataclass
from graspmanifold.control.recall import ApproachRecall


@dataclass(frozen=True)
class MyRule(ApproachRecall):
    def pressed(self, c, amount):
        return super().pressed(c, {amount})
'''


def test_ones_own_recall_rule_is_keyed_by_its_code_not_its_name(tmp_path, monkeypatch):
    """Round seven's bad case 2: after an edit to one's own rule, a rerun must not resume the old code's trials."""
    import importlib
    import sys

    from graspmanifold.base.checkpoints import code_identity

    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "my_rule.py").write_text(RULE.format(amount="amount"))
    module = importlib.import_module("my_rule")
    poses = np.zeros((1, 4))
    first = TrialSetup(object="box", params=replace(APPROACH, recall=module.MyRule()))
    key, made_by = first.key(poses, 0), first.provenance(0)  # the first run's
    (tmp_path / "my_rule.py").write_text(RULE.format(amount="0.5 * amount"))
    sys.modules.pop("my_rule")
    edited = TrialSetup(object="box", params=replace(APPROACH, recall=importlib.import_module("my_rule").MyRule()))
    assert key != edited.key(poses, 0) and made_by["code"]["recall"] != edited.provenance(0)["code"]["recall"]
    assert made_by["code"]["recall"].startswith("source:")
    assert TrialSetup(object="box", params=APPROACH).code() == {}  # the library's own: its fingerprint covers them

    class Stated(ApproachRecall):
        version = "2"

    assert code_identity(Stated()) == "version:2"
    namespace: dict = {"__name__": "a_notebook_cell"}
    exec("class Unreadable:\n    pass", namespace)  # no source to read: never resumed, and said so
    with pytest.warns(UserWarning, match="will not be resumed"):
        unknown = code_identity(namespace["Unreadable"]())
    assert unknown.startswith("unknown:") and code_identity(namespace["Unreadable"]) == unknown
