"""The four-phase grasp controller and the evaluation over a grid."""

from dataclasses import replace

import numpy as np
from goldens import assert_matches_golden, blend_golden_results
import pytest

import graspmanifold as gm
from graspmanifold.control.controller import BLEND, BatchController
from graspmanifold.sim.hand import PHYSICS_TIMESTEP
from graspmanifold.trials.grid import palm_pose_for


@pytest.fixture(scope="module")
def experience():
    candidates = gm.generate_postures("cylinder", 60, seed=0, params=gm.GeneratorParams(job_size=15, verify=False))
    postures = gm.verify_postures(candidates, "cylinder").postures  # those of the 60 that hold
    return {"database": gm.PostureDatabase(postures), "som": gm.SOM(6, 6, 22, seed=0).fit(postures, epochs=20)}


def run_until_touch(obj_pose, experience, cycles=40, params=None):
    """Targets the controller sends, cycle by cycle, until anything touches the object."""
    obj = gm.get_object("cylinder")
    scene = gm.Scene(obj, free_object=True)
    scene.set_object_support(2000.0, 30.0)
    controller = gm.GraspController(experience, params)
    scene.set_hand_pose(*palm_pose_for(obj, obj_pose))
    scene.set_posture(controller.initial)
    targets = []
    for _ in range(cycles):
        reading = scene.tactile()
        if reading.segments:
            break
        targets.append(controller.step(scene.posture(), reading.segment_forces))
        scene.set_target(targets[-1])
        scene.run(controller.params.control_period)
    return targets


@pytest.mark.parametrize("kind", ["none", "database", "som"])
@pytest.mark.parametrize("params", [gm.ControllerParams(), BLEND], ids=["target", "blend"])
def test_actions_do_not_depend_on_the_object_until_it_is_touched(experience, kind, params):
    exp = None if kind == "none" else experience[kind]
    near = run_until_touch(np.array([0.0, 0.0, 0.01, 0.0]), exp, params=params)
    far = run_until_touch(np.array([0.0, 0.0, 0.3, 0.0]), exp, params=params)  # 30 cm away: never touched
    assert len(near) >= 10 and len(far) == 40
    np.testing.assert_array_equal(np.array(near), np.array(far[: len(near)]))


def test_controller_reads_only_joints_and_forces(experience):
    controller = gm.GraspController(experience["som"])
    forces = np.zeros(len(gm.SEGMENTS))
    first = controller.step(gm.open_posture(), forces)
    assert first.shape == (22,) and controller.phase == "A"
    with pytest.raises(ValueError, match="shape"):
        controller.step(np.zeros(21), forces)
    with pytest.raises(ValueError, match="segment_forces"):
        controller.step(gm.open_posture(), np.zeros(3))
    with pytest.raises(ValueError, match="segment_forces"):
        controller.step(gm.open_posture(), np.full(len(gm.SEGMENTS), np.nan))


def test_phases_follow_the_contacts(experience):
    params = gm.ControllerParams(preshape_time=0.04, max_match_distance=np.inf)
    controller = gm.GraspController(experience["database"], params)
    forces = np.zeros(len(gm.SEGMENTS))
    controller.step(gm.open_posture(), forces)
    assert controller.phase == "A"
    controller.step(gm.open_posture(), forces)
    controller.step(gm.open_posture(), forces)
    assert controller.phase == "B"
    forces[gm.SEGMENTS.index("ffdistal")] = 1.0
    target = controller.step(gm.open_posture(), forces)
    assert controller.phase == "C" and controller.matches >= 2
    assert gm.within_limits(target)
    for _ in range(300):
        controller.step(gm.open_posture(), forces)
    assert controller.done and controller.time_to_grasp <= params.timeout + 1e-9


def test_matches_far_from_the_sensed_joints_are_not_trusted(experience):
    """With a match-confidence gate, a best match farther than it from the sensed joints is ignored."""
    forces = np.zeros(len(gm.SEGMENTS))
    database = experience["database"]
    near = database.postures[0]
    counts = {}
    for gate in (1e-6, np.inf):
        for sensed_name, sensed in (("open", gm.open_posture()), ("near", near)):
            controller = gm.GraspController(database, gm.ControllerParams(preshape_time=0.0, max_match_distance=gate))
            for _ in range(3):
                controller.step(sensed, forces)
            counts[gate, sensed_name] = controller.matches
    assert counts[np.inf, "open"] > 0 and counts[np.inf, "near"] > 0
    assert counts[1e-6, "open"] == 0  # the open hand is far from every experienced grasp
    assert counts[1e-6, "near"] > 0   # an experienced posture matches itself exactly


def _thumb_targets(controller, joints, forces, cycles):
    """The thumb targets over `cycles` control cycles with the sensed joints and forces held fixed."""
    thumb = [i for i, j in enumerate(gm.FINGER_JOINTS) if j.startswith("TH")]
    return np.array([controller.step(joints, forces)[thumb] for _ in range(cycles)])


def test_phase_b_target_changes_with_the_hand_posture_while_it_closes(experience):
    """Phase B re-matches the whole sensed posture every cycle: other joints sensed, another target."""
    forces = np.zeros(len(gm.SEGMENTS))
    params = gm.ControllerParams(preshape_time=0.0, max_match_distance=np.inf)
    rng = np.random.default_rng(0)
    postures = experience["database"].postures
    for kind in ("database", "som"):
        a, b = gm.GraspController(experience[kind], params), gm.GraspController(experience[kind], params)
        diverged = False
        for cycle in range(10):
            first = postures[rng.integers(len(postures))]
            second = postures[rng.integers(len(postures))]
            ta, tb = a.step(first, forces), b.step(second, forces)
            assert a.phase == "B" and a.matches == cycle + 1  # a match every cycle
            diverged |= not np.allclose(ta, tb)
        assert diverged
    # the plain heuristic's closing does not depend on the sensed posture in B
    a, b = gm.GraspController(None, params), gm.GraspController(None, params)
    for _ in range(5):
        np.testing.assert_array_equal(a.step(postures[0], forces), b.step(postures[1], forces))


