"""The verification part of the protocols study (`studies.verification`) on a small configuration."""

import numpy as np

from graspmanifold.studies.verification import ablate, ablations, verify_object


def test_an_objects_verified_grasps_hold_under_their_protocol_and_the_base_ablation_is_the_plain_replay():
    result = verify_object(("cube", "ours", 2))
    assert "error" not in result and result["held_ours"].all()  # verified under ours: held when replayed under ours
    assert len(result["q1"]) == 2 and (result["q1"] >= 0).all() and (result["penetration"] <= 0.003).all()
    assert set(result["grasp_type"]) <= {"power", "precision", "tripod", "lateral"} and len(result["design"]) == 2
    assert 2 <= int(result["candidates"]) and float(result["seconds"]) > 0
    base = ablate(("cube", "the protocol as it is", 2))  # the same grasps, DexGraspBench's main version unchanged
    assert np.array_equal(base, result["held_dexgraspbench"])
    assert list(ablations())[0] == "the protocol as it is" and len(ablations()) == 6

