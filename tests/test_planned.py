"""The planned-grasp benchmark: the palm where the plan puts it for the nominal pose, the displacement never read by
a controller, the open loop replaying the plan's verified stages, every arm from the same state, faults counted as
failures; the settled squeeze; the null experience."""

from dataclasses import replace

import numpy as np
import pytest

from graspmanifold.base.errors import InvalidInput
from graspmanifold.base.poses import compose, invert
from graspmanifold.control.controller import APPROACH, BatchController, ControllerParams, SETTLED_BLEND
from graspmanifold.trials.open_loop import OpenLoop, OpenLoopController
from graspmanifold.manifold.experience import PostureDatabase, scrambled
from graspmanifold.sim.hand import FINGER_JOINTS, N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND
from graspmanifold.sim.posture import open_posture
from graspmanifold.trials import planned
from graspmanifold.trials.evaluation import evaluate
from graspmanifold.trials.grid import displaced_palm_pose
from graspmanifold.trials.planned import ARMS, LEVELS, PlanTrials, arm_setup, displacements, run_plan
from graspmanifold.trials.episode import run_trials, trial_scene
from graspmanifold.trials.record import Trial
from graspmanifold.trials.setup import Noise, TrialSetup

BOX_MOVES = np.array([[0.0, 0.0, 0.0, 0.0], [0.02, 0.0, 0.0, 0.2], [0.0, -0.01, 0.0, -0.1]])


class Spy:
    """A controller that records everything it is given and closes nothing."""

    made: list = []

    def __init__(self, n, hand):
        Spy.made.append((n, hand))
        self.n, self.control_period, self.initial = n, 0.02, open_posture(hand)
        self.done = np.zeros(n, dtype=bool)
        self.seen = []
        Spy.last = self

    def reset(self):
        self.done[:] = False

    def step(self, joints, segment_forces):
        self.seen.append((np.array(joints), np.array(segment_forces)))
        self.done[:] = len(self.seen) >= 3
        return np.tile(self.initial, (self.n, 1))


def test_a_planned_trial_puts_the_palm_at_the_plans_pose_for_the_nominal_object_and_never_tells_the_displacement(
        box_plans):
    _, plans = box_plans
    plan = plans[0]
    setup = TrialSetup(object="box", plan=plan, controller=Spy, method="spy")
    for move in BOX_MOVES:  # the palm, seen from where the nominal object would be, is where the plan says
        scene = trial_scene(setup, move, np.random.default_rng(0), open_posture())
        assert np.allclose(scene.posture(), plan.postures[0], atol=1e-9)  # in the plan's pregrasp
        palm_in_true = scene.hand_pose()
        x, z, gap, yaw = move
        nominal_in_palm = invert(plan.poses[0, :3], plan.poses[0, 3:])
        true_in_palm = invert(*palm_in_true)
        assert np.allclose(true_in_palm[0] - nominal_in_palm[0], [x, -gap, z], atol=1e-9)
        turned = compose(*true_in_palm, *invert(*nominal_in_palm))[1]
        assert np.isclose(2 * np.arccos(min(1.0, abs(turned[0]))), abs(yaw), atol=1e-6)
    assert np.allclose(np.concatenate(displaced_palm_pose(plan.poses[0], np.zeros(4))), plan.poses[0], atol=1e-12)
    Spy.made = []
    run_trials(setup, BOX_MOVES, [np.random.default_rng(i) for i in range(len(BOX_MOVES))])
    assert Spy.made == [(len(BOX_MOVES), SHADOW_HAND)]  # the worlds and the hand: nothing of the poses
    joints, forces = Spy.last.seen[0]
    assert joints.shape == (len(BOX_MOVES), N_FINGER_JOINTS) and forces.shape == (len(BOX_MOVES), len(SEGMENTS))
    assert np.array_equal(joints, np.tile(joints[0], (len(BOX_MOVES), 1)))  # the same open hand wherever the box is
    assert not forces.any()