def test_a_free_finger_never_waits_at_a_reset_closure(experience):
    """The blend: after the first contact a free finger keeps closing every cycle, even when it cannot move."""
    params = replace(BLEND, preshape_time=0.0)
    controller = gm.GraspController(experience["database"], params)
    forces = np.zeros(len(gm.SEGMENTS))
    for _ in range(10):  # phase B
        controller.step(gm.open_posture(), forces)
    forces[gm.SEGMENTS.index("ffdistal")] = 1.0  # the index finger touches; the thumb is blocked where it is
    targets = _thumb_targets(controller, gm.open_posture(), forces, 60)
    closed = gm.closed_posture()[-5:]
    distance = np.linalg.norm(targets - closed, axis=1)
    moving = distance > 1e-9
    assert np.all(np.diff(distance)[moving[1:]] < 0)  # closer to the closed thumb every cycle until there
    assert distance[-1] < 1e-6


def test_a_finger_that_loses_its_contact_closes_on_from_where_it_held(experience):
    params = replace(BLEND, preshape_time=0.0)
    controller = gm.GraspController(experience["som"], params)
    forces = np.zeros(len(gm.SEGMENTS))
    held = gm.open_posture()
    held[-5:] = [0.3, 1.0, 0.1, 0.3, 0.5]
    forces[gm.SEGMENTS.index("ffdistal")] = forces[gm.SEGMENTS.index("thdistal")] = 1.0
    pressed = _thumb_targets(controller, held, forces, 3)[-1]
    forces[gm.SEGMENTS.index("thdistal")] = 0.0
    targets = _thumb_targets(controller, held, forces, 40)
    released = targets[round(params.release_time / params.control_period) + 1:]
    closed = gm.closed_posture()[-5:]
    # no jump back to a matched posture: the first released target is next to where the thumb held
    # (within the squeeze it pressed with), and from there it closes on towards the closed thumb
    assert np.linalg.norm(pressed - held[-5:]) > 0.1
    assert np.linalg.norm(released[0] - held[-5:]) < params.squeeze
    distance = np.linalg.norm(released - closed, axis=1)
    assert np.all(np.diff(distance[2:]) <= 1e-12) and distance[-1] < 0.5 * distance[0]


@pytest.mark.parametrize("field, value", [("control_period", 0.0), ("control_period", -0.02),
                                          ("closing_rate", -1.0), ("timeout", float("nan")),
                                          ("squeeze", -0.1), ("steered_fingers", ("ff", "toe")),
                                          ("max_match_distance", 0.0), ("recall", "memory"),
                                          # not a whole number of 2 ms physics steps: the clocks would drift apart
                                          # (0.0005 once ran 24.8 s of physics for 6.2 s of controller time)
                                          ("control_period", 0.0005), ("control_period", 0.003),
                                          ("control_period", 1e-9), ("control_period", True),
                                          ("grip_force", 0.0), ("grip_force", float("nan")), ("grip_force", True),
                                          ("grip_gain", 0.0), ("grip_press", 1.5), ("grip_press", -0.1)])
def test_bad_controller_params_raise(field, value):
    with pytest.raises(ValueError, match=field):
        gm.ControllerParams(**{field: value})
    with pytest.raises(ValueError, match=r"BlendRecall\(restart_closure\) needs steered_joints='all'"):
        gm.ControllerParams(recall=gm.BlendRecall(restart_closure=True), steered_joints="spread")


@pytest.mark.parametrize("rule, field, value", [(gm.BlendRecall, "restart_closure", 1), (gm.BlendRecall, "reach", -0.01),
                                                (gm.BlendRecall, "reach_speed", 0.0), (gm.TargetRecall, "tolerance", 0.0),
                                                (gm.TargetRecall, "closes_only", 1)])
def test_a_recall_rule_refuses_a_bad_setting_and_cannot_hold_another_rules(rule, field, value):
    """A rule checks its own settings; a setting of the other rule cannot be written at all (the blend's reach on the
    paper's reading, where the recalled posture is already the fingers' target)."""
    with pytest.raises(ValueError, match=f"{rule.__name__}.{field}"):
        rule(**{field: value})
    with pytest.raises(TypeError):
        gm.TargetRecall(reach=0.02)
    with pytest.raises(TypeError):
        gm.BlendRecall(closes_only=True)


def test_the_physics_timestep_is_the_models():
    scene = gm.Scene("cylinder")
    assert scene.model.opt.timestep == PHYSICS_TIMESTEP
    assert gm.ControllerParams(control_period=0.004).control_period == 0.004


def test_a_recall_with_reach_moves_the_palm_to_where_the_recalled_grasp_puts_the_touching_segment():
    """With reach, the first trusted recall after a contact moves the palm (at reach_speed, at most reach
    far) by the difference between where the touching segment is and where the recalled grasp puts it,
    and every finger, the touching one too, follows the recall meanwhile."""
    from graspmanifold.sim.hand import SegmentKinematics

    recalled = gm.closed_posture() * 0.5
    sensed = recalled.copy()
    sensed[:4] += (0.0, -0.3, -0.2, -0.2)  # the index finger touches less flexed than in the recalled grasp
    kinematics = SegmentKinematics()
    index_tip = gm.SEGMENTS.index("ffdistal")
    expected = kinematics.positions(sensed)[index_tip] - kinematics.positions(recalled)[index_tip]
    assert 0.01 < np.linalg.norm(expected) < 0.05
    forces = np.zeros(len(gm.SEGMENTS))
    forces[index_tip] = 1.0
    for reach, speed in ((0.05, 0.1), (0.01, 0.1)):
        params = gm.ControllerParams(recall=gm.BlendRecall(reach=reach, reach_speed=speed), max_match_distance=np.inf)
        controller = gm.GraspController(gm.PostureDatabase(recalled[None]), params)
        offsets, reaching = [], []
        for _ in range(60):
            controller.step(sensed, forces)
            offsets.append(controller.palm_offset.copy())
            reaching.append(controller.reaching)
            if controller.reaching:  # while the palm is on its way nothing is held
                assert not controller.holding
        assert sum(reaching) >= 3 and not reaching[-1]
        steps = np.linalg.norm(np.diff(np.array(offsets), axis=0), axis=1)
        assert steps.max() <= speed * params.control_period + 1e-12
        goal = expected if np.linalg.norm(expected) <= reach else expected * reach / np.linalg.norm(expected)
        np.testing.assert_allclose(offsets[-1], goal, atol=1e-12)
        assert "ff" in controller.holding  # once arrived, the touching finger holds again
    assert np.all(gm.GraspController(None).palm_offset == 0)


