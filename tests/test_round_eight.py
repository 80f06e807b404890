"""Hardening, round eight (issue 88): what issues 84 and 88 added, tried as a tester would (RELIABILITY.md's round
eight table). Each poor case fixed has its test here, failing before its fix."""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.judging.protocols import get_protocol


def _steered_without_flange():
    from dataclasses import replace

    from graspmanifold.control.controller import CONTROLLERS, PALM_TOUCH
    from graspmanifold.trials.setup import TrialSetup

    return TrialSetup(object="box", params=replace(CONTROLLERS["paper"], palm=PALM_TOUCH))


def _config(**fields):
    from graspmanifold.studies.planned_grasps import PlannedStudyConfig

    return PlannedStudyConfig(**fields)


def _drawn(count):
    from graspmanifold.studies.planned_grasps import drawn_plans

    return drawn_plans(np.array([True, False, True]), count, 0, 2, "box")


def _headroom(*args):
    from graspmanifold.studies.planned_grasps import Headroom

    return Headroom(*args)


def _grid(poses):
    from graspmanifold.studies.dataset import trial_grid

    return trial_grid("quick", poses, gm.get_object("box"))


def _difference():
    from graspmanifold.trials.stats import bootstrap_difference

    return bootstrap_difference([1, 0, 1], [1, 1], [0, 1, 2])


def _json(value):
    from graspmanifold.base.io import json_text

    return json_text(value)


def _study_into(out):
    from graspmanifold.studies.runner import StudyRun

    return StudyRun(out, 1)


@pytest.mark.parametrize("call, message", [
    (_difference, r"outcomes_a, outcomes_b must be outcomes of the same trials.*outcomes_a \(3,\), outcomes_b \(2,\)"),
    (lambda: _config(plans=10 ** 9), r"plans must be a whole number in 1 \.\.\. 1000, got 1000000000"),
    (lambda: _drawn(-1), "count must be"),
    (lambda: _grid(0), "poses must be a positive whole number"),
    (lambda: _json({"kept": {1, 2}}), "a result file holds dictionaries, lists, strings, numbers and None"),
    (_steered_without_flange, r"ControllerParams.palm steers the palm on an arm, but these trials have none"),
    (lambda: _headroom("nope", ("open-loop",), (0.0,)), "Headroom arm must be one of"),
    (lambda: _headroom("open-loop", ("approach",), ()), "a Headroom needs a ceiling and levels"),
    (lambda: _study_into(""), "--out must name a folder, got an empty path"),
    (lambda: get_protocol("lift").check_arm("an arm", 0.1), "palm must be a FlangeLimits or None, got str"),
    (lambda: get_protocol("lift").check_arm(None, float("nan")), "object_mass must be a finite number > 0"),
    (lambda: gm.generate_postures("sphere", 1, params=gm.GeneratorParams(hand="gymnasium-robotics"),
                                  hand="shadow-primitives"), r"hand='shadow-primitives' \(the 0.1 keyword\) and "
                                                             "params.hand='gymnasium-robotics' disagree"),
])
def test_round_eight_refusals_name_what_is_wrong(call, message):
    """Poor cases: a raw numpy error for outcomes of two lengths, a billion plans per object taken without a word, a
    negative draw or an empty grid ending in numpy's errors, a set in a result file a TypeError, palm steering with no
    arm to steer moving nothing, a headroom of arms no study has failing at its report, an empty --out writing into
    the current folder, the old hand keyword silently overriding the new one."""
    with pytest.warns(DeprecationWarning) if "keyword" in message else nullcontext():
        with pytest.raises(gm.InvalidInput, match=message):
            call()


def test_result_files_take_arrays_and_a_corrupt_one_is_named(tmp_path):
    """Poor cases: `json_text` of a NumPy array raised a TypeError; `read_json` of a binary file or of a million
    nested brackets raised UnicodeDecodeError and RecursionError."""
    from graspmanifold.base.io import json_text, read_json

    assert json_text({"held": np.array([1.0, np.inf])}, indent=None) == '{"held": [1.0, "Infinity"]}'
    (tmp_path / "binary.json").write_bytes(b"\xff\xfe\x00garbage")
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    for name in ("binary.json", "deep.json"):
        with pytest.raises(gm.InvalidInput, match=f"{name}.* is not JSON"):
            read_json(tmp_path / name, name)