def test_the_open_loop_replays_the_plans_verification_stages(box_plans):
    postures, plans = box_plans
    plan = plans[0]
    assert postures.metadata["generator"]["stages"] == "contacts"  # verified with the stages made from the contacts
    controller = OpenLoopController(2, plan)
    assert np.array_equal(controller.initial, plan.postures[0]) and not controller.moves_palm
    targets = []
    while not controller.done.all():
        targets.append(controller.step(np.zeros((2, N_FINGER_JOINTS)), np.zeros((2, len(SEGMENTS))))[0])
    per_move = controller.targets * controller.periods_per_target
    assert len(targets) == 2 * per_move  # pregrasp -> grasp -> squeeze, DexGraspBench's 10 targets each
    for move, waypoint in enumerate(plan.postures[1:]):
        assert np.allclose(targets[(move + 1) * per_move - 1], waypoint, atol=1e-12)
    assert np.allclose(targets[1], 0.9 * plan.postures[0] + 0.1 * plan.postures[1])  # its first target, two periods
    opened = planned.open_start(plan)  # started from the open hand instead, it shapes the grasp from there
    assert np.array_equal(OpenLoopController(1, opened).initial, open_posture())
    assert np.array_equal(opened.postures[1:], plan.postures[1:])
    after = controller.step(np.zeros((2, N_FINGER_JOINTS)), np.zeros((2, len(SEGMENTS))))
    assert np.allclose(after, plan.postures[2])  # done, it keeps the squeeze
    with pytest.raises(InvalidInput, match="OpenLoopGrasp"):
        OpenLoopController(1, plan.postures)


@pytest.mark.parametrize("family, reference", [(planned.EXECUTION_ARMS, "open-loop"),
                                               (planned.PALM_ARMS, "flange-open-loop")], ids=["execution", "palm"])
def test_every_arm_of_one_pose_starts_from_the_same_state(box_plans, family, reference):
    postures, plans = box_plans
    experiences = {"object": PostureDatabase(postures.postures),
                   "scrambled": PostureDatabase(scrambled(postures.postures))}
    starts, firsts = {}, {}
    for name in family:
        arm = ARMS[name]
        if arm.attempts > 1:  # the same set-up but for what follows a failed probe
            continue
        setup = arm_setup(arm, planned.get_object("box"), plans[1], experiences)
        seen = []

        def observe(worlds, seen=seen):
            scene = worlds.scenes[0]
            seen.append((scene.state().copy(), scene.data.qvel.copy(), scene.model.opt.gravity.copy(),
                         scene.model.jnt_stiffness.copy(), scene.model.qpos_spring.copy(), scene.data.ctrl.copy()))

        run_trials(setup, BOX_MOVES[1:2], [np.random.default_rng(0)], observer=observe)
        starts[name], firsts[name] = seen[0], seen[1]
    reference = starts[reference]
    for name, start in starts.items():
        for a, b in zip(start, reference):
            assert np.array_equal(a, b), name
    # the first physics step: the same state stepped, so arms that command the same first targets agree bit for bit
    groups: dict[bytes, list] = {}
    for name, first in firsts.items():
        groups.setdefault(first[-1].tobytes(), []).append(first)
    assert any(len(group) > 1 for group in groups.values())
    for group in groups.values():
        assert all(np.array_equal(first[0], group[0][0]) and np.array_equal(first[1], group[0][1]) for first in group)


def test_a_fault_in_any_arm_is_a_failure_and_is_reported():
    ok = Trial(np.zeros(4), np.zeros(22), np.zeros(len(SEGMENTS), bool), 0.1, True, 0.0, 1.0, 0)
    bad = replace(ok, fault="the physics failed")
    trials = PlanTrials(np.zeros((3, 4)), np.array([1, 0, 2]), {"a": [ok, bad], "b": [bad, ok]}, np.zeros((3, 3)))
    assert trials.held("a").tolist() == [True, False, False] and trials.faulted("a").tolist() == [False, False, True]
    assert trials.held("b").tolist() == [False, False, True] and trials.faulted("b").tolist() == [True, False, False]


