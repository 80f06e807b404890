"""Issue 85, the house: the three hubs cut into rooms (their old names answer with a warning), the controller's
read-outs declared and checked once, not read by `getattr` along the loop."""

import ast
import warnings
from pathlib import Path

import numpy as np
import pytest

from graspmanifold.base.errors import InvalidInput
from graspmanifold.base.moved import MOVED_NAMES
from graspmanifold.control.controller import READOUTS, BatchController, declared_readouts
from graspmanifold.sim.objects import get_object
from graspmanifold.sim.posture import open_posture
from graspmanifold.trials.episode import run_trials
from graspmanifold.trials.open_loop import OpenLoopController
from graspmanifold.trials.setup import TrialSetup

SRC = Path(__file__).resolve().parents[1] / "src" / "graspmanifold"


@pytest.mark.parametrize("module", ["judging.replay", "synthesis.generator", "trials.experience_pays",
                                    "judging.judge", "trials.episode"])
def test_every_name_that_left_a_hub_answers_there_with_a_warning_as_the_same_object(module):
    import importlib

    old = importlib.import_module(f"graspmanifold.{module}")
    for name, where in MOVED_NAMES[module].items():
        new_module, new_name = where.split(":")
        with pytest.warns(DeprecationWarning, match=f"{module}.{name} is now graspmanifold.{new_module}.{new_name}"):
            found = getattr(old, name)
        assert found is getattr(importlib.import_module(f"graspmanifold.{new_module}"), new_name)


def test_the_trial_face_gives_the_rooms_objects_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from graspmanifold.trials import episode, record, recording, setup, trial
    assert trial.TrialSetup is setup.TrialSetup and trial.Trial is record.Trial
    assert trial.run_trials is episode.run_trials and trial.record_trial is recording.record_trial
    assert trial.Episodes is episode.EpisodeWorlds


def test_the_trial_loop_reads_no_member_of_a_controller_by_getattr():
    """The loop read six members (`matches`, `winners`, `attempt`, `moves_palm`, `palm_offset`,
    `object_estimate`) by `getattr` with silent defaults: a second, undeclared contract."""
    tree = ast.parse((SRC / "trials" / "episode.py").read_text())
    calls = [node for node in ast.walk(tree) if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
             and node.func.id in ("getattr", "hasattr")]
    assert calls == [], [ast.unparse(call) for call in calls]


class Mine:
    """A user's controller that closes nothing and declares the queries it made."""

    readouts = ("matches",)

    def __init__(self, n, hand):
        self.n, self.control_period, self.initial = n, 0.02, open_posture(hand)
        self.done = np.zeros(n, dtype=bool)
        self.matches = np.full(n, 7)
        self.steps = 0

    def reset(self):
        self.done[:] = False

    def step(self, joints, segment_forces):
        self.steps += 1
        self.done[:] = self.steps >= 2
        return np.tile(self.initial, (self.n, 1))


class Unknown(Mine):
    readouts = ("matches", "confidence")


class Misshapen(Mine):
    readouts = ("matches", "attempt")

    def __init__(self, n, hand):
        super().__init__(n, hand)
        self.attempt = np.ones(n + 1, dtype=int)


class Undeclared(Mine):
    readouts = ()


def test_a_controllers_declared_readouts_are_recorded_and_the_undeclared_get_their_defaults():
    poses = np.array([[0.0, 0.0, 0.01, 0.0]])
    declared = run_trials(TrialSetup(object="box", controller=Mine, method="mine"), poses, [np.random.default_rng(0)])
    assert declared[0].matches == 7 and declared[0].attempts == 1
    silent = run_trials(TrialSetup(object="box", controller=Undeclared, method="undeclared"), poses,
                        [np.random.default_rng(0)])
    assert silent[0].matches == 0  # it has `matches`, but did not declare it


def test_a_bad_declaration_is_refused_when_the_controller_is_made():
    from graspmanifold.sim.hand import SHADOW_HAND

    with pytest.raises(InvalidInput, match=r"Unknown.readouts names \['confidence'\].*they read"):
        declared_readouts(Unknown(2, SHADOW_HAND))
    with pytest.raises(InvalidInput, match=r"Misshapen.attempt must be \(N,\) int for its 2 worlds, got shape \(3,\)"):
        declared_readouts(Misshapen(2, SHADOW_HAND))
    with pytest.raises(InvalidInput, match="Misshapen.attempt"):
        run_trials(TrialSetup(object="box", controller=Misshapen, method="misshapen"), np.zeros((0, 4)), [])
    assert declared_readouts(BatchController(3)) == frozenset(READOUTS)