def test_a_headroom_the_ceiling_never_opened_says_so():
    """Poor case: a family whose ceiling held no more than its floor reported 'nan % [nan, nan]'."""
    from graspmanifold.studies.planned_grasps import share_text
    from graspmanifold.trials.stats import headroom_share

    assert share_text(headroom_share([1, 0], [1, 1], [1, 1], [0, 1]).to_dict()) == ("no headroom: the ceiling held no "
                                                                                   "more than the floor")
    assert share_text(headroom_share([1, 1, 0, 0], [0, 0, 0, 0], [1, 1, 1, 1], [0, 1, 2, 3]).to_dict()).startswith(
        "50 % [")


# Round eight, second part: what issue 85 added (the rooms, declared read-outs, one description of a set-up, the
# trials' columns from one spec)


def test_compare_of_what_is_not_a_result_names_the_argument():
    """Poor: `gm.compare([1, 2], [1, 2])` ended in "'list' object has no attribute 'trials'"."""
    with pytest.raises(gm.InvalidInput, match="a must be one method's trials .* got list"):
        gm.compare([1, 2], [1, 2])


def test_a_set_up_subclass_with_a_field_the_key_does_not_describe_is_refused():
    """Poor: a subclass of `TrialSetup` with a field of its own got the key of its parent: two set-ups that differ
    in it shared a key, so a resumed run returned the other's trials."""
    import dataclasses

    from graspmanifold.trials.setup import TrialSetup

    @dataclasses.dataclass(frozen=True, eq=False, kw_only=True)
    class Stiffer(TrialSetup):
        stiffness: float = 1.0

    with pytest.raises(gm.InvalidInput, match=r"Stiffer has fields the trials' key does not describe: \['stiffness'\]"):
        Stiffer(object="box", stiffness=2.0).key(np.zeros((1, 4)), 0)


@pytest.mark.parametrize("damage", ["narrow", "text"])
def test_a_trials_file_with_a_column_of_another_width_or_kind_is_named_corrupt(tmp_path, damage):
    """Poor: a trials file whose `touching` column had 3 segments instead of 19 loaded as if whole; one whose
    epsilon was text ended in "could not convert string to float", the file unnamed."""
    from graspmanifold.trials.evaluation import EvaluationResult
    from graspmanifold.trials.record import Trial

    trial = Trial(grid_pose=np.zeros(4), posture=np.zeros(22), touching=np.zeros(19, dtype=bool), epsilon=0.1,
                  hold=True, hold_displacement=0.0, time_to_grasp=1.0, matches=0)
    path = EvaluationResult(gm.get_object("box"), "none", "custom", 0, [trial]).save(tmp_path / "trials.npz")
    arrays = dict(np.load(path, allow_pickle=False))
    if damage == "narrow":
        arrays["touching"] = arrays["touching"][:, :3]
    else:
        arrays["epsilon"] = np.array(["a"])
    np.savez(tmp_path / "damaged.npz", **arrays)
    with pytest.raises(gm.InvalidInput, match=r"damaged.npz: (touching must be \(1, 19\)|epsilon must hold float)"):
        EvaluationResult.load(tmp_path / "damaged.npz")


@pytest.mark.parametrize("readouts, message", [
    ("matches", "must be a tuple of names"), ((1, 2), "must be a tuple of names"),
    (("palm_offset",), "needs a bool `moves_palm`"), (("object_estimate",), "has no such member")])
def test_a_controllers_declaration_is_checked_by_name(readouts, message):
    """Good: each bad declaration of read-outs is refused when the controller is made, the member named."""
    from graspmanifold.control.controller import declared_readouts

    class Declaring:
        def __init__(self):
            self.n, self.readouts, self.palm_offset = 2, readouts, np.zeros((2, 3))

    with pytest.raises(gm.InvalidInput, match=message):
        declared_readouts(Declaring())


@pytest.mark.parametrize("given, message", [("folder", "is a folder"), ("missing.npz", "does not exist")])
def test_experience_given_a_folder_or_no_file_names_the_flag(tmp_path, given, message):
    """Poor: `evaluate --experience FOLDER` (a trained file, new in 0.3) ended in "path: FOLDER is a directory", the
    flag unnamed, and a missing file in "path: no such file"."""
    from graspmanifold.cli import main

    (tmp_path / "folder").mkdir()
    target = str(tmp_path / given)
    with pytest.raises(SystemExit, match=f"--experience {target} {message}: give none, one of"):
        main(["evaluate", "--object", "box", "--experience", target, "--out", str(tmp_path / "run")])
