"""Every hand model the library knows loads behind the one interface, and its 22 finger joints are the paper's."""

import os
import re
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

from graspmanifold import InvalidInput
from graspmanifold.sim.hand import FINGERS, SHADOW_HAND, finger_of
from graspmanifold.sim.hand_models import HAND_MODELS, check_hand_model, hand_model, joint_agreement, mjcf_hand


def available(name: str):
    if name == "menagerie" and "MENAGERIE_ROOT" not in os.environ:
        pytest.skip("Menagerie's hand is read from a checkout: set MENAGERIE_ROOT")
    try:
        return hand_model(name)
    except ImportError as error:  # the optional model's package ('graspmanifold[hands]') is not installed
        pytest.skip(str(error))


def fingertips(hand, posture: np.ndarray) -> np.ndarray:
    """The fingertip sites (5, 3) in the palm frame, m, for a posture in the paper's sense."""
    model, data = hand.model, mujoco.MjData(hand.model)
    for joint, angle in zip(hand.finger_joints, hand.to_model(posture)):
        data.qpos[model.joint(joint).qposadr[0]] = angle
    mujoco.mj_kinematics(model, data)
    palm = model.body(hand.palm).id
    sites = np.array([data.site_xpos[model.site(name).id] for name in hand.fingertip_sites])
    return (sites - data.xpos[palm]) @ data.xmat[palm].reshape(3, 3)


@pytest.mark.parametrize("name", HAND_MODELS)
def test_every_hand_model_loads_and_its_fingertips_lie_in_a_hand_sized_box(name):
    hand = available(name)
    assert len(hand.finger_joints) == 22 and len(hand.segments) == len(SHADOW_HAND.segments)
    for key in ("open", "closed"):
        tips = fingertips(hand, hand.keyframe_posture(key))
        assert np.all(np.isfinite(tips)) and np.all(np.linalg.norm(tips, axis=1) < 0.25), (key, tips)
    open_, closed = fingertips(hand, hand.keyframe_posture("open")), fingertips(hand, hand.keyframe_posture("closed"))
    assert np.all(np.linalg.norm(closed[:4], axis=1) < np.linalg.norm(open_[:4], axis=1))  # closing curls the fingers
    coupling = hand.coupling()
    assert coupling.shape == (len(hand.actuators), 22) and (coupling.sum(axis=0) <= 1).all()


@pytest.mark.parametrize("name", [n for n in HAND_MODELS if n != "shadow-primitives"])
def test_the_finger_joints_map_in_the_papers_order_and_sense(name):
    """A small turn of each mapped joint moves its fingertip the way ours does (the map's order and signs), and
    the four fingers' tips of the closed hand lie where ours do."""
    hand = available(name)
    base = 0.5 * (SHADOW_HAND.keyframe_posture("open") + SHADOW_HAND.keyframe_posture("closed"))
    for index, joint in enumerate(SHADOW_HAND.finger_joints):
        finger = FINGERS.index(finger_of(joint))
        turn = np.zeros(22)
        turn[index] = 0.1
        ours = fingertips(SHADOW_HAND, base + turn)[finger] - fingertips(SHADOW_HAND, base)[finger]
        theirs = fingertips(hand, base + turn)[finger] - fingertips(hand, base)[finger]
        assert ours @ theirs / (np.linalg.norm(ours) * np.linalg.norm(theirs)) > 0.9, joint
    closed = SHADOW_HAND.keyframe_posture("closed")
    np.testing.assert_allclose(fingertips(hand, closed)[:4], fingertips(SHADOW_HAND, closed)[:4], atol=0.005)


def gymnasium_file(folder) -> str:
    """Gymnasium-Robotics' hand written out as one MJCF file, as a user would have it."""
    from graspmanifold.sim.hand_models import _gymnasium_assets

    root = _gymnasium_assets()
    path = folder / "gymnasium_hand.xml"
    path.write_text(f"""<mujoco model="a user's hand">
  <compiler angle="radian" meshdir="{root.parent / 'stls' / 'hand'}" texturedir="{root.parent / 'textures'}"/>
  <include file="{root / 'shared.xml'}"/>
  <asset><include file="{root / 'shared_asset.xml'}"/></asset>
  <worldbody><include file="{root / 'robot.xml'}"/></worldbody>
</mujoco>""")
    return str(path)


