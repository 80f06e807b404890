"""Posture validation, conversions and the Partial Contact Posture mask (Eq. 1)."""

import numpy as np
import pytest

import graspmanifold as gm


def idx(*joints):
    return [gm.FINGER_JOINTS.index(j) for j in joints]


def test_validate_rejects_wrong_length_and_non_finite():
    with pytest.raises(ValueError, match=r"shape \(22,\)"):
        gm.validate_posture(np.zeros(21))
    with pytest.raises(ValueError, match=r"shape \(22,\)"):
        gm.validate_posture(np.zeros((2, 22)))
    bad = np.zeros(22)
    bad[5] = np.nan
    with pytest.raises(ValueError, match="MFJ3"):
        gm.validate_posture(bad)
    bad[5] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        gm.validate_posture(bad)


def test_limits_check_clip_and_within():
    p = np.zeros(22)
    p[idx("FFJ3")] = 2.0
    assert not gm.within_limits(p)
    with pytest.raises(ValueError, match="FFJ3"):
        gm.validate_posture(p, check_limits=True)
    clipped = gm.clip_posture(p)
    assert clipped[idx("FFJ3")] == pytest.approx(1.5708)
    assert gm.within_limits(clipped)


def test_dict_round_trip_and_errors(rng):
    limits = gm.finger_limits()
    p = rng.uniform(limits[:, 0], limits[:, 1])
    np.testing.assert_array_equal(gm.dict_to_posture(gm.posture_to_dict(p)), p)
    d = gm.posture_to_dict(p)
    with pytest.raises(ValueError, match="unknown joint names"):
        gm.dict_to_posture({**d, "XXJ9": 0.0})
    del d["THJ1"]
    with pytest.raises(ValueError, match="missing"):
        gm.dict_to_posture(d)


def test_ctrl_couples_j1_and_j2(rng):
    limits = gm.finger_limits()
    p = rng.uniform(limits[:, 0], limits[:, 1])
    ctrl = gm.posture_to_ctrl(p, wrist=(0.1, -0.2))
    names = list(gm.ACTUATORS)
    assert ctrl.shape == (20,)
    assert ctrl[names.index("A_WRJ2")] == 0.1 and ctrl[names.index("A_WRJ1")] == -0.2
    for finger in ("FF", "MF", "RF", "LF"):
        j2, j1 = idx(f"{finger}J2", f"{finger}J1")
        assert ctrl[names.index(f"A_{finger}J0")] == pytest.approx(p[j2] + p[j1])
    for joint in ("FFJ4", "FFJ3", "LFJ5", "THJ5", "THJ1"):
        assert ctrl[names.index(f"A_{joint}")] == p[idx(joint)[0]]
    assert gm.SHADOW_HAND.ctrl_matrix.sum() == 22  # every joint drives exactly one actuator
    with pytest.raises(ValueError, match="wrist"):
        gm.posture_to_ctrl(p, wrist=(0.0,))


def test_pcp_mask_follows_eq1():
    assert gm.pcp_mask([]).sum() == 0
    assert gm.pcp_mask(["palm", "forearm", "wrist"]).sum() == 0
    # a distal contact specifies the whole finger
    np.testing.assert_array_equal(np.flatnonzero(gm.pcp_mask(["ffdistal"])), idx("FFJ4", "FFJ3", "FFJ2", "FFJ1"))
    # a middle contact specifies the joints up to the middle segment, not J1
    np.testing.assert_array_equal(np.flatnonzero(gm.pcp_mask(["mfmiddle"])), idx("MFJ4", "MFJ3", "MFJ2"))
    # proximal: J4 (the knuckle carries no geometry of its own) and J3
    np.testing.assert_array_equal(np.flatnonzero(gm.pcp_mask(["rfproximal"])), idx("RFJ4", "RFJ3"))
    np.testing.assert_array_equal(np.flatnonzero(gm.pcp_mask(["lfmetacarpal"])), idx("LFJ5"))
    np.testing.assert_array_equal(np.flatnonzero(gm.pcp_mask(["thmiddle"])), idx("THJ5", "THJ4", "THJ3", "THJ2"))
    assert gm.pcp_mask(gm.DISTAL_SEGMENTS).all()
    # several contacts on one finger: the outermost decides; order does not matter
    np.testing.assert_array_equal(gm.pcp_mask(["ffproximal", "ffmiddle"]), gm.pcp_mask(["ffmiddle", "ffproximal"]))


def test_pcp_mask_rejects_unknown_segments():
    with pytest.raises(ValueError, match="unknown segment"):
        gm.pcp_mask(["ffdistal", "ffnail"])


def test_open_and_closed_postures_are_within_limits():
    assert gm.within_limits(gm.open_posture())
    assert gm.within_limits(gm.closed_posture())
