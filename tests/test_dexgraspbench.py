"""DexGraspBench's protocol: its physics profile, its external-force test, its Q1, its grasp files."""

import math

import mujoco
import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.sim.grip import squeezed
from graspmanifold.judging.plans import OpenLoopGrasp
from graspmanifold.judging.push_test import external_force_test
from graspmanifold.judging.quality import q1
from graspmanifold.judging.protocols import DEXGRASPBENCH, DEXGRASPBENCH_PAPER, get_protocol
from graspmanifold.synthesis.grasp_files import read_grasp_file, read_grasp_files, write_grasp_files
from graspmanifold.judging.quality import epsilon_l1


@pytest.fixture(scope="module")
def box_grasps():
    postures = gm.generate_postures("box", 3, seed=0, workers=1, progress=False)
    return [OpenLoopGrasp(np.tile(pose, (3, 1)), np.array([gm.open_posture(), posture, squeezed(posture, 0.15)]))
            for pose, posture in zip(postures.hand_poses, postures.postures)]


@pytest.mark.parametrize("version, mass", [(DEXGRASPBENCH, 0.1), (DEXGRASPBENCH_PAPER, 0.03)])
def test_the_physics_profile_sets_the_options_listed(version, mass):
    scene = gm.Scene("box", free_object=True, gravity=True)
    version.physics.apply(scene)
    opt = scene.model.opt
    assert opt.timestep == 0.004 and opt.impratio == 10 and opt.noslip_iterations == 2
    assert opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST and opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert (scene.model.geom_condim == 4).all()
    assert np.allclose(scene.model.geom_friction[:, :2], [0.6, 0.02]) and not opt.gravity.any()
    assert math.isclose(scene.model.body_mass[scene.object_body], mass)
    assert version.push == pytest.approx(10 * mass)
    assert get_protocol(version.name).push_test is version and get_protocol(version.name).physics is version.physics
    with pytest.raises(ValueError, match="protocol must be one of"):
        get_protocol("dexgraspbench-v9")


def test_a_grasp_that_holds_passes_every_direction(box_grasps):
    results = [external_force_test(gm.Scene("box", free_object=True), g) for g in box_grasps]
    held = [r for r in results if r.success]
    assert held, [r.translation for r in results]
    for r in held:
        assert r.steps == 2 * 10 * 10 + 6 * 10 * 50 and not r.fault  # one approach, then six pushes
        assert (r.translation <= DEXGRASPBENCH.translation_limit).all()
        assert (r.rotation <= DEXGRASPBENCH.angle_limit).all()


def test_every_direction_starts_from_the_approachs_end_as_a_replay_of_it_would(box_grasps):
    """The approach runs once and each push starts from its saved end: the same as DexGraspBench's replay of the
    approach for each direction (a test of that one direction alone)."""
    from dataclasses import replace

    for grasp in box_grasps:
        whole = external_force_test(gm.Scene("box", free_object=True), grasp)
        for k in np.flatnonzero(np.isfinite(whole.translation)):
            alone = external_force_test(gm.Scene("box", free_object=True), grasp,
                                        replace(DEXGRASPBENCH, directions=(DEXGRASPBENCH.directions[k],)))
            assert alone.translation[0] == whole.translation[k] and alone.rotation[0] == whole.rotation[k]


def test_a_grasp_that_drops_fails_in_its_first_direction_and_stops_early(box_grasps):
    away = box_grasps[0].poses + np.array([0.0, 0.0, 0.15, 0, 0, 0, 0])  # the hand far from the object
    result = external_force_test(gm.Scene("box", free_object=True),
                                 OpenLoopGrasp(away, np.tile(gm.open_posture(), (3, 1))))
    assert not result.success and result.translation[0] > DEXGRASPBENCH.translation_limit
    assert np.isnan(result.translation[1:]).all()  # no later direction ran
    assert 2 * 10 * 10 < result.steps < 2 * 10 * 10 + 10 * 50  # the push stopped early


def test_a_pregrasp_15_mm_inside_the_object_fails_outright():
    position, quat = gm.facing_pose("box", clearance=0.0)  # the palm faces the box from +x, touching it
    inside = np.r_[position - [0.015, 0.0, 0.0], quat]
    grasp = OpenLoopGrasp(np.tile(inside, (3, 1)), np.tile(gm.open_posture(), (3, 1)))
    result = external_force_test(gm.Scene("box", free_object=True), grasp, DEXGRASPBENCH_PAPER)
    assert not result.success and result.steps == 0 and "inside the object" in result.fault
    assert result.penetration > 0.01