def test_holds_without_force_closure_are_examined_by_what_touched_and_the_timeout():
    from graspmanifold.studies.planned_grasps import outcomes_of, without_closure

    touch = np.zeros(len(SEGMENTS), bool)
    pinch, hook = touch.copy(), touch.copy()
    pinch[[SEGMENTS.index("thdistal"), SEGMENTS.index("ffdistal")]] = True
    hook[[SEGMENTS.index("palm"), SEGMENTS.index("mfmiddle")]] = True
    closed = Trial(np.zeros(4), np.zeros(22), pinch, 0.1, True, 0.0, 1.0, 0)
    trials = [closed, replace(closed, epsilon=0.0, time_to_grasp=3.0), replace(closed, epsilon=0.0, touching=hook),
              replace(closed, epsilon=0.0, hold=False)]
    result = PlanTrials(np.zeros((5, 4)), np.array([1, 1, 0, 1, 2]), {"approach-recall": trials}, np.zeros((5, 3)))
    assert without_closure({"plan": outcomes_of(result)}, "approach-recall") == {
        "held": 3, "no_closure": 2, "at_timeout": 1, "thumb_opposed": 1, "palm_no_thumb": 1, "fingers_only": 0}


def test_displacements_are_each_level_in_eight_directions_with_a_bounded_yaw_and_the_seed_decides():
    moved = displacements(seed=3, plan=2)
    assert moved.shape == (1 + 8 * (len(LEVELS) - 1), 4) and not moved[0].any()
    assert np.allclose(np.sort(planned.level_of(moved)), np.repeat(LEVELS, [1] + [8] * (len(LEVELS) - 1)))
    assert not moved[:, 2].any()  # in the palm's plane
    levels = planned.level_of(moved)
    assert np.all(np.abs(moved[:, 3]) <= planned.MAX_YAW * levels / max(LEVELS) + 1e-12)
    assert np.array_equal(moved, displacements(seed=3, plan=2)) and not np.array_equal(moved, displacements(seed=4, plan=2))
    with pytest.raises(InvalidInput, match="levels"):
        displacements((0.02, 0.01))
    with pytest.raises(InvalidInput, match="directions"):
        displacements(directions=0)


def test_a_planned_setup_refuses_what_it_cannot_run(box_plans):
    _, plans = box_plans
    with pytest.raises(InvalidInput, match="plan must be an OpenLoopGrasp"):
        TrialSetup(object="box", plan=plans[0].postures)
    with pytest.raises(InvalidInput, match="noise"):
        TrialSetup(object="box", plan=plans[0], noise=Noise(position=0.01))
    with pytest.raises(InvalidInput, match="not a preset"):
        evaluate("box", None, "quick", plan=plans[0])
    with pytest.raises(InvalidInput, match="inside the hand in the plan's pregrasp"):  # the box pushed into the palm
        evaluate("box", None, np.array([[0.0, 0.0, -0.03, 0.0]]), plan=plans[0])
    with pytest.raises(InvalidInput, match="unknown arm"):
        planned.run_planned("box", plans, ["open-loop", "blindfolded"])
    with pytest.raises(InvalidInput, match="'object' experience"):
        planned.run_planned("box", plans, ["blend"])


def test_the_plan_is_part_of_the_trials_key(box_plans):
    _, plans = box_plans
    poses = np.zeros((1, 4))
    keys = {TrialSetup(object="box", plan=p).key(poses, 0) for p in plans}
    assert len(keys) == 2 and TrialSetup(object="box").key(poses, 0) not in keys


def test_a_plan_runs_every_arm_through_the_one_trial_loop(box_plans):
    postures, plans = box_plans
    experiences = {"object": PostureDatabase(postures.postures),
                   "scrambled": PostureDatabase(scrambled(postures.postures))}
    result = run_plan(plans[0], planned.get_object("box"), ("open-loop", "approach-recall"), experiences,
                      np.zeros((1, 4)))
    assert result.start.tolist() == [1]  # from the pregrasp
    assert result.held("open-loop").tolist() == [True]  # a verified grasp, replayed where it was verified, holds
    assert set(result.trials) == {"open-loop", "approach-recall"}