def test_the_first_recall_after_a_contact_restarts_the_free_fingers_closure():
    """With restart_closure the free fingers go to the recalled grasp first: right after the first
    contact their target lies at the recalled posture, not most of the way to the closed hand."""
    recalled = gm.closed_posture() * 0.5
    experience = gm.PostureDatabase(recalled[None])
    trust = dict(max_match_distance=np.inf)
    forces = np.zeros(len(gm.SEGMENTS))
    controllers = {restart: gm.GraspController(experience, gm.ControllerParams(recall=gm.BlendRecall(restart_closure=restart),
                                                                               experience_preshape=False, **trust))
                   for restart in (False, True)}
    targets = {}
    for restart, controller in controllers.items():
        for cycle in range(60):
            if cycle == 40:  # the index fingertip touches
                forces[gm.SEGMENTS.index("ffdistal")] = 1.0
            targets[restart] = controller.step(gm.open_posture() if cycle < 40 else recalled, forces)
        forces[:] = 0.0
    thumb = [gm.FINGER_JOINTS.index(j) for j in ("THJ5", "THJ4", "THJ3", "THJ2", "THJ1")]
    far = np.linalg.norm(targets[False][thumb] - recalled[thumb])
    near = np.linalg.norm(targets[True][thumb] - recalled[thumb])
    assert near < 0.5 * far, (near, far)
    assert controllers[True].batch.state.closure_restarted[0] and not controllers[False].batch.state.closure_restarted[0]


def test_switches_turn_experience_off(experience):
    """With B's preshape and C's steering off, the experience controller acts as the plain heuristic."""
    forces = np.zeros(len(gm.SEGMENTS))
    off = gm.ControllerParams(experience_preshape=False, experience_steering=False)
    a, b = gm.GraspController(experience["som"], off), gm.GraspController(None)
    for cycle in range(40):
        if cycle == 25:
            forces[gm.SEGMENTS.index("ffdistal")] = 1.0
        np.testing.assert_allclose(a.step(gm.open_posture(), forces), b.step(gm.open_posture(), forces))
    assert a.matches == 0
    only_thumb = gm.GraspController(experience["som"], gm.ControllerParams(steered_fingers=("th",)))
    plain = gm.GraspController(None)
    for _ in range(30):
        t, p = only_thumb.step(gm.open_posture(), forces), plain.step(gm.open_posture(), forces)
    np.testing.assert_allclose(t[:17], p[:17])  # the other fingers close as the heuristic does


def test_bad_experience_is_rejected():
    with pytest.raises(ValueError, match="experience must be None"):
        gm.GraspController(np.zeros((5, 22)))
    with pytest.raises(ValueError, match="22-joint"):
        gm.GraspController(gm.SOM(3, 3, 10).fit(np.random.default_rng(0).normal(size=(20, 10)), epochs=1))
    with pytest.raises(ValueError, match="experience must be None"):
        gm.evaluate("cylinder", "som")

    class HalfDone:  # a user's experience that forgot the batch methods
        dim = 22
        references = np.zeros((3, 22))

        def best_match(self, x, mask=None):
            return 0

        def complete(self, x, mask=None):
            return self.references[0]

    with pytest.raises(ValueError, match=r"Experience \(the protocol.*HalfDone lacks best_match_batch, complete_batch$"):
        gm.GraspController(HalfDone())


def test_the_error_lists_every_member_of_the_experience_protocol():
    from graspmanifold.manifold import experience
    assert experience._PROTOCOL_MEMBERS == ("dim", "references", "best_match", "best_match_batch", "complete",
                                            "complete_batch")


def test_a_centred_cylinder_is_grasped_and_held():
    result = gm.evaluate("cylinder", None, grid=np.array([[0.0, 0.0, 0.01, 0.0]]), margin=True)
    trial = result.trials[0]
    assert trial.force_closure and trial.hold and trial.margin > 0
    assert trial.touching[[gm.SEGMENTS.index(s) for s in gm.DISTAL_SEGMENTS]].sum() >= 4
    assert result.summary["trials"] == 1 and result.summary["force_closure_rate"] == 1.0


def test_evaluation_is_deterministic_and_files_round_trip(experience, tmp_path):
    grid = np.array([[0.0, 0.0, 0.01, 0.0], [0.01, -0.01, 0.02, -0.3]])
    noise = gm.Noise(position=0.003, yaw=0.05, joints=0.01)
    a = gm.evaluate("cylinder", experience["som"], grid=grid, seed=5, noise=noise)
    b = gm.evaluate("cylinder", experience["som"], grid=grid, seed=5, noise=noise, workers=2)
    assert [t.epsilon for t in a.trials] == [t.epsilon for t in b.trials]
    assert a.summary == b.summary
    loaded = gm.EvaluationResult.load(a.save(tmp_path / "trials.npz"))
    assert loaded.summary == a.summary and loaded.noise == noise
    assert loaded.object is gm.get_object("cylinder") is a.object  # the object, not a plain dict
    slippery = gm.make_object("cylinder", friction=0.3)
    variant = gm.EvaluationResult(slippery, "none", "custom", 0, a.trials[:1])
    assert gm.EvaluationResult.load(variant.save(tmp_path / "variant.npz")).object == slippery
    assert a.successful_postures().shape[1] == 22
    # the per-cycle best-match winners travel with the trials: one SOM node per match used
    assert sum(t.matches for t in a.trials) > 0
    for trial, again in zip(a.trials, loaded.trials):
        assert len(trial.winners) == trial.matches and np.array_equal(trial.winners, again.winners)
        assert ((0 <= trial.winners) & (trial.winners < experience["som"].n_nodes)).all()
    arrays = dict(np.load(tmp_path / "trials.npz"))
    np.savez(tmp_path / "corrupt.npz", **{**arrays, "winners": arrays["winners"][:-1]})
    with pytest.raises(ValueError, match="corrupt.npz: its .* winners do not add up"):
        gm.EvaluationResult.load(tmp_path / "corrupt.npz")