def test_ours_declare_what_they_have():
    from graspmanifold.judging.plans import open_loop_grasp

    plan = open_loop_grasp(np.r_[0.0, -0.08, 0.0, 1.0, 0.0, 0.0, 0.0], open_posture())
    assert declared_readouts(OpenLoopController(2, plan)) == {"attempt", "palm_offset"}


def test_every_field_of_a_trial_is_a_column_of_its_file_from_one_spec(tmp_path):
    """`Trial` was saved column by column by hand in `evaluation.py` and read back the same way: a new field cost an
    edit in three places. Each field is now one `Column` (its file name, width, kind, what it is, and the value of
    a file written before it was kept)."""
    import dataclasses

    from graspmanifold.trials.evaluation import FIELDS, EvaluationResult
    from graspmanifold.trials.record import TRIAL_COLUMNS, Trial

    assert {f.name for f in dataclasses.fields(Trial)} == set(TRIAL_COLUMNS) | {"winners"}
    assert set(FIELDS) == {column.file for column in TRIAL_COLUMNS.values()} | {"winners"}
    poses = np.array([[0.0, 0.0, 0.01, 0.0], [0.01, 0.0, 0.01, 0.0]])
    trials = run_trials(TrialSetup(object="box", controller=Undeclared, method="mine"), poses,
                        [np.random.default_rng(i) for i in range(2)])
    result = EvaluationResult(get_object("box"), "mine", "custom", 0, trials)
    path = result.save(tmp_path / "trials.npz")
    again = EvaluationResult.load(path)
    for before, after in zip(trials, again.trials):
        for name in TRIAL_COLUMNS:
            assert np.array_equal(np.asarray(getattr(before, name)), np.asarray(getattr(after, name)), equal_nan=True) \
                if np.asarray(getattr(before, name)).dtype.kind == "f" else \
                np.array_equal(np.asarray(getattr(before, name)), np.asarray(getattr(after, name))), name
    arrays = dict(np.load(path, allow_pickle=False))
    older = {key: value for key, value in arrays.items() if key not in ("hold_time", "attempts", "first_contact")}
    np.savez(tmp_path / "older.npz", **older)  # its metadata member kept: a file written before the three columns
    read = EvaluationResult.load(tmp_path / "older.npz").trials[0]
    assert np.isnan(read.hold_time) and read.attempts == 1 and np.isnan(read.first_contact).all()


def test_a_set_up_is_described_once_and_every_field_has_its_entry():
    """`TrialSetup.key` and `TrialSetup.provenance` were parallel dicts that every new field had to enter in step.
    Both are made from `DESCRIPTION` now: every field has one entry, and what changes an outcome changes the key."""
    import dataclasses

    from graspmanifold.trials.setup import DESCRIPTION

    described = [name for entry in DESCRIPTION for name in entry.fields]
    assert sorted(described) == sorted(f.name for f in dataclasses.fields(TrialSetup)), "a field without its entry"
    assert len(described) == len(set(described))
    base = TrialSetup(object="box")
    poses = np.zeros((1, 4))
    same = [dataclasses.replace(base, method="another label"), dataclasses.replace(base, batch_size=8)]
    assert all(setup.key(poses, 0) == base.key(poses, 0) for setup in same)
    from graspmanifold import Noise, Regrasp

    changed = [dataclasses.replace(base, noise=Noise(joints=0.01)), dataclasses.replace(base, touch="sensors"),
               dataclasses.replace(base, regrasp=Regrasp(attempts=2)), dataclasses.replace(base, margin=True),
               dataclasses.replace(base, preshape=open_posture())]
    keys = {setup.key(poses, 0) for setup in changed} | {base.key(poses, 0), base.key(poses, 1)}
    assert len(keys) == len(changed) + 2
    made = base.provenance(0)
    assert list(made)[:3] == ["library_version", "object", "hand"] and made["method"] == "none"


