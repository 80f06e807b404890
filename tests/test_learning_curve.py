"""The learning curve: the rounds of the controller's own grasps add only the held final grasps of the selection
split; every seed makes its own experience and the claims pool the seeds."""

import numpy as np
import pytest

from graspmanifold.sim.hand import N_FINGER_JOINTS


def test_the_rounds_add_only_the_held_final_grasps_of_the_selection_split_on_every_seed(tmp_path, monkeypatch):
    from graspmanifold.studies import learning_curve
    from graspmanifold.studies.learning_curve import (
        LearningCurveConfig,
        LearningCurveStudy,
        subset,
    )

    given, rounds = [], []
    real_test, real_evaluate = LearningCurveStudy.test, LearningCurveStudy.evaluate

    def test(self, tag, postures, types, seed=0, trained_on=None):
        given.append((tag, postures.copy(), seed))
        return real_test(self, tag, postures, types, seed, trained_on)

    def evaluate(self, split, method, *args, **kwargs):
        results = real_evaluate(self, split, method, *args, **kwargs)
        if method.startswith("own_round"):
            rounds.append((split, results))
        return results

    monkeypatch.setattr(LearningCurveStudy, "test", test)
    monkeypatch.setattr(LearningCurveStudy, "evaluate", evaluate)
    study = LearningCurveStudy(LearningCurveConfig(quick=True, sizes=(3,), rounds=1, seeds=2, workers=1,
                                                   controllers=("som_paper",), out=str(tmp_path)))
    info = study.run()
    assert [seed for _, _, seed in given] == [0, 0, 0, 1, 1, 1] and len(rounds) == 2
    (split, selection), _ = rounds
    assert split == "selection"
    for key, result in selection.items():  # the round grasped selection poses only, none of the test split
        poses = np.array([t.grid_pose for t in result.trials])
        assert all(any(np.array_equal(p, q) for q in study.split["selection"][key]) for p in poses)
        assert not any(np.array_equal(p, q) for p in poses for q in study.split["test"][key])
    (_, start, _), (_, grown, _), (null_tag, null_given, _), (tag_1, start_1, _) = given[:4]
    _, sets = study.experience()
    assert np.array_equal(start, subset(sets, 3)[0])
    assert tag_1 == "n3_seed1" and np.array_equal(start_1, subset(study.experience(1)[1], 3, seed=1)[0])
    assert not np.array_equal(start, start_1)  # another seed: another generator's experience
    held = [t.posture for key in selection for t in selection[key].trials if t.valid and t.hold]
    assert np.array_equal(grown, np.concatenate([start, np.array(held).reshape(-1, N_FINGER_JOINTS)]))
    assert info["added"][0] == [len(held)] and set(info["by_round"]) == {"0", "1"} and info["seeds"] == [0, 1]
    for row in info["comparisons"]:  # each claim pools the seeds' pairs and carries every seed's difference
        signs = np.sign(row["seeds"])
        assert len(signs) == 2 and row["sign_holds"] == (signs[0] == signs[1] != 0)
    trials = sum(len(r.trials) for r in study.results[("test", "som_paper_n3")].values())  # seed 0's
    assert info["comparisons"][0]["n"] <= 2 * trials and info["by_size"]["3"]["som_paper"][1] > trials
    assert null_tag == "n3_null" and np.array_equal(null_given, start)  # the null map: these postures, scrambled
    assert learning_curve.own_grasps(selection).shape == (len(held), N_FINGER_JOINTS)
    # the report again from study.json, with the ceiling quoted from the planned-grasp study's report
    learning_curve.main(["--render", "--quick", "--sizes", "3", "--rounds", "1", "--seeds", "2", "--controllers",
                         "som_paper", "--out", str(tmp_path)])
    report = (tmp_path / "learning_curve.md").read_text()
    top = learning_curve.ceiling()
    assert top is not None and "## The ceiling: a perfect recall" in report
    held, n = top["approach-recall"][0]
    assert n >= 300 and f"approach-recall (planned-grasp study) | {100 * held / n:.0f} %" in report


def test_the_ceiling_is_the_planned_grasp_studys_perfect_recall_or_none(tmp_path):
    import json

    from graspmanifold.studies.learning_curve import ceiling

    assert ceiling(tmp_path / "absent.json") is None
    planned = json.loads(open("docs/studies/planned_grasps.json").read())
    top = ceiling()
    assert top["levels"] == [0.0, 0.01]
    assert top["approach-recall"][0] == planned["ceiling"]["approach-recall"]  # every plan at 0 cm
    assert top["open-loop"][1] == planned["by_level"]["open-loop"][planned["levels"].index(0.01)]


@pytest.mark.parametrize("field, value", [("sizes", (200, 48)), ("sizes", (0, 48)), ("sizes", (True,)),
                                          ("rounds", -2), ("every", -1), ("seeds", -1), ("seeds", 11),
                                          ("controllers", ("som_magic",)), ("controllers", ("som_paper", "som_paper"))])
def test_bad_study_settings_are_refused_by_name(field, value):
    from graspmanifold.base.errors import InvalidInput
    from graspmanifold.studies.learning_curve import LearningCurveConfig
    from graspmanifold.studies.uncertainty import UncertaintyStudyConfig

    config = UncertaintyStudyConfig if field == "every" else LearningCurveConfig
    with pytest.raises(InvalidInput, match=field):
        config(**{field: value})