@pytest.mark.parametrize("call, message", [
    (lambda: gm.evaluate("cylinder", None, grid=np.zeros((0, 4))), "grid"),
    (lambda: gm.evaluate("cylinder", None, grid="huge"), "unknown grid"),
    (lambda: gm.evaluate("cylinder", None, grid=[["a", "b", "c", "d"]]), "an \\(n, 4\\) array of numbers"),
    (lambda: gm.evaluate("cylinder", None, grid=np.array([[0, 0, np.nan, 0]])), "finite"),
    (lambda: gm.Noise(position=float("nan")), "noise position"),
    (lambda: gm.Noise(joints=-0.1), "noise joints"),
    (lambda: gm.evaluate("cylinder", None, workers=0), "workers"),
    (lambda: gm.evaluate("cylinder", None, seed=-1), "seed must be a whole number >= 0"),
    (lambda: gm.generate_postures("cylinder", 4, seed=-1), "seed must be a whole number >= 0"),
    (lambda: gm.Noise("a"), "noise position must be a standard deviation"),  # was a ufunc TypeError
    (lambda: gm.Noise(joints=1e9), "noise joints must be a standard deviation 0 ... 0.5"),
    (lambda: gm.evaluate("box", None, np.array([0.0, 0.0, 5.0, 0.0])), "beyond the hand's reach"),
    (lambda: gm.facing_pose("box", clearance=-0.01), "a negative one puts the palm inside"),
    (lambda: gm.GeneratorParams(verify_hold_seconds=0), "verify_hold_seconds must be > 0"),
    # an object no pose of the grid can hold used to run 0 trials and write NaN into summary.json
    (lambda: gm.evaluate(gm.make_object("box", size=(0.3, 0.3, 0.3)), None, "quick"), "no pose of the 'quick' grid"),
])
def test_bad_evaluation_input_raises(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_grid_presets_cover_enough_trials():
    for name in ("box", "cylinder", "sphere"):
        assert len(gm.grid_preset("quick", name)) >= 30
        assert len(gm.grid_preset("paper", name)) >= 200
        far = gm.grid_preset("far", name)
        assert len(far) >= 40 and far[:, 2].min() >= 0.03  # 3-5 cm out of the palm
        assert len(gm.grid_preset("hard", name)) >= 40


def test_an_object_on_a_table_is_grasped_and_lifted_off():
    """With a table the object stands on it under gravity while the hand closes; judging lifts it off."""
    grid = gm.grid_preset("quick", "cylinder", table=True)
    assert 0 < len(grid) < len(gm.grid_preset("quick", "cylinder"))  # the table is in the way of some poses
    result = gm.evaluate("cylinder", None, grid=grid[:2], table=True, margin=True)
    assert all(t.hold and t.margin > 0 for t in result.trials)
    scene = gm.Scene("cylinder", free_object=True, gravity=True, table=True)
    scene.run(0.5)
    assert abs(scene.object_pose()[0][2]) < 1e-3  # it stands on the table
    scene.set_table(False)
    scene.run(0.2)
    assert scene.object_pose()[0][2] < -0.1  # and falls once the table is taken away
    with pytest.raises(ValueError, match="table=True"):
        gm.Scene("cylinder", free_object=True).set_table(False)
    assert not gm.reachable("sphere", gm.grid_preset("quick", "sphere"), table=True).any()


def test_trials_start_with_the_open_hand_clear_of_the_object():
    from graspmanifold.trials.grid import START_CLEARANCE, open_hand_clearance
    for name in ("box", "cylinder", "sphere"):
        for preset in ("quick", "paper"):
            assert np.all(open_hand_clearance(name, gm.grid_preset(preset, name)) >= START_CLEARANCE)
    # a long object turned so that its end comes down to the thumb sits deep inside the open thumb
    inside = np.array([[0.0, 0.0, 0.01, 0.0], [-0.015, 0.0, 0.01, 0.5]])
    assert open_hand_clearance("cylinder", inside)[1] < -0.005
    assert gm.reachable("cylinder", inside).tolist() == [True, False]
    with pytest.raises(ValueError, match=r"grid rows \[1\] put the object inside"):
        gm.evaluate("cylinder", None, grid=inside)


def test_resumed_learning_reports_smoothness_and_leaves_the_original(experience):
    som = experience["som"]
    before = som.weights.copy()
    rng = np.random.default_rng(0)
    new = gm.clip_posture(som.weights.reshape(-1, 22)[0]) + rng.normal(0, 0.05, (40, 22))
    resumed, report = gm.resume_learning(som, new)
    assert np.array_equal(som.weights, before)
    assert len(resumed.history) == len(som.history) + 1 and resumed.history[-1]["epochs"] == 10
    assert resumed.quantization_error(new) < som.quantization_error(new)
    for key in ("distance_cv", "distance_max_deg", "unsupported_by_evaluation"):
        assert key in report["before"] and key in report["after"]


def test_a_constant_preshape_replaces_phase_b_matching(experience):
    """`preshape` is the phase-B base; phase C still steers with the experience."""
    preshape = experience["database"].postures[3]
    forces = np.zeros(len(gm.SEGMENTS))
    params = gm.ControllerParams(preshape_time=0.0)
    fixed = gm.GraspController(None, params, preshape=preshape)
    recalled = gm.GraspController(gm.PostureDatabase(preshape[None]),
                                  gm.ControllerParams(preshape_time=0.0, max_match_distance=np.inf))
    for _ in range(10):
        np.testing.assert_allclose(fixed.step(gm.open_posture(), forces), recalled.step(gm.open_posture(), forces))
    assert fixed.matches == 0
    steered = gm.GraspController(experience["som"], params, preshape=preshape)
    for _ in range(10):
        steered.step(gm.open_posture(), forces)
    assert steered.matches == 0
    forces[gm.SEGMENTS.index("ffdistal")] = 1.0
    steered.step(experience["database"].postures[0], forces)
    assert steered.matches == 1  # the PCP is matched once something touches
    with pytest.raises(ValueError, match="preshape"):
        gm.GraspController(None, preshape=np.full(22, 5.0))


def test_coverage_sees_placements_up_to_the_objects_symmetry():
    from graspmanifold.base.poses import compose
    from graspmanifold.trials.grid import coverage

    grid = np.array([[0.0, 0.0, 0.01, 0.0], [0.01, -0.01, 0.02, 0.3]])
    turn = np.array([np.cos(0.5), 0.0, 0.0, np.sin(0.5)])  # 1 rad about the cylinder's axis
    experienced = [np.concatenate(compose(np.zeros(3), turn, *palm_pose_for(gm.get_object("cylinder"), g)))
                   for g in grid]
    np.testing.assert_allclose(coverage("cylinder", grid, np.array(experienced)), 0.0, atol=1e-6)
    shifted = coverage("cylinder", grid + [0.0, 0.0, 0.005, 0.0], np.array(experienced))
    np.testing.assert_allclose(shifted[:, 0], 0.005, atol=1e-6)
    with pytest.raises(ValueError, match="hand_poses"):
        coverage("cylinder", grid, np.zeros((0, 7)))


def test_a_pose_is_covered_where_a_verified_grasp_holds_the_object_within_a_centimetre_and_its_axis_near():
    """`grid.covered`: the centre within `COVERED_WITHIN` of an experienced one, seen from the palm, and the long axis
    within `COVERED_ANGLE`; turned a quarter about the palm normal, a cylinder at the same centre is not covered."""
    from graspmanifold.trials.grid import COVERED_WITHIN, covered

    obj = gm.get_object("cylinder")
    grid = np.array([[0.0, 0.0, 0.01, 0.0]])
    experienced = np.concatenate(palm_pose_for(obj, grid[0]))[None]
    moved = grid + [[0.0, 0.0, 0.0, 0.0], [0.009, 0.0, 0.0, 0.0], [0.0, 0.011, 0.0, 0.0], [0.0, 0.0, 0.0, np.pi / 2]]
    assert covered(obj, moved, experienced).tolist() == [True, True, False, False]
    assert covered(obj, moved, experienced, within=0.02, angle=np.pi).tolist() == [True] * 4
    assert COVERED_WITHIN == 0.01
    for bad in (dict(within=-0.01), dict(angle=float("nan")), dict(within=True)):
        with pytest.raises(ValueError, match=next(iter(bad))):
            covered(obj, grid, experienced, **bad)


def test_one_reachability_rule_for_evaluate_and_record_trial_and_it_says_why():
    """record_trial ran (and called valid) poses that evaluate refused; why a pose was refused was not said;
    a single pose as a 1-D array was refused."""
    inside = (0.0, 0.0, -0.01, 0.0)
    assert "palm is 10.0 mm inside the cylinder" in gm.why_unreachable("cylinder", inside)
    assert "thmiddle" in gm.why_unreachable("cylinder", (0.0, 0.0, 0.01, 0.2))  # a positive yaw meets the thumb
    assert gm.why_unreachable("cylinder", (0.0, 0.0, 0.01, 0.0)) is None
    for call in (lambda: gm.evaluate("cylinder", None, np.array([inside])),
                 lambda: gm.record_trial("cylinder", grid_pose=inside)):
        with pytest.raises(ValueError, match="palm is 10.0 mm inside the cylinder"):
            call()
    one = gm.evaluate("cylinder", None, np.array([0.0, 0.0, 0.01, 0.0]))
    assert len(one.trials) == 1 and one.trials[0].valid
    with pytest.raises(ValueError, match="pose must be four finite numbers"):
        gm.why_unreachable("cylinder", (0.0, 0.0))


def test_the_papers_reading_takes_every_free_finger_to_its_recall_before_it_closes_beyond_it():
    """recall='target' (the default) with a one-posture experience, in a real MuJoCo scene where nothing
    touches: every finger's target moves straight to its part of the recalled posture, and closes on
    towards the closed hand only once the finger's sensed joints are within `TargetRecall.tolerance` of it."""
    from graspmanifold.control.state import FINGER_JOINT_MASKS

    recalled = gm.open_posture() + 0.4 * (gm.closed_posture() - gm.open_posture())
    params = gm.ControllerParams()
    assert params.recall == gm.TargetRecall() and params.max_match_distance == np.inf  # the paper trusts every match
    obj = gm.get_object("cylinder")
    scene = gm.Scene(obj, free_object=True)
    scene.set_object_support(2000.0, 30.0)
    controller = gm.GraspController(gm.PostureDatabase(recalled[None]), params)
    scene.set_hand_pose(*palm_pose_for(obj, np.array([0.0, 0.0, 0.3, 0.0])))  # 30 cm away: nothing touches
    scene.set_posture(controller.initial)
    joints, targets = [], []
    while not controller.done:
        joints.append(scene.posture())
        reading = scene.tactile()
        assert not reading.segments
        targets.append(controller.step(joints[-1], reading.segment_forces))
        scene.set_target(targets[-1])
        scene.run(params.control_period)
    closed = gm.closed_posture()
    for finger, of in zip(gm.FINGERS, FINGER_JOINT_MASKS):
        at = [np.array_equal(t[of], recalled[of]) for t in targets]
        first = at.index(True)  # the target arrives at the recall ...
        leave = next(k for k in range(first, len(at)) if not at[k])  # ... and later leaves it
        way = [np.linalg.norm(t[of] - recalled[of]) for t in targets[: first + 1]]
        assert np.all(np.diff(way) <= 1e-12), finger  # straight there, never away
        assert np.abs(joints[leave][of] - recalled[of]).max() <= params.recall.tolerance, finger
        beyond = [np.linalg.norm(t[of] - closed[of]) for t in targets[leave - 1:]]
        assert np.all(np.diff(beyond) <= 1e-12) and beyond[-1] < 1e-9, finger  # then on to the closed hand
    assert controller.matches == len(targets) - round(params.preshape_time / params.control_period)


def test_a_recall_of_the_closed_hand_closes_as_the_plain_heuristic():
    """The paper's reading with the closed hand as its only recall: the fingers go to the closed hand at
    the heuristic's joint speed, so the trials are the plain heuristic's (real trials, three poses)."""
    from graspmanifold.trials.episode import run_trial
    from graspmanifold.trials.setup import TrialSetup

    closed = gm.PostureDatabase(gm.closed_posture()[None])
    obj = gm.get_object("cylinder")
    for pose in gm.grid_preset("quick", obj)[::10]:
        plain = run_trial(TrialSetup(object=obj), pose, np.random.default_rng(0))
        recalled = run_trial(TrialSetup(object=obj, experience=closed), pose, np.random.default_rng(0))
        assert recalled.matches > 0 and plain.matches == 0
        assert recalled.hold == plain.hold and np.array_equal(recalled.touching, plain.touching)
        assert recalled.time_to_grasp == pytest.approx(plain.time_to_grasp)
        np.testing.assert_allclose(recalled.posture, plain.posture, atol=1e-6)


def test_the_blend_gives_the_trials_of_the_commit_before_the_papers_reading():
    """`BLEND` is the controller every result before the paper's reading came from: its trials, their
    postures, epsilons and per-cycle winners equal those that commit computed (tests/data/blend_trials.npz,
    written by `goldens.blend_golden_results` run on it). Bit for bit only on the processor and MuJoCo that wrote it: MuJoCo
    4.0.1 moves a hold displacement by 1.2e-4 from 4.0.0's on the same processor, and a 1e-12 change of the poses
    flips a database recall whose two nearest postures the sensed joints find about equally near, after which that
    trial closes to another posture (0.085 rad away; `tests/test_last_bits.py`). So what is pinned is what no last
    bit moves: the outcomes exactly, nine in ten of each method's winners, and the measured values of every trial
    whose recalls all equal the golden's to well within what any reading resolves."""
    results = blend_golden_results()
    for name, result in results.items():
        assert_matches_golden(result, name)


def test_the_controller_recalls_what_the_experience_completes():
    """A recall of one's own that blends postures in `complete` was silently ignored: the controller took the
    reference row of the best match. It now recalls the experience's completion."""

    class Blending(gm.PostureDatabase):
        def complete_batch(self, X, masks=None):  # the mean of every reference, whatever the query
            return np.tile(self.references.mean(axis=0), (len(np.atleast_2d(X)), 1))

    references = np.array([gm.closed_posture() * 0.2, gm.closed_posture() * 0.6])
    controller = BatchController(1, Blending(references))
    open_hand = controller.initial[None]
    for _ in range(round(controller.params.preshape_time / controller.control_period) + 1):  # into phase B
        controller.step(open_hand, np.zeros((1, len(gm.SEGMENTS))))
    assert controller.matches[0] > 0
    assert np.allclose(controller.state.recalled_posture[0], gm.closed_posture() * 0.4)  # the blend, not a reference


def test_a_closing_recall_never_sends_a_joint_back_towards_the_open_hand():
    """`CLOSING_RECALL`: the recall of a free finger is kept no more open than its target, joint by joint; the
    literal reading (the default) sends it wherever the recalled posture is, the open hand included."""
    from graspmanifold.control.controller import CLOSING_RECALL, BatchController

    opened, closed = gm.open_posture(), gm.closed_posture()
    half = opened + 0.5 * (closed - opened)
    recalled = opened + np.where(np.arange(len(opened)) % 2 == 0, 0.2, 0.8) * (closed - opened)  # some back, some on
    for params, expected in ((gm.ControllerParams(), recalled),
                             (CLOSING_RECALL, np.where((recalled - half) * np.sign(closed - opened) < 0, half, recalled))):
        controller = BatchController(1, gm.PostureDatabase(recalled[None]), params)
        controller.state.target[0] = half
        controller.params.recall.recall(controller, np.array([0]), np.array([0]), recalled[None], half[None],
                                           np.zeros((1, len(gm.SEGMENTS)), dtype=bool), np.zeros((1, 5), dtype=bool))
        np.testing.assert_allclose(controller.state.recalled_posture[0], expected)
    assert np.any(expected != recalled) and np.all((expected - half) * np.sign(closed - opened) >= 0)


def test_a_traced_controller_logs_every_cycle_and_changes_no_trial():
    """`recall_trace.TracedController` around ours: one log entry per control cycle, the same trials as untraced."""
    from graspmanifold.control.controller import CLOSING_RECALL, BatchController
    from graspmanifold.studies.recall_trace import TracedController
    from graspmanifold.trials.episode import run_trials
    from graspmanifold.trials.setup import TrialSetup

    obj = gm.get_object("cylinder")
    som = gm.SOM(4, 4, 22, seed=0).fit(gm.open_posture() + np.linspace(0.1, 0.9, 30)[:, None]
                                         * (gm.closed_posture() - gm.open_posture()))
    poses = gm.grid_preset("quick", obj)[:2]
    made = []

    def traced(n, hand):
        made.append(TracedController(BatchController(n, som, CLOSING_RECALL, hand=hand)))
        return made[-1]

    plain = run_trials(TrialSetup(object=obj, experience=som, params=CLOSING_RECALL), poses, [np.random.default_rng(i) for i in range(2)])
    logged = run_trials(TrialSetup(object=obj, controller=traced, method="traced"), poses,
                        [np.random.default_rng(i) for i in range(2)])
    assert [t.hold for t in plain] == [t.hold for t in logged]
    assert all(np.array_equal(a.posture, b.posture) for a, b in zip(plain, logged))
    times = [entry[0] for entry in made[0].log]
    assert len(times) > 10 and np.allclose(np.diff(times), CLOSING_RECALL.control_period)
    assert all(entry[3].shape == (2, 5) and entry[2].shape == (2, 22) for entry in made[0].log)


def test_a_recall_rule_of_ones_own_runs_without_a_change_to_the_controller():
    """`RecallRule` is the controller's one place for what a best match does: a rule that ignores every match, the
    recall of our controller's parameters with an experience, grasps as the plain heuristic does (the same trials,
    the matches still counted); the rules named by the parameters are the module's two, and a configuration file
    names one with its settings."""
    from dataclasses import dataclass

    from graspmanifold.base.config_files import apply_table, to_toml
    from graspmanifold.control.recall import BlendRecall, RecallRule, TargetRecall
    from graspmanifold.trials.grid import check_grid

    @dataclass(frozen=True)
    class Ignoring(RecallRule):
        name = "ignoring"

        def preshape(self, c, worlds, postures):
            pass

        def recall(self, c, worlds, winners, match, joints, touching_segments, fingers_touching):
            pass

    database = gm.PostureDatabase(np.array([gm.closed_posture(), gm.open_posture()]))
    poses = check_grid("quick", gm.get_object("cylinder"))[1][::12]
    plain = gm.evaluate("cylinder", None, poses, seed=0, workers=1, progress=False)
    ignoring = gm.evaluate("cylinder", database, poses, seed=0, workers=1, progress=False,
                           params=gm.ControllerParams(recall=Ignoring()))
    assert [t.hold for t in ignoring.trials] == [t.hold for t in plain.trials]
    np.testing.assert_array_equal([t.posture for t in ignoring.trials], [t.posture for t in plain.trials])
    assert sum(t.matches for t in ignoring.trials) > 0 == sum(t.matches for t in plain.trials)
    assert gm.ControllerParams().recall == TargetRecall() and BLEND.recall == BlendRecall()
    assert gm.ControllerParams(recall=BlendRecall(reach=0.03)).recall.moves_palm
    with pytest.raises(ValueError, match="ControllerParams.recall must be a RecallRule"):
        gm.ControllerParams(recall=3)
    reaching = gm.ControllerParams(recall=BlendRecall(reach=0.03), max_match_distance=0.2)
    assert "recall = { \"rule\" = \"base\", \"restart_closure\" = false, \"reach\" = 0.03" in to_toml(reaching)
    assert apply_table(gm.ControllerParams(), {"recall": {"rule": "base", "reach": 0.03}, "max_match_distance": 0.2},
                       "controller") == reaching
    assert apply_table(BLEND, {"recall": "target"}, "controller").recall == TargetRecall()
    with pytest.raises(ValueError, match=r"unknown setting\(s\) \['reach'\] of the recall rule 'target'"):
        apply_table(gm.ControllerParams(), {"recall": {"reach": 0.03}}, "controller")
    old = {"recall": "base", "recall_tolerance": 0.05, "recall_closes_only": False, "restart_closure": True,
           "reach": 0.0, "reach_speed": 0.1, "max_match_distance": 0.2}  # a run.json of the flat settings
    assert apply_table(gm.ControllerParams(), old, "controller") == replace(BLEND, recall=BlendRecall(restart_closure=True))


def test_the_approach_takes_every_finger_to_its_recall_together_then_on_along_the_way_it_came():
    """recall='approach' (`APPROACH`) with a one-posture experience, in a real MuJoCo scene where nothing touches,
    from a start posture short of the recall: every finger's target moves straight to its part of the recall, all
    arriving in the same cycle, and closes on along the way it came (never towards the closed fist) to at most the
    overshoot beyond it."""
    from graspmanifold.control.controller import APPROACH
    from graspmanifold.control.state import FINGER_JOINT_MASKS

    recalled = gm.open_posture() + 0.5 * (gm.closed_posture() - gm.open_posture())
    recalled[gm.FINGER_JOINTS.index("THJ5")] -= 0.3  # the thumb's way is not the fist's
    start = gm.open_posture() + 0.1 * (gm.closed_posture() - gm.open_posture())
    way = recalled - start
    obj = gm.get_object("cylinder")
    scene = gm.Scene(obj, free_object=True)
    scene.set_object_support(2000.0, 30.0)
    controller = gm.GraspController(gm.PostureDatabase(recalled[None]), APPROACH, initial_posture=start)
    scene.set_hand_pose(*palm_pose_for(obj, np.array([0.0, 0.0, 0.3, 0.0])))  # 30 cm away: nothing touches
    scene.set_posture(start)
    targets = []
    while not controller.done:
        reading = scene.tactile()
        assert not reading.segments
        targets.append(controller.step(scene.posture(), reading.segment_forces))
        scene.set_target(targets[-1])
        scene.run(APPROACH.control_period)
    arrivals = []
    for finger, of in zip(gm.FINGERS, FINGER_JOINT_MASKS):
        at = [np.allclose(t[of], recalled[of], atol=1e-12) for t in targets]
        arrivals.append(at.index(True))
        to = [np.linalg.norm(t[of] - recalled[of]) for t in targets[: arrivals[-1] + 1]]
        assert np.all(np.diff(to) <= 1e-12), finger  # straight there, never away
        beyond = np.array([t[of] - recalled[of] for t in targets[arrivals[-1]:]])
        along = beyond @ way[of] / np.linalg.norm(way[of]) ** 2  # in lengths of the way
        np.testing.assert_allclose(beyond, along[:, None] * way[of], atol=1e-9, err_msg=finger)  # on along the way
        assert np.all(np.diff(along) >= -1e-12) and along[-1] <= APPROACH.recall.overshoot + 1e-9, finger
        assert along[-1] > 0.5, finger  # it did close on
    assert max(arrivals) - min(arrivals) <= 1  # together


def test_a_finger_the_heuristic_would_not_move_does_not_stop_the_others_on_their_way_together():
    """A finger whose start is already the closed posture has no closing speed; its way's time was infinite and
    held every finger of the approach where it started."""
    from graspmanifold.control.controller import APPROACH
    from graspmanifold.control.state import FINGER_JOINT_MASKS

    start = gm.open_posture() + 0.1 * (gm.closed_posture() - gm.open_posture())
    first = FINGER_JOINT_MASKS[0]
    start[first] = gm.closed_posture()[first]
    recalled = gm.open_posture() + 0.5 * (gm.closed_posture() - gm.open_posture())
    controller = gm.GraspController(gm.PostureDatabase(recalled[None]), APPROACH, initial_posture=start)
    joints, forces = start.copy(), np.zeros(len(gm.SEGMENTS))
    for _ in range(200):
        with np.errstate(all="raise"):
            joints = controller.step(joints, forces)  # the joints follow their targets exactly: nothing touches
    for finger, of in zip(gm.FINGERS, FINGER_JOINT_MASKS):
        assert np.linalg.norm(joints[of] - start[of]) > 0.1, finger  # every finger left its start


def test_a_touching_finger_presses_on_along_its_way_and_without_a_way_the_approach_is_the_papers_closing():
    """A finger that touches holds where it touched and presses `squeeze` rad (its joints' norm) on along the way it
    came to its recall; with no experience there is no way, and the approach closes and presses exactly as the
    paper's reading with the same squeeze does."""
    from graspmanifold.control.controller import APPROACH
    from graspmanifold.control.state import FINGER_JOINT_MASKS

    start = gm.open_posture()
    recalled = start + 0.3 * (gm.closed_posture() - start)
    touch = np.zeros((1, len(gm.SEGMENTS)))
    touch[0, gm.SEGMENTS.index("ffdistal")] = 1.0
    ff = FINGER_JOINT_MASKS[gm.FINGERS.index("ff")]

    def run(experience, params):
        controller = BatchController(1, experience, params, initial_posture=start)
        joints, out = start[None].copy(), []
        for cycle in range(60):
            out.append(controller.step(joints, touch if cycle >= 30 else np.zeros_like(touch)))
            joints = out[-1]  # the joints follow their targets
        return controller, np.array(out)

    controller, targets = run(gm.PostureDatabase(recalled[None]), APPROACH)
    assert controller.state.held[0, 0]
    way = controller.state.way[0, ff]
    np.testing.assert_allclose(way, (recalled - start)[ff])
    pressed = controller.state.held_posture[0, ff] + APPROACH.squeeze * way / np.linalg.norm(way)
    np.testing.assert_allclose(targets[-1, 0, ff], pressed, atol=1e-12)
    _, plain = run(None, APPROACH)
    _, paper = run(None, replace(gm.ControllerParams(), squeeze=APPROACH.squeeze))
    np.testing.assert_array_equal(plain, paper)


@pytest.mark.parametrize("field, value", [("overshoot", -0.5), ("overshoot", float("nan")), ("together", 1)])
def test_the_approach_refuses_a_bad_setting(field, value):
    with pytest.raises(ValueError, match=f"ApproachRecall.{field}"):
        gm.ApproachRecall(**{field: value})


def test_the_grip_is_regulated_to_the_grip_force_within_its_press_bounds_while_grasping_and_once_done():
    """A holding finger's press follows the total sensed force, while the grasp goes on and once it is done: less
    while it is above `grip_force`, more while below, never outside [0, `grip_press`] rad; along the approach's way,
    so the press targets stay on it. Without a grip force (inf) the press is the squeeze, and a done grasp keeps its
    targets whatever it senses."""
    from graspmanifold.control.controller import APPROACH
    from graspmanifold.control.state import FINGER_JOINT_MASKS

    start = gm.open_posture()
    recalled = start + 0.3 * (gm.closed_posture() - start)
    tips = np.zeros((1, len(gm.SEGMENTS)))
    tips[0, [gm.SEGMENTS.index(s) for s in ("ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal")]] = 1.0

    def grasped(params):
        controller = BatchController(1, gm.PostureDatabase(recalled[None]), params, initial_posture=start)
        joints = start[None].copy()
        for cycle in range(200):
            joints = controller.step(joints, tips * (cycle >= 30))
            if controller.done[0]:
                return controller, joints
        raise AssertionError("the grasp never finished")

    controller, done_targets = grasped(replace(APPROACH, grip_force=10.0, grip_gain=2.0))
    ff = FINGER_JOINT_MASKS[gm.FINGERS.index("ff")]
    held = controller.state.held_posture[0, ff]
    way = controller.state.way[0, ff] / np.linalg.norm(controller.state.way[0, ff])
    press = [controller.state.grip[0]]
    assert APPROACH.squeeze < press[0] <= APPROACH.grip_press  # 5 N sensed while grasping, half the grip force
    for _ in range(20):  # 40 N sensed, four times the grip force: the press eases off, down to 0
        targets = controller.step(done_targets, tips * 8.0)
        press.append(controller.state.grip[0])
    assert np.all(np.diff(press) <= 0) and press[-1] == 0.0
    np.testing.assert_allclose(targets[0, ff], held, atol=1e-12)  # back where the finger touched
    for _ in range(40):  # 5 N sensed, half the grip force: the press grows, up to grip_press
        targets = controller.step(done_targets, tips)
        press.append(controller.state.grip[0])
    assert np.all(np.diff(press[21:]) >= 0) and press[-1] == APPROACH.grip_press
    np.testing.assert_allclose(targets[0, ff], held + APPROACH.grip_press * way, atol=1e-12)
    assert controller.done[0]

    controller, done_targets = grasped(APPROACH)
    assert controller.state.grip[0] == APPROACH.squeeze
    for forces in (tips * 8.0, tips * 0.0):
        np.testing.assert_array_equal(controller.step(done_targets, forces), done_targets)
