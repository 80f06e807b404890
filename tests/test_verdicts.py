"""Every row of the verdict table follows its stated rule (`graspmanifold.verdicts`)."""

from __future__ import annotations

import copy

import pytest

from graspmanifold.verdicts import NOT_REPRODUCED, PARTLY, REPRODUCED, judge_claims


def _object(min_deg: float, max_deg: float) -> dict:
    return {"dataset_size": 5000, "candidates": 5000, "clusters": {"between_deg": 40.0, "starts": 3}, "starting_postures": 4,
            "nearest_neighbour_deg": {"min": 0.2}, "border_distance_ratio": 2.0, "evaluation_on_unsupported_nodes": 0.7,
            "map": {"distance_min_deg": min_deg, "distance_max_deg": max_deg, "distance_cv": 0.9,
                    "unsupported_by_training": 100, "unsupported_by_evaluation": 600},
            "resumed_map": {"distance_min_deg": min_deg, "distance_max_deg": max_deg / 2, "distance_cv": 0.5,
                            "unsupported_by_training": 300, "unsupported_by_evaluation": 500}}


def _summary() -> dict:
    """A run that reproduces every claim."""
    runs = [{"steps_deg": [3.0, 4.0, 3.0], "crosses_unsupported": True, "middle_intermediate": [True, True]}] * 2
    return {"objects": {"box": _object(0.02, 55.0), "cylinder": _object(0.013, 60.0), "sphere": _object(0.007, 70.0)},
            "fig5": {"object": "cylinder", "runs": runs}}


def _verdict(summary: dict, claim_start: str) -> tuple[str, str]:
    row = next(v for v in judge_claims(summary) if v.claim.startswith(claim_start))
    return row.verdict, row.cause


CHANGES = {  # claim -> (change for one object, change for every object)
    "dataset sizes": ("dataset_size", 1000),
    "minimum inter-node": ("map.distance_min_deg", 1.0),
    "maximum inter-node": ("map.distance_max_deg", 30.0),
    "clusters and borders": ("border_distance_ratio", 1.1),
    "evaluation grasps": ("evaluation_on_unsupported_nodes", 0.3),
    "resumed learning homogenises": ("resumed_map.distance_cv", 2.0),
    "after resumed learning": ("resumed_map.unsupported_by_training", 50),
    "the resumed map represents": ("resumed_map.unsupported_by_evaluation", 700),
}


def _set(o: dict, key: str, value: float) -> None:
    *path, last = key.split(".")
    for part in path:
        o = o[part]
    o[last] = value


def test_every_claim_is_reproduced_by_a_run_that_meets_every_rule():
    verdicts = judge_claims(_summary())
    assert len(verdicts) == 9
    assert {v.verdict for v in verdicts} == {REPRODUCED}
    assert all(v.rule and v.paper and v.ours and not v.cause for v in verdicts)


@pytest.mark.parametrize("claim", sorted(CHANGES))
def test_a_rule_that_fails_for_one_object_gives_partly_and_for_all_not_reproduced(claim):
    key, value = CHANGES[claim]
    one = copy.deepcopy(_summary())
    _set(one["objects"]["box"], key, value)
    assert _verdict(one, claim)[0] == PARTLY
    every = copy.deepcopy(_summary())
    for o in every["objects"].values():
        _set(o, key, value)
    assert _verdict(every, claim)[0] == NOT_REPRODUCED


def test_the_minimum_distance_rule_is_a_factor_of_three_both_ways_and_names_the_cause():
    summary = _summary()
    summary["objects"]["box"]["map"]["distance_min_deg"] = 0.013 * 2.9
    assert _verdict(summary, "minimum")[0] == REPRODUCED
    summary["objects"]["box"]["map"]["distance_min_deg"] = 0.013 / 3.1
    verdict, cause = _verdict(summary, "minimum")
    assert verdict == PARTLY and "box 0.2°" in cause


def test_the_maximum_distance_rule_is_twenty_percent():
    summary = _summary()
    summary["objects"]["cylinder"]["map"]["distance_max_deg"] = 63.45 * 1.19
    assert _verdict(summary, "maximum")[0] == REPRODUCED
    summary["objects"]["cylinder"]["map"]["distance_max_deg"] = 63.45 * 0.79
    verdict, cause = _verdict(summary, "maximum")
    assert verdict == PARTLY and "cylinder: 3 of 4 starting postures kept grasps, cluster means 40° apart" in cause


def test_fig5_needs_border_crossings_and_intermediate_middle_nodes():
    summary = _summary()
    summary["fig5"]["runs"] = [{"steps_deg": [6, 54, 8], "crosses_unsupported": True,
                                "middle_intermediate": [True, False]}] * 2
    assert _verdict(summary, "unsupported inter-cluster")[0] == PARTLY
    summary["fig5"]["runs"] = [{"steps_deg": [6, 54, 8], "crosses_unsupported": True,
                                "middle_intermediate": [False, False]}] * 2
    assert _verdict(summary, "unsupported inter-cluster")[0] == NOT_REPRODUCED
    summary["fig5"]["runs"] = [{"steps_deg": [3, 3, 3], "crosses_unsupported": False,
                                "middle_intermediate": [True, True]}] * 2
    verdict, cause = _verdict(summary, "unsupported inter-cluster")
    assert verdict == NOT_REPRODUCED and "no 1 x 4 run" in cause


def test_claims_about_the_paper_objects_are_left_out_for_other_objects():
    summary = {"objects": {"ring_m": _summary()["objects"]["box"]}}
    claims = [v.claim for v in judge_claims(summary)]
    assert not any(c.startswith(("dataset", "minimum", "maximum")) for c in claims)
    assert len(claims) == 5