def ours_renamed(folder, prefix: str = "rh_", edit=lambda spec: None, written=lambda xml: xml) -> str:
    """Our hand written out with Menagerie's names (rh_FFJ4 ..., rh_ffproximal ...) and without fingertip sites."""
    spec = SHADOW_HAND.spec()
    for site in [s for s in spec.sites if s.name.endswith("tip")]:
        spec.delete(site)
    names = {e.name for kind in (spec.bodies, spec.joints, spec.geoms, spec.actuators, spec.tendons, spec.sites)
             for e in kind if e.name and e.name != "world"}
    xml = re.sub(r'"([^"]+)"', lambda m: f'"{prefix}{m[1]}"' if m[1] in names else m[0], spec.to_xml())
    spec = mujoco.MjSpec.from_string(xml)
    edit(spec)
    path = folder / f"{prefix or 'plain_'}hand.xml"
    path.write_text(written(spec.to_xml()))
    return str(path)


def test_a_hand_from_an_mjcf_file_is_described_by_measurement(tmp_path):
    """A model given by path: its names read (any prefix, counted from 1 or from 0), its joints' senses measured,
    fingertip sites added where it has none; the Gymnasium hand from a file is described as the named one."""
    named = available("gymnasium-robotics")
    from_file = hand_model(gymnasium_file(tmp_path))
    assert from_file.name == str(tmp_path / "gymnasium_hand.xml") and from_file.mount == "robot0:hand mount"
    assert (from_file.finger_joints, from_file.flipped, from_file.actuators, from_file.fingertip_sites) == (
        named.finger_joints, named.flipped, named.actuators, named.fingertip_sites)
    assert named.flipped == ("robot0:FFJ3", "robot0:MFJ3", "robot0:THJ1", "robot0:THJ0")
    assert np.all(joint_agreement(from_file) > 0.99)

    renamed = mjcf_hand(ours_renamed(tmp_path), name="renamed")
    assert renamed.finger_joints == tuple(f"rh_{j}" for j in SHADOW_HAND.finger_joints) and renamed.flipped == ()
    assert renamed.segments == tuple(f"rh_{s}" for s in SHADOW_HAND.segments) and renamed.mount == "rh_hand_mount"
    np.testing.assert_allclose(joint_agreement(renamed), 1.0, atol=1e-9)
    np.testing.assert_allclose(fingertips(renamed, SHADOW_HAND.keyframe_posture("closed")),
                               fingertips(SHADOW_HAND, SHADOW_HAND.keyframe_posture("closed")), atol=1e-6)
    np.testing.assert_array_equal(renamed.coupling(), SHADOW_HAND.coupling())
    scene = __import__("graspmanifold").Scene("cylinder", hand=renamed)  # and it runs
    scene.set_posture(SHADOW_HAND.keyframe_posture("closed"))
    np.testing.assert_allclose(scene.posture(), SHADOW_HAND.keyframe_posture("closed"), atol=1e-9)


def turned_joint(spec):
    spec.joint("rh_FFJ3").axis = [0.0, 1.0, 0.0]


def floor(spec):
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])


def missing_mesh(xml):
    return xml.replace("</mujoco>", '  <asset><mesh name="gone" file="no_such_mesh.stl"/></asset>\n</mujoco>')


@pytest.mark.parametrize("edit, written, message", [
    (turned_joint, None, r"do not move as the paper's do .*rh_FFJ3 \(0\.\d\d\)"),
    (floor, None, "must hold the hand alone under its world .* geoms \\['floor'\\]"),
    (None, missing_mesh, "does not compile: .*no_such_mesh.stl"),
    (None, lambda xml: xml.replace('"rh_THJ1"', '"lh_THJ1"'),
     r"must name its joints as Shadow does .* prefixes \['lh_', 'rh_'\]"),
])
def test_a_file_that_is_not_a_right_shadow_hand_is_refused_saying_why(tmp_path, edit, written, message):
    path = ours_renamed(tmp_path, "rh_", edit or (lambda spec: None), written or (lambda xml: xml))
    with pytest.raises(InvalidInput, match=message):
        mjcf_hand(path)


def test_unknown_and_incomplete_models_are_refused_naming_what_is_missing(tmp_path):
    with pytest.raises(InvalidInput, match="hand must be one of .* or the path of an MJCF file"):
        hand_model("allegro")
    with pytest.raises(InvalidInput, match="hand: no such file: .*absent.xml"):
        hand_model(str(tmp_path / "absent.xml"))
    broken = replace(SHADOW_HAND, finger_joints=("FFJ9",) + SHADOW_HAND.finger_joints[1:],
                     fingertip_sites=SHADOW_HAND.fingertip_sites[:4] + ("thumbtip",))
    with pytest.raises(InvalidInput, match="lacks what its description names: joint FFJ9, site thumbtip"):
        check_hand_model(broken)
    with pytest.raises(InvalidInput, match="22 finger joints"):
        check_hand_model(replace(SHADOW_HAND, finger_joints=SHADOW_HAND.finger_joints[:21]))