def test_q1_in_its_convention_equals_the_hand_computation():
    # four links on a 3 cm sphere, one of them touching twice; a fifth contact 8 mm away does not count
    points = np.array([[0.03, 0, 0], [-0.015, 0.026, 0], [-0.015, -0.026, 0.0], [0, 0, 0.029], [0, 0, 0.031],
                       [0, 0, -0.038]])
    normals = -points / np.linalg.norm(points, axis=1, keepdims=True)
    links = np.array([1, 2, 3, 4, 4, 5])
    distances = np.array([0, 0, 0, -0.001, 0.001, 0.008])
    # by hand: link 4's two contacts become (0, 0, 0.03) along -z; the centroid of the four is
    # (0, 0, 0.0075); their mean distance from it
    where = np.array([[0.03, 0, 0], [-0.015, 0.026, 0], [-0.015, -0.026, 0.0], [0, 0, 0.03]])
    towards = np.array([[-1, 0, 0], normals[1], normals[2], [0, 0, -1]])
    centroid = np.array([0.0, 0.0, 0.0075])
    radius = np.mean(np.linalg.norm(where - centroid, axis=1))
    expected = epsilon_l1(where, towards, centroid, mu=0.3, num_edges=8, torque_scale=radius)
    assert expected > 0
    assert q1(points, normals, links, distances) == pytest.approx(expected, rel=1e-9)
    assert q1(points[:1], normals[:1], links[:1]) == 0.0  # one link: no closure


def test_grasp_files_round_trip(tmp_path, box_grasps):
    written = write_grasp_files(tmp_path, box_grasps, "DGNObj/box_core", object_scale=0.8)
    assert [p.name for p in written] == ["grasp_00000.npy", "grasp_00001.npy", "grasp_00002.npy"]
    read = read_grasp_files(tmp_path)
    assert len(read) == 3
    for mine, theirs in zip(box_grasps, read):
        assert np.allclose(mine.postures, theirs.grasp.postures)
        assert np.allclose(mine.poses[:, :3], theirs.grasp.poses[:, :3], atol=1e-9)
        assert np.allclose(np.abs(np.sum(mine.poses[:, 3:] * theirs.grasp.poses[:, 3:], axis=1)), 1.0)
        assert theirs.object_path == "DGNObj/box_core" and theirs.object_scale == 0.8


def test_the_other_root_layout_reads_the_same(tmp_path, box_grasps):
    write_grasp_files(tmp_path / "inside", box_grasps[:1], "box")
    content = read_grasp_file(tmp_path / "inside" / "grasp_00000.npy")
    apart = dict(content)
    for stage in ("pregrasp", "grasp", "squeeze"):
        apart[f"{stage}_pose"], apart[f"{stage}_qpos"] = content[f"{stage}_qpos"][:7], content[f"{stage}_qpos"][7:]
    (tmp_path / "apart").mkdir()
    np.save(tmp_path / "apart" / "g.npy", np.array(apart, dtype=object), allow_pickle=True)
    one, other = read_grasp_files(tmp_path / "inside")[0], read_grasp_files(tmp_path / "apart")[0]
    assert np.allclose(one.grasp.poses, other.grasp.poses) and np.allclose(one.grasp.postures, other.grasp.postures)


def _leave_a_mark(path):
    with open(path, "w") as handle:
        handle.write("ran")


class _Foreign:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return _leave_a_mark, (self.marker,)