def test_the_settled_squeeze_presses_nothing_until_every_finger_settles_then_ramps():
    params = replace(ControllerParams(recall="base"), squeeze_time=0.2, squeeze=0.3)
    controller = BatchController(1, params=params)
    joints = np.tile(open_posture(), (1, 1))
    forces = np.zeros((1, len(SEGMENTS)))
    forces[0, SEGMENTS.index("ffdistal")] = 1.0
    for _ in range(20):  # phase A, then the first finger touches while the others close
        targets = controller.step(joints, forces)
    ff = np.array([j.startswith("FF") for j in FINGER_JOINTS])
    assert controller.state.held[0, 0] and controller.state.squeezing[0] == 0.0
    assert np.allclose(targets[0, ff], controller.state.held_posture[0, ff])  # held where it touched, no press
    every = np.zeros((1, len(SEGMENTS)))
    every[0, [SEGMENTS.index(s) for s in ("ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal")]] = 1.0
    levels = []
    for _ in range(15):
        controller.step(joints, every)
        levels.append(controller.state.squeezing[0])
    assert np.all(np.diff(levels) >= 0) and levels[-1] == 1.0 and levels[0] < 1.0
    assert SETTLED_BLEND.squeeze_time > 0 and SETTLED_BLEND.recall.name == "base"


def test_a_fading_release_hands_the_supports_load_to_the_grasp_gradually(box_plans):
    """`JudgingRules.release_seconds`: the support's spring weakens to nothing over that time, the hand acting on,
    before the grasp is recorded; the planned benchmark's protocol fades it, ours lets go at once."""
    from graspmanifold.judging.protocols import HOLD_TEST, HOLD_TEST_FADED, get_protocol

    assert get_protocol("hold-test-faded") is HOLD_TEST_FADED and HOLD_TEST_FADED.rules.release_seconds > 0
    assert HOLD_TEST.rules.release_seconds == 0.0 and planned.PLANNED_PROTOCOL is HOLD_TEST_FADED
    _, plans = box_plans
    stiffness = []

    def observe(worlds):
        scene = worlds.scenes[0]
        stiffness.append(float(scene.model.jnt_stiffness[scene.model.joint("object_free").id]))

    for protocol in (HOLD_TEST, HOLD_TEST_FADED):
        stiffness.clear()
        setup = TrialSetup(object="box", plan=plans[0], controller=OpenLoop(plans[0]), method="o", protocol=protocol)
        run_trials(setup, np.zeros((1, 4)), [np.random.default_rng(0)], observer=observe)
        steps = np.diff(stiffness)
        if protocol is HOLD_TEST:
            assert np.count_nonzero(steps) == 1 and steps[steps != 0][0] == -stiffness[0]  # let go at once
        else:
            falling = steps[steps != 0]
            assert len(falling) == 16 and np.allclose(falling, -stiffness[0] / 16)  # 15 periods weaker each, then off
            assert np.isclose(stiffness[-1], 0.0)


def test_the_null_experience_keeps_every_joints_values_and_no_posture():
    rng = np.random.default_rng(0)
    postures = rng.normal(size=(40, 22))
    null = scrambled(postures, seed=1)
    assert np.array_equal(np.sort(null, axis=0), np.sort(postures, axis=0))  # each column a permutation of its own
    assert not any(np.array_equal(row, p) for row in null for p in postures)
    assert np.array_equal(null, scrambled(postures, seed=1)) and not np.array_equal(null, scrambled(postures, seed=2))
    with pytest.raises(InvalidInput, match="postures"):
        scrambled(np.zeros((0, 22)))


def test_a_bounded_grip_force_grips_the_real_object_less_than_a_high_one(box_plans):
    """The grip regulation in the physics: a perfect recall of a box plan, its press regulated to a low and to a
    high total grip force; over the later half of each trial (the grasp's end and the hold test) the low one's fingers
    push less (the mean of the summed segment forces)."""
    _, plans = box_plans
    sensed = {}
    for force in (3.0, 200.0):
        arm = planned.Arm(f"grip{force:g}", "approach", "plan", replace(APPROACH, grip_force=force, grip_press=0.6))
        setup = arm_setup(arm, planned.get_object("box"), plans[0], {})
        totals = []
        run_trials(setup, np.zeros((1, 4)), [np.random.default_rng(0)],
                   observer=lambda worlds: totals.append(worlds.segment_forces(np.array([0]))[0].sum()))
        sensed[force] = np.array(totals)
    low, high = (sensed[f][len(sensed[f]) // 2:].mean() for f in (3.0, 200.0))  # the later half of each trial
    assert low < 0.5 * high  # measured: 3.1 N against 24 N