def test_one_flag_names_what_the_controller_recalls_from_and_the_old_ones_answer(capsys, tmp_path):
    """What the controller recalls from was `--experience` (evaluate), `--manifold` (reproduce, dataset) and
    `--map`/`--som` (a trained file): now `--experience` on every command, a kind or a trained file; the old flags
    set the same value and say on stderr that they are old."""
    import argparse

    from graspmanifold.cli import build_parser, main
    from graspmanifold.studies.dataset import add_arguments

    parser = build_parser()
    assert parser.parse_args(["reproduce", "--experience", "ukr"]).manifold == "ukr"
    assert parser.parse_args(["reproduce", "--manifold", "ukr"]).manifold == "ukr"
    assert "--manifold is now --experience" in capsys.readouterr().err
    assert parser.parse_args(["reproduce"]).manifold == "som"
    dataset = argparse.ArgumentParser()
    add_arguments(dataset)
    assert dataset.parse_args(["folder", "--manifold", "linear"]).manifold == "linear"
    assert dataset.parse_args(["folder", "--experience", "ukr"]).manifold == "ukr"
    assert parser.parse_args(["evaluate", "--som", "map.npz", "--out", "run"]).map == "map.npz"
    assert "--som is now --experience FILE.npz" in capsys.readouterr().err
    with pytest.raises(SystemExit, match="--experience must be none, one of .*som.*or a trained file"):
        main(["evaluate", "--object", "box", "--experience", "bogus", "--out", str(tmp_path / "run")])
    with pytest.raises(SystemExit, match="both name a trained file"):
        main(["evaluate", "--object", "box", "--experience", "a.npz", "--map", "b.npz", "--out", str(tmp_path / "r")])


def test_a_trials_file_of_the_previous_version_loads_and_is_written_back_the_same(tmp_path):
    """tests/data/v0_2/evaluation.npz was written by main cf58c49, before the trials' columns came from one spec: it
    loads, and written again its arrays are the same bytes (the file format did not move)."""
    from graspmanifold.trials.evaluation import EvaluationResult

    old = Path(__file__).parent / "data" / "v0_2" / "evaluation.npz"
    result = EvaluationResult.load(old)
    assert len(result.trials) == 2 and sum(t.matches for t in result.trials) > 0
    again = result.save(tmp_path / "again.npz")
    before, after = np.load(old, allow_pickle=False), np.load(again, allow_pickle=False)
    arrays = [name for name in before.files if not name.startswith("__")]
    assert set(arrays) <= set(after.files)
    for name in arrays:
        assert before[name].dtype == after[name].dtype and before[name].tobytes() == after[name].tobytes(), name


def test_the_lifts_settings_live_on_its_stage():
    """`JudgingRules` held the lift stage's height and speed beside every other protocol's rules: a stage's own
    settings live on the stage now (`LiftStage`), and the arm's check and the protocol's sentence read them there."""
    from dataclasses import replace

    from graspmanifold.judging.protocols import JudgingProtocol, get_protocol
    from graspmanifold.judging.judge import JUDGING
    from graspmanifold.judging.stages import LiftStage
    from graspmanifold.sim.flange import FlangeLimits

    lift = get_protocol("lift")
    assert lift.rules.lift == LiftStage() and JUDGING.lift is None and lift.rules.needs_flange
    higher = JudgingProtocol("higher-lift", replace(lift.rules, stages=(LiftStage(height=0.3, speed=0.2),)))
    assert "raises the palm 0.3 m at 0.2 m/s" in higher.summary()
    with pytest.raises(InvalidInput, match="raises the palm 0.3 m, but the arm travels FlangeLimits.travel=0.25"):
        higher.check_arm(FlangeLimits(travel=0.25), 0.1)
    for bad in ({"speed": True}, {"height": 0.0}, {"speed": float("nan")}):
        with pytest.raises(InvalidInput, match="LiftStage"):
            LiftStage(**bad)


def test_a_som_takes_its_training_schedule_as_one_value():
    """`SOM(rows, cols, schedule=...)`: the paper's schedules (`PAPER`, `RESUME`) or one's own, as one value; the flat
    keywords stay, and the two ways at once are refused."""
    import graspmanifold as gm
    from graspmanifold.manifold.som import PAPER, RESUME, SOMSchedule

    resumed = gm.SOM(5, 5, schedule=RESUME)
    assert (resumed.epochs, resumed.learning_rate, resumed.sigma) == (RESUME.epochs, RESUME.learning_rate, RESUME.sigma)
    mine = gm.SOM(5, 5, schedule=SOMSchedule(7, (0.5, 0.1), (2.0, 0.5)))
    assert mine.epochs == 7 and gm.SOM(5, 5).epochs == PAPER.epochs
    with pytest.raises(InvalidInput, match="give the schedule once"):
        gm.SOM(5, 5, epochs=3, schedule=RESUME)
    with pytest.raises(InvalidInput, match="schedule must be a SOMSchedule"):
        gm.SOM(5, 5, schedule=(7, (0.5, 0.1), (2.0, 0.5)))
