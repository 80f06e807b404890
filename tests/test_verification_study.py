"""The verification part of the protocols study (`studies.verification`) on a small configuration."""

import numpy as np

from graspmanifold.studies.verification import ablate, ablations, verify_object


def test_an_objects_verified_grasps_hold_under_their_protocol_and_the_base_ablation_is_the_plain_replay():
    result = verify_object(("cube", "hold-test", 2))
    assert "error" not in result and result["held_hold-test"].all()  # verified under ours: held when replayed under ours
    assert len(result["q1"]) == 2 and (result["q1"] >= 0).all() and (result["penetration"] <= 0.003).all()
    assert set(result["grasp_type"]) <= {"power", "precision", "tripod", "lateral"} and len(result["design"]) == 2
    assert 2 <= int(result["candidates"]) and float(result["seconds"]) > 0
    base = ablate(("cube", "the protocol as it is", 2))  # the same grasps, DexGraspBench's main version unchanged
    assert np.array_equal(base["held"], result["held_dexgraspbench"])
    assert list(ablations())[0] == "the protocol as it is" and len(ablations()) == 6



def squares(task):
    return {"square": np.array([task[0] ** 2])}


def test_a_studys_tasks_are_kept_each_under_its_key_and_taken_up_again(tmp_path):
    """`StudyRun.keep_each`, the study's one way to keep many results: a rerun computes none of them again; a task
    kept by other code (a file of another key) is computed again."""
    from graspmanifold.base.io import load_npz, save_npz
    from graspmanifold.studies.runner import StudyRun

    read = lambda path: load_npz(path, "squares", {})  # noqa: E731
    write = lambda arrays, path, meta: save_npz(path, "squares", arrays, meta)  # noqa: E731
    study = StudyRun(tmp_path, workers=1)
    first = study.keep_each("kept", [(2,), (3,)], squares, read, write, lambda task, r: f"{task}: {r['square']}")
    assert [int(r["square"][0]) for r in first.values()] == [4, 9] and study.computed == 2
    again = StudyRun(tmp_path, workers=1)
    assert {t: int(r["square"][0]) for t, r in again.keep_each("kept", [(3,), (2,)], squares, read, write).items()} \
        == {(3,): 9, (2,): 4}
    assert again.computed == 0 and again.reused == 2
