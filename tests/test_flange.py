"""The palm's flange (issue 66): a hand on an arm's flange is placed as before, moves no faster and pushes no harder
than its limits, stops at its travel, and holds still when locked; every hand model hangs on it."""

import mujoco
import numpy as np
import pytest

from graspmanifold import InvalidInput
from graspmanifold.base.poses import compose, invert
from graspmanifold.sim.flange import FLANGE_JOINTS, FlangeLimits
from graspmanifold.sim.scene import Scene, facing_pose

#: timesteps of half a second
HALF_SECOND = 250
#: s, the controller's control period
PERIOD = 0.02


def flanged(obj: str = "box", hand: str = "shadow-primitives", **limits) -> Scene:
    scene = Scene(obj, hand=hand, flange=FlangeLimits(**limits), gravity=True)
    scene.set_hand_pose(*facing_pose(scene.object, clearance=0.03))
    return scene


def moved(scene: Scene, start: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The palm's pose now in the palm's frame at `start`."""
    return compose(*invert(*start), *scene.hand_pose())


def steer(scene: Scene, target, periods: int, period: float = PERIOD) -> None:
    """Steer the flange towards a target every control period for `periods` periods."""
    for _ in range(periods):
        scene.steer_flange(target, period)
        scene.step(round(period / scene.model.opt.timestep))


def test_a_flanged_hand_is_placed_where_a_mounted_one_is_and_holds_still_under_gravity():
    mounted, scene = Scene("box"), flanged()
    mounted.set_hand_pose(*facing_pose(mounted.object, clearance=0.03))
    for a, b in zip(mounted.hand_pose(), scene.hand_pose()):
        assert np.allclose(a, b, atol=1e-9)
    start = scene.hand_pose()
    scene.step(HALF_SECOND)  # gravity on: the arm carries the hand's weight
    assert np.linalg.norm(moved(scene, start)[0]) < 1e-4 and np.abs(scene.flange()).max() < 1e-4
    assert "flange" in repr(scene)
    # placed again after moving, the flange is home
    steer(scene, [0.1, 0, 0, 0, 0, 0], 10)
    scene.set_hand_pose(*facing_pose(scene.object, clearance=0.03))
    assert np.array_equal(scene.flange(), np.zeros(6)) and np.array_equal(scene.flange_set_point(), np.zeros(6))
    assert np.allclose(scene.hand_pose()[0], start[0], atol=1e-9)


@pytest.mark.parametrize("axis", range(6))
def test_the_flange_moves_along_the_palms_own_axes_no_faster_than_its_bound(axis):
    scene = flanged(speed=0.05, turn_rate=0.4)
    start = scene.hand_pose()
    target = np.zeros(6)
    target[axis] = 0.9  # far beyond what half a second reaches
    steer(scene, target, 25)  # 0.5 s
    bound = 0.05 if axis < 3 else 0.4
    assert np.isclose(scene.flange_set_point()[axis], bound * 0.5)
    travelled = scene.flange()
    assert 0.8 * bound * 0.5 < travelled[axis] <= 1.01 * bound * 0.5  # the servo follows its set point closely
    assert np.abs(np.delete(travelled, axis)).max() < 1e-3 * max(1.0, travelled[axis])
    position, quat = moved(scene, start)
    if axis < 3:  # a slide moves the palm along its own axis, without turning it
        assert np.isclose(position[axis], travelled[axis], atol=1e-4) and abs(quat[0]) > 1 - 1e-6  # the wrist gives
    else:  # a hinge turns it about its own axis, through its origin
        angle = 2 * np.arctan2(np.linalg.norm(quat[1:]), quat[0])
        # the wrist gives a little
        assert np.isclose(angle, travelled[axis], atol=1e-3) and np.linalg.norm(position) < 1e-3
    scene.step(HALF_SECOND)  # not steered: the set point stays, the servo settles on it
    assert np.isclose(scene.flange()[axis], bound * 0.5, atol=1e-3)


def test_the_flange_stops_at_its_travel():
    scene = flanged(speed=0.1, travel=0.02)
    steer(scene, [0.0, 0.0, 0.1, 0.0, 0.0, 0.0], 50)
    assert np.isclose(scene.flange_set_point()[2], 0.02) and abs(scene.flange()[2] - 0.02) < 1e-3


def test_the_flange_pushes_the_object_no_harder_than_its_force_bound():
    scene = Scene("box", flange=FlangeLimits(force=20.0))
    scene.set_hand_pose(*facing_pose(scene.object, clearance=0.01))
    steer(scene, [0.0, -0.1, 0.0, 0.0, 0.0, 0.0], 50)  # the palm's -y: towards the object, which is welded
    force = scene.data.actuator_force[scene.flange_actuators]
    assert np.isclose(force[1], -20.0) and np.all(np.abs(force[:3]) <= 20.0 + 1e-9)
    assert scene.segment_forces().sum() > 15.0  # it does push, with what it has
    assert scene.flange_set_point()[1] < scene.flange()[1] - 0.05  # its set point went on; the palm did not


def test_a_locked_flange_refuses_to_be_steered_and_holds_its_pose_under_a_push():
    scene = flanged()
    steer(scene, [0.02, 0.0, 0.0, 0.0, 0.0, 0.0], 25)
    scene.lock_flange()
    held = scene.flange()
    with pytest.raises(InvalidInput, match="locked"):
        scene.steer_flange(np.zeros(6), PERIOD)
    scene.data.xfrc_applied[scene.palm_id, :3] = [10.0, 10.0, 10.0]  # a 17 N push on the palm
    scene.step(HALF_SECOND)
    assert np.abs(scene.flange()[:3] - held[:3]).max() < 2e-3  # a stiff arm: about 0.5 mm per 10 N
    scene.data.xfrc_applied[:] = 0.0
    scene.unlock_flange()
    steer(scene, [-0.05, 0.0, 0.0, 0.0, 0.0, 0.0], 25)
    assert scene.flange()[0] < held[0] - 0.01
    scene.reset()
    assert not scene.flange_locked and np.array_equal(scene.flange(), np.zeros(6))


def test_bad_flange_input_is_refused_by_name():
    scene = flanged()
    for bad in ([0.0] * 5, [np.nan] + [0.0] * 5, "fast"):
        with pytest.raises(InvalidInput, match="target"):
            scene.steer_flange(bad, PERIOD)
    for period in (0.0, -1.0, np.inf, True):
        with pytest.raises(InvalidInput, match="period"):
            scene.steer_flange(np.zeros(6), period)
    with pytest.raises(InvalidInput, match="has no flange"):
        Scene("box").flange()
    for field, value in (("speed", 0.0), ("force", -1.0), ("travel", np.inf), ("turn", 4.0), ("torque", True)):
        with pytest.raises(InvalidInput, match=field):
            FlangeLimits(**{field: value})
    with pytest.raises(InvalidInput, match="flange"):
        Scene("box", flange={"speed": 0.1})


@pytest.mark.parametrize("hand", ["shadow-primitives", "gymnasium-robotics"])
def test_every_hand_model_hangs_on_the_flange_and_its_scene_writes_itself_out(hand):
    if hand != "shadow-primitives":
        pytest.importorskip("gymnasium_robotics")
    scene = flanged(hand=hand)
    model = mujoco.MjModel.from_xml_string(scene.to_xml())  # the flanged scene's XML round trip
    assert (model.nbody, model.njnt, model.nu) == (scene.model.nbody, scene.model.njnt, scene.model.nu)
    assert all(model.joint(name).id >= 0 for name in FLANGE_JOINTS)
    start = scene.hand_pose()
    steer(scene, [0.0, 0.0, 0.02, 0.0, 0.0, 0.0], 25)
    assert 0.018 < moved(scene, start)[0][2] <= 0.02 + 1e-4


def test_the_lift_protocol_raises_the_palm_and_holds_what_keeps_up_with_it():
    import graspmanifold as gm
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.judging.replay import replay
    from graspmanifold.judging.judge import judge_scene, supported_scene
    from graspmanifold.judging.protocols import PROTOCOLS
    from graspmanifold.sim.objects import get_object

    lift = PROTOCOLS["lift"]
    assert lift.rules.needs_flange and not PROTOCOLS["hold-test"].rules.needs_flange and "raises the palm 0.2 m" in \
        lift.summary()
    # an open hand: the object falls away from the rising palm, judged in the period it is 10 cm behind
    scene = supported_scene(get_object("cylinder"), flange=FlangeLimits(), rules=lift.rules)
    scene.set_hand_pose(*facing_pose(scene.object, clearance=0.03))
    start = scene.data.xpos[scene.object_body, 2]
    dropped = judge_scene(scene, lift.rules)
    assert not dropped.hold and 0.1 < dropped.displacement < 0.12 and dropped.hold_time < 0.5
    assert scene.data.xpos[scene.object_body, 2] < start - 0.05
    # verified grasps, replayed open loop, hold under the lift as under our hold test; the arm raised them 0.2 m
    grasps = open_loop_grasps(gm.generate_postures("cylinder", 3, seed=0, workers=1), obj="cylinder")
    held, faults = replay("cylinder", grasps, "lift")
    assert held.all() and faults == ["", "", ""]
    with pytest.raises(InvalidInput, match="has no flange"):  # the lift needs an arm to raise the palm
        judge_scene(supported_scene(get_object("cylinder"), rules=lift.rules), lift.rules)


def test_a_trial_set_up_with_a_palm_runs_on_the_flange_and_keys_it():
    import graspmanifold as gm
    from graspmanifold.trials.setup import TrialSetup

    assert TrialSetup(object="box", protocol="lift").palm == FlangeLimits()  # the lift brings its arm
    plain, slow = TrialSetup(object="box"), TrialSetup(object="box", palm=FlangeLimits(speed=0.05))
    assert plain.palm is None and plain.key(np.zeros((1, 4)), 0) != slow.key(np.zeros((1, 4)), 0)
    with pytest.raises(InvalidInput, match="palm"):
        TrialSetup(object="box", palm={"speed": 0.05})
    result = gm.evaluate("cylinder", None, np.array([[0.0, 0.0, 0.01, 0.0], [0.005, 0.0, 0.015, 0.0]]), seed=0,
                         protocol="lift", workers=1)
    assert len(result.trials) == 2 and all(t.valid for t in result.trials)
    assert all((t.hold_displacement <= 0.1) == t.hold for t in result.trials)


def test_a_recall_that_moves_the_palm_moves_it_by_the_flange_where_the_hand_has_one():
    """BlendRecall's reach: without a flange the arm puts the palm at the controller's offset at once; on a flange,
    the flange's set point follows the offset at its bounded speed while the grasp goes on, then stays."""
    import graspmanifold as gm
    from graspmanifold.trials.grid import check_grid
    from graspmanifold.trials.episode import run_trials
    from graspmanifold.trials.setup import TrialSetup

    obj = gm.get_object("cylinder")
    poses = check_grid("quick", obj)[1][::5]
    params = gm.ControllerParams(recall=gm.BlendRecall(reach=0.03))
    limits = FlangeLimits(speed=0.02)
    experience = gm.PostureDatabase(gm.generate_postures("cylinder", 12, seed=0, workers=1).postures)
    setup = TrialSetup(object=obj, experience=experience, params=params, palm=limits)
    seen = []
    trials = run_trials(setup, poses, [np.random.default_rng([3, i]) for i in range(len(poses))],
                        observer=lambda worlds: seen.append(np.array([s.flange_set_point() for s in worlds.scenes])))
    points = np.array(seen)  # (periods, worlds, 6)
    assert np.abs(points[:, :, :3]).max() > 1e-3 and np.all(points[:, :, 3:] == 0)  # some palm moved, none turned
    steps = np.abs(np.diff(points[:, :, :3], axis=0)).max()
    assert steps <= limits.speed * params.control_period + 1e-12
    assert all(t.valid for t in trials)


def test_the_palm_approaches_until_touched_then_recentres_on_the_touch_and_stays_once_settled():
    """PalmSteering's phases on one controller, fed what a hand would sense: the guarded approach along the palm's
    -y at its speed, stopped by the first contact; re-centring in the palm's plane towards the touching segments'
    centre, bounded; still once the grasp has settled."""
    import graspmanifold as gm
    from graspmanifold.control.controller import GRASP_CENTRE_IN_PALM
    from graspmanifold.sim.hand import SegmentKinematics

    palm = gm.PalmSteering(approach=0.02, approach_speed=0.05, reach=0.01, speed=0.04)
    controller = gm.GraspController(None, gm.ControllerParams(palm=palm))
    dt = controller.params.control_period
    assert controller.moves_palm and not gm.GraspController(None).moves_palm
    joints, forces = gm.open_posture(), np.zeros(len(gm.SEGMENTS))
    offsets = []
    for _ in range(45):  # nothing touches: after phase A the palm advances along -y, 1 mm a cycle, to 2 cm
        controller.step(joints, forces)
        offsets.append(controller.palm_offset.copy())
    offsets = np.array(offsets)
    assert np.isclose(offsets[-1, 1], -0.02) and np.allclose(offsets[:, [0, 2]], 0.0)
    assert np.abs(np.diff(offsets, axis=0)).max() <= palm.approach_speed * dt + 1e-12
    controller = gm.GraspController(None, gm.ControllerParams(palm=palm))
    for _ in range(20):  # phase A, then 5 mm of approach
        controller.step(joints, forces)
    y = controller.palm_offset[1]
    assert -0.02 < y < 0
    touched = gm.closed_posture() * 0.5
    forces[gm.SEGMENTS.index("ffdistal")] = 1.0  # the index finger's tip touches: the object is over there
    centre = SegmentKinematics().positions(touched)[gm.SEGMENTS.index("ffdistal")]
    expected = np.clip(centre[[0, 2]] - GRASP_CENTRE_IN_PALM[[0, 2]], -palm.reach, palm.reach)
    offsets = []
    for _ in range(40):
        controller.step(touched, forces)
        offsets.append(controller.palm_offset.copy())
    offsets = np.array(offsets)
    assert np.allclose(offsets[:, 1], y)  # the approach stopped at the contact
    assert np.linalg.norm(np.diff(offsets, axis=0), axis=1).max() <= palm.speed * dt + 1e-12
    assert np.sign(offsets[-1, [0, 2]]).tolist() == np.sign(expected).tolist()
    assert np.abs(offsets[-1, [0, 2]]).max() <= palm.reach + 1e-12
    # every finger touching (settled): the palm is locked for the squeeze
    forces[[gm.SEGMENTS.index(f"{f}distal") for f in ("mf", "rf", "lf", "th")]] = 1.0
    controller.step(touched, forces)
    held = controller.palm_offset.copy()
    for _ in range(10):
        controller.step(touched, forces)
    assert np.array_equal(controller.palm_offset, held)


def test_palm_steering_is_checked_and_a_still_palm_keeps_the_trials_keys():
    import graspmanifold as gm

    assert "palm" not in gm.ControllerParams().to_table()
    steered = gm.ControllerParams(palm=gm.PalmSteering(reach=0.02))
    assert steered.to_table()["palm"]["reach"] == 0.02
    for field, value in (("approach", -0.01), ("reach", 0.5), ("speed", 0.0), ("approach_speed", np.nan)):
        with pytest.raises(InvalidInput, match=field):
            gm.PalmSteering(**{field: value})
    with pytest.raises(InvalidInput, match="one of them moves it"):
        gm.ControllerParams(recall=gm.BlendRecall(reach=0.02), palm=gm.PalmSteering(reach=0.02))
    with pytest.raises(InvalidInput, match="palm"):
        gm.ControllerParams(palm={"reach": 0.02})


def test_with_recalled_places_the_palm_moves_by_where_touch_finds_the_object_against_where_the_grasp_had_it():
    """The same touch, two experiences of the same recalled posture: one that knows where its grasp had the object
    (the object then sits off the touching segment as it sat off the recalled posture's, and the palm moves by the
    difference between the two), one that does not (it re-centres from touch alone, on the palm's grasp centre)."""
    import graspmanifold as gm
    from graspmanifold.control.controller import GRASP_CENTRE_IN_PALM
    from graspmanifold.sim.hand import SegmentKinematics

    recalled = gm.closed_posture() * 0.5
    sensed = recalled.copy()
    sensed[gm.FINGER_JOINTS.index("FFJ4")] += 0.2  # the index finger spread: it touches off its recalled place
    forces = np.zeros(len(gm.SEGMENTS))
    tip = gm.SEGMENTS.index("ffdistal")
    forces[tip] = 1.0
    place = GRASP_CENTRE_IN_PALM + [0.0, -0.03, 0.02]
    kinematics = SegmentKinematics()
    found = kinematics.positions(sensed)[tip] - kinematics.positions(recalled)[tip]  # where touch finds it, relative
    palm = gm.PalmSteering(reach=0.05, speed=0.05, recalled_place=True)
    ends, estimates = {}, {}
    for name, experience in (("knows", gm.PostureDatabase(recalled[None], place[None])),
                             ("does not", gm.PostureDatabase(recalled[None]))):
        controller = gm.GraspController(experience, gm.ControllerParams(palm=palm))
        for _ in range(60):
            controller.step(sensed, forces)
        assert controller.winners  # it recalled
        ends[name], estimates[name] = controller.palm_offset.copy(), controller.batch.object_estimate[0].copy()
    assert abs(found[0]) > 1e-3  # the spread moved the tip across the palm
    assert np.allclose(ends["knows"][[0, 2]], found[[0, 2]], atol=1e-9)  # moved by the difference
    assert np.allclose(estimates["knows"], place + found, atol=1e-9)  # the object where the grasp had it, moved so
    centre = kinematics.positions(sensed)[tip]
    assert np.allclose(ends["does not"][[0, 2]], (centre - GRASP_CENTRE_IN_PALM)[[0, 2]], atol=1e-9)
    assert np.allclose(estimates["does not"], centre, atol=1e-9)  # touch alone: the object where it is touched