def test_a_foreign_pickle_is_refused_and_nothing_runs(tmp_path):
    marker = tmp_path / "it ran"
    np.save(tmp_path / "evil.npy", np.array({"obj_path": _Foreign(str(marker))}, dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"evil\.npy: refused"):
        read_grasp_file(tmp_path / "evil.npy")
    with pytest.raises(ValueError, match=r"evil\.npy: refused"):
        read_grasp_files(tmp_path)
    assert not marker.exists()
    np.save(tmp_path / "list.npy", np.array([[1, 2]], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"list\.npy: refused, it must hold a dict"):
        read_grasp_file(tmp_path / "list.npy")
    (tmp_path / "cut.npy").write_bytes((tmp_path / "evil.npy").read_bytes()[:70])
    with pytest.raises(ValueError, match=r"cut\.npy: refused"):
        read_grasp_file(tmp_path / "cut.npy")


def test_a_grasp_file_without_its_stages_is_named(tmp_path):
    np.save(tmp_path / "half.npy", np.array({"obj_path": "x", "obj_scale": 1.0, "obj_pose": np.zeros(7)},
                                            dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match=r"half\.npy: lacks \['pregrasp_qpos'"):
        read_grasp_files(tmp_path)


def test_closed_loop_trials_take_either_protocol_by_name():
    grid = gm.grid_preset("quick", "box")[:4]
    ours = gm.evaluate("box", None, grid, workers=1, progress=False)
    theirs = gm.evaluate("box", None, grid, workers=1, progress=False, protocol="dexgraspbench")
    for trial in theirs.trials:  # a push of 1 N per direction for 2 s, each from the grasp's end
        assert trial.valid and trial.hold_time <= 6 * 2.0 + 1e-9
        assert trial.hold_time == pytest.approx(12.0) if trial.hold else trial.hold_time < 12.0
    assert max(t.hold_time for t in ours.trials) <= 6 * 0.5 + 1e-9
    assert gm.TrialSetup(object="box").key(grid, 0) != gm.TrialSetup(object="box", protocol="dexgraspbench").key(grid, 0)
    with pytest.raises(ValueError, match="protocol must be one of"):
        gm.evaluate("box", None, grid, protocol="dexgraspbench-v0")
    with pytest.raises(ValueError, match="without our disturbance margin"):
        gm.TrialSetup(object="box", protocol="dexgraspbench", margin=True)
    verified = gm.generate_postures("box", 2, seed=0, workers=1, progress=False,
                                    params=gm.GeneratorParams(verify_protocol="dexgraspbench-paper"))
    assert len(verified) == 2


def test_open_loop_replay_is_a_method_judged_by_either_protocol(box_grasps):
    from graspmanifold.judging.plans import GRASP_STAGES, open_loop_grasps
    from graspmanifold.judging.replay import replay

    postures = gm.generate_postures("box", 2, seed=0, workers=1, progress=False)
    grasps = open_loop_grasps(postures)  # the stages the set was verified with: from its contacts
    assert np.allclose(grasps[0].postures[1], postures.postures[0])
    assert np.allclose(grasps[0].poses, postures.hand_poses[0])  # the palm stays, the fingers move
    opened = open_loop_grasps(postures, GRASP_STAGES["open"])
    assert np.linalg.norm(opened[0].poses[0, :3]) == pytest.approx(np.linalg.norm(opened[0].poses[1, :3]) + 0.02)
    for name in ("hold-test", "dexgraspbench"):
        held, faults = replay("box", grasps, name)
        assert held.dtype == bool and held.shape == (2,) and len(faults) == 2
        alone = [replay("box", [g], name)[0][0] for g in grasps]  # a hold test before leaves nothing behind
        assert list(held) == alone
    held, _ = replay("box", box_grasps, "dexgraspbench")
    direct = [external_force_test(gm.Scene("box", free_object=True), g).success for g in box_grasps]
    assert list(held) == direct  # the same test, grasp by grasp
    with pytest.raises(ValueError, match="protocol must be one of"):
        replay("box", grasps, "dexgraspbench-v0")


def test_a_grasp_files_object_folder_is_found_or_named(tmp_path, box_grasps):
    import trimesh

    from graspmanifold.synthesis.grasp_files import grasp_object, posture_set

    folder = tmp_path / "objects" / "core_box_1" / "mesh"
    folder.mkdir(parents=True)
    trimesh.creation.box(extents=(40.0, 40.0, 160.0)).export(folder / "simplified.obj")  # in mm
    write_grasp_files(tmp_path / "grasps", box_grasps, "core_box_1", object_scale=0.001)
    files = read_grasp_files(tmp_path / "grasps")
    obj = grasp_object(files[0], root=tmp_path / "objects")
    assert obj.name == "core_box_1" and np.allclose(sorted(2 * np.asarray(obj.half_extents)), [0.04, 0.04, 0.16])
    with pytest.raises(ValueError, match=r"object folder .*core_box_1 is missing"):
        grasp_object(files[0], root=tmp_path / "elsewhere")
    postures = posture_set(files)
    assert len(postures) == 3 and np.allclose(postures.postures, [g.grasp.postures[1] for g in files])
    assert np.allclose(postures.metadata["squeeze"], [g.grasp.postures[2] for g in files])


@pytest.mark.parametrize("protocol_name", ["hold-test", "dexgraspbench"])
def test_the_verifier_is_the_replay(protocol_name):
    """The generator's verifier and `replay` are one procedure (`replay_grasp`): on candidates that hold and
    candidates that drop, the verifier's outcome is the replay's, grasp by grasp."""
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.judging.replay import GraspVerifier, replay
    from graspmanifold.judging.judge import JUDGING

    candidates = gm.generate_postures("cylinder", 6, seed=1, workers=1, progress=False,
                                      params=gm.GeneratorParams(verify=False, designs="grasp_types"))
    verifier = GraspVerifier(gm.get_object("cylinder"), hold_seconds=JUDGING.hold_seconds, protocol=protocol_name)
    verified = [verifier(p, h[:3], h[3:]).hold for p, h in zip(candidates.postures, candidates.hand_poses)]
    held, _ = replay("cylinder", open_loop_grasps(candidates), protocol_name)
    assert verified == list(held) and 0 < sum(verified) < len(verified)
    # a look at the scene at the squeeze's end (`observe`, as the spring-holds study takes it) changes nothing and
    # sees every grasp that holds touching its object
    touching = []
    for posture, pose in zip(candidates.postures, candidates.hand_poses):
        seen = []
        touching.append((verifier(posture, pose[:3], pose[3:], observe=lambda s: seen.append(s.tactile().segments)).hold,
                         seen))
    assert [hold for hold, _ in touching] == verified
    assert all(len(seen) == 1 and len(seen[0]) >= 2 for hold, seen in touching if hold)


@pytest.mark.parametrize("name, protocol_name, stages", [
    ("box", "hold-test", "open"), ("cylinder", "hold-test", "contacts"), ("cube", "hold-test", "contacts"),
    ("marble", "hold-test", "open"), ("cylinder", "dexgraspbench", "contacts"), ("pen", "hold-test", "contacts"),
])
def test_a_verified_posture_replays_to_a_hold_under_the_protocol_it_was_verified_with(name, protocol_name, stages):
    """What the generator keeps holds when replayed open loop (`replay`, a new scene) under its verifier's
    protocol, with its stages."""
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.judging.replay import replay
    from graspmanifold.trials.benchmark import OBJECTS

    obj = OBJECTS[name].object
    params = gm.GeneratorParams(verify_protocol=protocol_name, stages=stages,
                                verify_hold_seconds=0.5 if protocol_name == "hold-test" else 0.25)
    postures = gm.generate_postures(obj, 2, seed=0, workers=1, progress=False, params=params)
    held, faults = replay(obj, open_loop_grasps(postures, params.grasp_stages, obj), protocol_name)
    assert held.all() and not any(faults), faults


def test_stages_made_from_the_contacts_move_the_touching_segments_along_the_normals():
    """`offset_along_normals`: the touching fingertips end about `depth` further along the object's inward normal
    (out for a pregrasp, in for a squeeze), the touching segments on average more than half of it; a finger that
    touches nothing keeps its joints."""
    from graspmanifold.sim.normal_offsets import CONTACT_REACH, offset_along_normals
    from graspmanifold.judging.plans import GRASP_STAGES, GraspStages, open_loop_grasp
    from graspmanifold.sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, segment_of_geoms

    start = next(s for s in gm.starting_postures("cylinder", "grasp_types") if s.name == "tripod")
    scene = gm.Scene("cylinder")
    pose = np.r_[start.hand_pos, start.hand_quat]
    segment_of = segment_of_geoms(scene.model, scene.hand)
    fingers = scene.hand.segments[len(scene.hand.base_segments):]

    def gaps(posture):
        scene.set_posture(posture)
        scene.set_hand_pose(pose[:3], pose[3:])
        return np.array([min(scene.distance_to_object(int(g)) for g in np.flatnonzero(segment_of == i))
                         for i in range(len(scene.hand.base_segments), len(scene.hand.segments))])

    before = gaps(start.posture)
    touching = before <= CONTACT_REACH
    tips = touching & np.isin(fingers, DISTAL_SEGMENTS)
    assert tips.sum() >= 2
    for depth in (-0.01, 0.005):  # a segment's nearest point may move on it as it turns: about depth, not exactly
        moved = offset_along_normals(scene, pose, start.posture, depth)
        change = (before - gaps(moved)) / depth  # how far further in, in units of depth
        assert (change[tips] > 0.6).all() and (change[tips] < 2.0).all(), (depth, change[tips])
        assert change[touching].mean() > 0.5
    backed = offset_along_normals(scene, pose, start.posture, -0.01)
    idle = [f for f in ("ff", "mf", "rf", "lf", "th") if not any(
        touching[i] for i, s in enumerate(fingers) if s.startswith(f))]
    columns = [j for j, name in enumerate(FINGER_JOINTS) if name[:2].lower() in idle]
    assert np.allclose(backed[columns], start.posture[columns], atol=1e-3)
    grasp = open_loop_grasp(pose, start.posture, GRASP_STAGES["contacts"], scene)
    assert np.allclose(grasp.poses, pose) and np.allclose(grasp.postures[1], start.posture)
    with pytest.raises(ValueError, match="need the object's scene"):
        open_loop_grasp(pose, start.posture, GRASP_STAGES["contacts"])
    with pytest.raises(ValueError, match="GraspStages.squeeze must be one of"):
        GraspStages(squeeze="fist")
    with pytest.raises(ValueError, match="GeneratorParams.stages must be one of"):
        gm.GeneratorParams(stages="closed")


def test_a_verifiers_outcome_does_not_depend_on_what_it_judged_before():
    """On a mesh (whose edges once gave a contact the normal of one face or the other by the last bit) the verifier
    judges each verified posture the same in either order, and `replay` holds every one."""
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.judging.replay import GraspVerifier, replay

    obj = gm.get_object("frustum_s")
    postures = gm.generate_postures(obj, 6, seed=0, workers=1, progress=False)
    verifier = GraspVerifier(obj)
    forward = [verifier(p, h[:3], h[3:]).hold for p, h in zip(postures.postures, postures.hand_poses)]
    backward = [verifier(p, h[:3], h[3:]).hold for p, h in zip(postures.postures[::-1], postures.hand_poses[::-1])]
    assert all(forward) and backward == forward[::-1]
    assert replay(obj, open_loop_grasps(postures), "hold-test")[0].all()


def test_a_protocol_is_one_value_looked_up_by_name_and_ones_own_runs_everywhere_a_name_does():
    """The registry holds our hold test, the lift and DexGraspBench's two versions; a protocol of one's own (here a
    pull of 1 N along +z only, gravity off, 0.3 s) is a `JudgingProtocol` value that `evaluate` and `replay_grasp` run
    without any change to the trial loop or the replay, and that keys its results apart from ours."""
    from dataclasses import replace as changed

    from graspmanifold.judging.plans import GRASP_STAGES, open_loop_grasps
    from graspmanifold.judging.replay import replay_grasp
    from graspmanifold.judging.judge import JUDGING
    from graspmanifold.judging.protocols import DEFAULT_PROTOCOL, PROTOCOLS, JudgingProtocol
    from graspmanifold.trials.setup import TrialSetup

    assert PROTOCOLS[DEFAULT_PROTOCOL].rules == JUDGING and PROTOCOLS[DEFAULT_PROTOCOL].physics is None
    assert {name for name, p in PROTOCOLS.items() if p.push_test is not None} == {"dexgraspbench", "dexgraspbench-paper"}
    lift = JudgingProtocol("pull", changed(JUDGING, push=1.0, directions=((0.0, 0.0, 1.0),), hold_seconds=0.3))
    with pytest.raises(ValueError, match="protocol must be one of .* or a JudgingProtocol"):
        TrialSetup(object="box", protocol="pull")
    from graspmanifold.trials.grid import check_grid

    poses = check_grid("quick", gm.get_object("box"))[1][:4]
    ours = gm.evaluate("box", None, poses, seed=0, workers=1, progress=False)
    lifted = gm.evaluate("box", None, poses, seed=0, workers=1, progress=False, protocol=lift)
    assert np.array_equal(ours.outcomes("force_closure"), lifted.outcomes("force_closure"))  # the same grasps
    assert ours.outcomes("hold").any() and lifted.outcomes("hold")[ours.outcomes("hold")].all()  # six hold one
    times = np.array([t.hold_time for t in lifted.trials])[lifted.outcomes("hold")]
    assert np.allclose(times, 0.3)  # one direction of 0.3 s, not six of 0.5 s
    assert TrialSetup(object="box", protocol=lift).key(poses, 0) != TrialSetup(object="box").key(poses, 0)
    assert TrialSetup(object="box", protocol=DEFAULT_PROTOCOL).key(poses, 0) == TrialSetup(object="box").key(poses, 0)
    postures = gm.generate_postures("box", 2, seed=0, workers=1, progress=False)
    scene = gm.Scene("box", free_object=True)
    for grasp in open_loop_grasps(postures, GRASP_STAGES["contacts"], "box"):
        replayed = replay_grasp(scene, grasp, lift)
        assert replayed.held and replayed.judgement.hold_time == pytest.approx(0.3)