@pytest.mark.parametrize("name", HAND_MODELS)
def test_a_scripted_grasp_on_every_model_is_felt_in_the_papers_segments_and_judged_by_the_same_test(name):
    """The scene adapts the model: postures in, postures out in the paper's sense, touch in the paper's
    segments, one hold test and force-closure measure for every model."""
    import graspmanifold as gm
    from graspmanifold.judging.judge import JUDGING, hold_on_support, judge_scene

    hand = available(name)
    scene = gm.Scene("cylinder", free_object=True, hand=hand)
    hold_on_support(scene)
    scene.set_hand_pose(*gm.facing_pose("cylinder", clearance=0.01))
    scene.set_posture(gm.open_posture())
    np.testing.assert_allclose(scene.posture(), gm.open_posture(), atol=1e-12)  # the model's signs undone
    scene.set_target(gm.closed_posture())
    scene.run(1.0)
    reading = scene.tactile()
    assert set(reading.segments) <= set(gm.SEGMENTS) and {"ffdistal", "thmiddle"} <= set(reading.segments)
    judgement = judge_scene(scene, replace(JUDGING, margin=False))
    assert scene.healthy() and judgement.epsilon > 0.01 and np.isfinite(judgement.displacement)


def test_the_generator_and_the_evaluation_run_on_another_hand_and_its_experience_stays_with_it():
    import graspmanifold as gm

    available("gymnasium-robotics")
    postures = gm.generate_postures("cylinder", 6, seed=0, workers=1,
                                    params=gm.GeneratorParams(job_size=3, verify=False, hand="gymnasium-robotics"))
    assert len(postures) == 6 and postures.metadata["hand"] == "gymnasium-robotics"
    grid = gm.grid_preset("quick", "cylinder")[:2]
    result = gm.evaluate("cylinder", postures, grid, workers=1, hand="gymnasium-robotics")
    assert len(result.trials) == 2 and all(t.valid for t in result.trials)
    with pytest.raises(InvalidInput, match="postures of the 'gymnasium-robotics' hand; these trials run the 'shadow-primitives'"):
        gm.evaluate("cylinder", postures, grid, workers=1)
    with pytest.raises(InvalidInput, match="backend='warp' runs our hand model only"):
        gm.evaluate("cylinder", None, grid, backend="warp", hand="gymnasium-robotics")


def test_a_controller_on_another_hand_drives_that_hand_and_never_commands_a_joint_outside_its_ranges():
    """The controller takes the trial's hand: its open posture, and its ranges for every target, also when the
    experience recalls our hand's postures beyond them (real trials on the Gymnasium-Robotics hand)."""
    import graspmanifold as gm
    from graspmanifold.control.controller import BatchController
    from graspmanifold.trials.episode import run_trials
    from graspmanifold.trials.setup import TrialSetup

    hand = available("gymnasium-robotics")
    low, high = hand.limits().T
    ours = SHADOW_HAND.limits()
    narrower = (ours[:, 0] < low - 1e-6) | (ours[:, 1] > high + 1e-6)
    assert narrower.any()  # e.g. its proximal joints cannot hyperextend
    beyond = np.where(narrower, ours[:, 0], gm.closed_posture())  # recalls outside its ranges
    experience = gm.PostureDatabase(np.array([beyond, 0.5 * (gm.open_posture() + beyond)]))
    seen = []

    class Watched(BatchController):
        def step(self, joints, segment_forces):
            seen.append(super().step(joints, segment_forces))
            return seen[-1]

    for params in (gm.ControllerParams(), gm.ControllerParams(recall="base", max_match_distance=np.inf)):
        controller = BatchController(2, experience, params, hand=hand)
        np.testing.assert_array_equal(controller.initial, hand.keyframe_posture("open"))
        np.testing.assert_array_equal(controller.closed, hand.keyframe_posture("closed"))
        setup = TrialSetup(object="cylinder", hand=hand, method="watched",
                           controller=lambda n, hand, params=params: Watched(n, experience, params, hand=hand))
        trials = run_trials(setup, gm.grid_preset("quick", "cylinder")[:2], [np.random.default_rng(k) for k in range(2)])
        assert all(t.valid for t in trials) and sum(t.matches for t in trials) > 0
    targets = np.concatenate(seen)
    assert np.all((targets >= low - 1e-12) & (targets <= high + 1e-12))
    assert np.isclose(targets[:, narrower], np.where(narrower, low, high)[narrower]).any()  # it met the ranges


