"""The MJCF hand against the kinematics sheet and the library's naming tables."""

import itertools

import mujoco
import numpy as np
import pytest
from sheet import SHEET, TIPS, WRIST_RANGES, sheet_fk

import graspmanifold as gm
from graspmanifold.sim.hand import JOINT_SEGMENT


@pytest.fixture(scope="module")
def hand():
    model = gm.load_hand()
    return model, mujoco.MjData(model)


def test_joints_are_the_24_named_hinges_in_order(hand):
    model, _ = hand
    assert model.njnt == 24
    assert tuple(model.joint(i).name for i in range(model.njnt)) == gm.HAND_JOINTS
    assert all(model.jnt_type[i] == mujoco.mjtJoint.mjJNT_HINGE for i in range(24))
    assert len(gm.FINGER_JOINTS) == 22 and gm.HAND_JOINTS[2:] == gm.FINGER_JOINTS


def test_joint_ranges_are_exactly_the_sheets(hand):
    model, _ = hand
    expected = {**WRIST_RANGES, **{joint: rng for (_, _, _, joint, _, rng) in SHEET.values()}}
    assert gm.JOINT_RANGES == expected
    for name, (lo, hi) in expected.items():
        assert tuple(model.joint(name).range) == (lo, hi), name
        assert model.jnt_limited[model.joint(name).id]


def test_bodies_axes_and_tip_sites_follow_the_sheet(hand):
    model, _ = hand
    for body, (parent, pos, quat, joint, axis, _) in SHEET.items():
        b = model.body(body)
        assert model.body(b.parentid[0]).name == parent
        np.testing.assert_allclose(b.pos, pos, atol=1e-9)
        np.testing.assert_allclose(b.quat, np.asarray(quat) / np.linalg.norm(quat), atol=1e-6)
        j = model.joint(joint)
        assert j.bodyid[0] == b.id
        np.testing.assert_allclose(j.axis, np.asarray(axis) / np.linalg.norm(axis), atol=1e-6)
    for site in TIPS:
        assert model.site(site).bodyid[0] == model.body(TIPS[site][0]).id


def test_forward_kinematics_match_the_sheet_for_random_postures(hand, rng):
    model, data = hand
    palm = model.body("palm").id
    for _ in range(25):
        joints = {name: rng.uniform(*gm.JOINT_RANGES[name]) for name in gm.HAND_JOINTS}
        for name, value in joints.items():
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_kinematics(model, data)
        rot, origin = data.xmat[palm].reshape(3, 3), data.xpos[palm]
        origins, tips = sheet_fk(joints)
        for body, expected in origins.items():
            got = rot.T @ (data.xpos[model.body(body).id] - origin)
            assert np.linalg.norm(got - expected) < 1e-3, body
        for site, expected in tips.items():
            got = rot.T @ (data.site_xpos[model.site(site).id] - origin)
            assert np.linalg.norm(got - expected) < 1e-3, site


def test_actuators_drive_twenty_dofs_with_j1_j2_coupled(hand):
    model, _ = hand
    assert tuple(model.actuator(i).name for i in range(model.nu)) == gm.ACTUATORS
    assert model.nu == 20
    for finger in ("FF", "MF", "RF", "LF"):
        actuator = model.actuator(f"A_{finger}J0")
        assert actuator.trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
        tendon = actuator.trnid[0]
        first, count = model.tendon_adr[tendon], model.tendon_num[tendon]
        joints = {model.joint(model.wrap_objid[first + k]).name for k in range(count)}
        assert joints == {f"{finger}J1", f"{finger}J2"}


def test_joint_segment_table_matches_the_model(hand):
    model, _ = hand
    has_geom = {model.body(model.geom_bodyid[g]).name for g in range(model.ngeom)}
    for joint, segment in JOINT_SEGMENT.items():
        body = model.body(model.joint(joint).bodyid[0])
        while body.name not in has_geom:  # follow the finger's chain outwards
            children = [b for b in range(model.nbody) if model.body_parentid[b] == body.id]
            assert len(children) == 1
            body = model.body(children[0])
        assert body.name == segment, joint
    assert set(gm.SEGMENTS) == has_geom


def test_masses_are_sensible(hand):
    model, _ = hand
    finger_segments = [s for segs in gm.FINGER_SEGMENTS.values() for s in segs]
    masses = np.array([model.body(s).mass[0] for s in finger_segments])
    assert np.all((masses > 0.005) & (masses < 0.1))
    total = sum(model.body(i).mass[0] for i in range(model.nbody))
    assert 1.5 < total < 5.0


def test_neighbouring_segments_never_collide(rng):
    scene = gm.Scene("sphere")
    scene.set_hand_pose([0.5, 0.0, 0.0], [1, 0, 0, 0])  # far from the object
    model, data = scene.model, scene.data
    parent = {model.body(i).name: model.body(model.body_parentid[i]).name for i in range(model.nbody)}
    neighbours = set()
    for seg in gm.SEGMENTS:
        up = parent[seg]
        while up not in gm.SEGMENTS and up != "world":
            up = parent[up]
        neighbours.add(frozenset((seg, up)))
    limits = gm.finger_limits()
    for _ in range(30):
        scene.set_posture(rng.uniform(limits[:, 0], limits[:, 1]))
        for c in range(data.ncon):
            pair = frozenset(model.body(model.geom_bodyid[g]).name for g in data.contact.geom[c])
            assert pair not in neighbours
    straight = np.zeros(22)
    scene.set_posture(straight)
    assert data.ncon == 0


def test_hand_segments_are_the_tactile_segments():
    assert set(gm.DISTAL_SEGMENTS) <= set(gm.SEGMENTS)
    assert len(set(itertools.chain(*gm.FINGER_SEGMENTS.values()))) == 16


def test_the_hand_model_describes_the_hand_in_one_object():
    """The open and closed postures are the MJCF's keyframes, the J1/J2 coupling is its fixed tendons."""
    hand = gm.SHADOW_HAND
    assert hand.finger_joints == gm.FINGER_JOINTS and hand.segments == gm.SEGMENTS
    np.testing.assert_array_equal(hand.keyframe_posture("open"), gm.open_posture())
    np.testing.assert_array_equal(hand.keyframe_posture("closed"), gm.closed_posture())
    coupling = hand.coupling()
    ff0 = coupling[gm.ACTUATORS.index("A_FFJ0")]
    assert ff0[gm.FINGER_JOINTS.index("FFJ1")] == ff0[gm.FINGER_JOINTS.index("FFJ2")] == 1 and ff0.sum() == 2
    assert not coupling[:2].any()  # the wrist drives no finger joint
    assert (coupling.sum(axis=0) == 1).all()  # every finger joint is driven by one actuator
    with pytest.raises(gm.InvalidInput, match="no keyframe 'grip'"):
        hand.keyframe_posture("grip")


def test_the_hand_alone_writes_out_as_mjcf_that_compiles(tmp_path):
    """Writing out the hand alone had no documented function (`SHADOW_HAND.spec().to_xml()` was found with dir())."""
    import mujoco

    from graspmanifold.sim.hand_models import hand_model

    text = gm.SHADOW_HAND.to_xml()
    model = mujoco.MjModel.from_xml_string(text)
    assert model.njnt == gm.SHADOW_HAND.model.njnt and model.nu == gm.SHADOW_HAND.model.nu
    path = tmp_path / "my_hand.xml"
    path.write_text(text)
    assert hand_model(path).finger_joints == gm.SHADOW_HAND.finger_joints  # read back as a hand file