def test_a_reproduction_runs_on_another_hand(tmp_path):
    import json

    import graspmanifold as gm
    from graspmanifold.paper.reproduce import ReproduceConfig, reproduce

    with pytest.raises(InvalidInput, match="ReproduceConfig.hand must be one of"):
        ReproduceConfig(postures={"cylinder": 4}, hand="allegro")
    available("gymnasium-robotics")
    config = ReproduceConfig(postures={"cylinder": 24}, grid=((0.0, 0.0, 0.01, 0.0), (0.0, 0.01, 0.02, 0.2)),
                             map_size=(4, 4), epochs=3, image_size=32, generator=gm.GeneratorParams(verify=False),
                             hand="gymnasium-robotics")
    summary = reproduce(tmp_path / "run", config, workers=1, log=lambda line: None)
    assert [r["method"] for r in summary["evaluation"]] == ["none", "database", "som", "som_all", "database_blend",
                                                            "som_blend"]
    assert json.loads((tmp_path / "run" / "run.json").read_text())["config"]["hand"] == "gymnasium-robotics"
    assert gm.PostureSet.load(tmp_path / "run" / "postures" / "cylinder.npz").metadata["hand"] == "gymnasium-robotics"
    assert "Gymnasium-Robotics' Shadow Hand" in (tmp_path / "run" / "report.md").read_text()


@pytest.mark.parametrize("obj", ["cylinder", "sphere"])
def test_touch_sensors_and_contact_forces_give_the_same_pcp_mask(obj):
    """Two ways to feel: the model's own touch sensors summed per segment, and the contact forces per segment."""
    import graspmanifold as gm
    from graspmanifold.judging.judge import hold_on_support

    with pytest.raises(InvalidInput, match="has no touch sensors"):
        gm.Scene(obj).touch()
    scene = gm.Scene(obj, free_object=True, hand=available("gymnasium-robotics-touch"))
    hold_on_support(scene)
    scene.set_hand_pose(*gm.facing_pose(obj, clearance=0.01))
    scene.set_posture(gm.open_posture())
    scene.set_target(gm.closed_posture())
    scene.run(1.0)
    felt = [gm.SEGMENTS[i] for i in np.flatnonzero(scene.touch() > 0)]
    touching = list(scene.tactile().segments)
    assert len(touching) >= 5 and sorted(felt) == sorted(touching)
    np.testing.assert_array_equal(gm.pcp_mask(felt), gm.pcp_mask(touching))


def test_pictures_draw_the_postures_on_the_hand_they_belong_to():
    """Another hand's postures are drawn on that hand, seen as ours is: the palm turned as ours."""
    import graspmanifold as gm
    from graspmanifold.sim.render import render_postures

    available("gymnasium-robotics")
    postures = np.array([gm.open_posture(), gm.closed_posture()])
    theirs, ours = render_postures(postures, 64, hand="gymnasium-robotics"), render_postures(postures, 64)
    covered = (theirs < 250).any(axis=3).mean(axis=(1, 2))  # the hand's share of the white picture
    assert np.all(covered > 0.05) and np.abs(theirs[0].astype(int) - theirs[1]).mean() > 5
    assert np.abs(theirs.astype(int) - ours).mean() > 5  # their grey hand, not our model
    # seen alike: the hand covers about the same part of the picture as ours does
    np.testing.assert_allclose(covered, (ours < 250).any(axis=3).mean(axis=(1, 2)), atol=0.1)


def test_menagerie_is_read_from_the_checkout_menagerie_root_names(tmp_path, monkeypatch):
    """`hand="menagerie"` reads $MENAGERIE_ROOT/shadow_hand/right_hand.xml (here a stand-in with Menagerie's names
    written from our model: no third-party file in the tests) and says what is missing when it is not there."""
    from graspmanifold.sim.hand_models import _described

    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    _described.cache_clear()
    try:
        with pytest.raises(InvalidInput, match="no such file: .*shadow_hand/right_hand.xml"):
            hand_model("menagerie")
        (tmp_path / "shadow_hand").mkdir()
        (tmp_path / "shadow_hand" / "right_hand.xml").write_text(Path(ours_renamed(tmp_path)).read_text())
        hand = hand_model("menagerie")
        assert hand.name == "menagerie" and hand.finger_joints[0] == "rh_FFJ4" and hand.palm == "rh_palm"
    finally:
        _described.cache_clear()


def test_the_command_takes_a_hand_by_name_or_path(tmp_path, capsys):
    from graspmanifold.cli import main

    assert main(["demo", "--object", "cylinder", "--seconds", "0.5", "--hand", ours_renamed(tmp_path)]) == 0
    assert "ffdistal" in capsys.readouterr().out  # touch read in the paper's segments, whatever the model's names
    with pytest.raises(SystemExit, match=r"error: hand must be one of \('shadow-primitives', 'gymnasium-robotics'"):
        main(["demo", "--hand", "allegro"])
