"""Issue 70, the house: control/ as its three ideas (control, judging, synthesis), the old import paths kept for
one release, the names that say what a thing is."""

import importlib
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.base.moved import MOVED_MODULES


@pytest.mark.parametrize("old", sorted(MOVED_MODULES))
def test_a_moved_module_imports_by_its_old_name_as_the_new_module_with_a_warning(old):
    new = importlib.import_module(f"graspmanifold.{MOVED_MODULES[old]}")
    sys.modules.pop(f"graspmanifold.{old}", None)
    with pytest.warns(DeprecationWarning, match=f"graspmanifold.{old} moved to graspmanifold.{MOVED_MODULES[old]}"):
        module = importlib.import_module(f"graspmanifold.{old}")
    assert module is new  # the same classes and registries, not a copy


def test_from_imports_of_old_paths_give_the_same_objects():
    from graspmanifold.judging.protocols import PROTOCOLS

    sys.modules.pop("graspmanifold.control.protocols", None)
    with pytest.warns(DeprecationWarning):
        from graspmanifold.control.protocols import PROTOCOLS as old_protocols
    assert old_protocols is PROTOCOLS


def test_renamed_attributes_of_the_package_answer_with_a_warning():
    with pytest.warns(DeprecationWarning, match="experience_pays"):
        assert gm.study is gm.experience_pays
    with pytest.warns(DeprecationWarning, match="strategy_selector"):
        assert gm.selector is gm.strategy_selector


def test_names_that_never_existed_still_fail_to_import():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("graspmanifold.control.no_such_module")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the current paths warn nothing
        importlib.import_module("graspmanifold.judging.replay")
        importlib.import_module("graspmanifold.synthesis.generator")


def test_a_recall_rule_that_steers_only_the_thumb_runs_on_the_controllers_public_view():
    """A rule of one's own steers: the recalled posture sets the thumb's joints and nothing else. It reads and
    changes only what `RecallRule` documents (`state`, `steered_joint_mask`, `limits`), no private name."""
    import ast
    import inspect
    import textwrap
    from dataclasses import dataclass

    import numpy as np

    from graspmanifold.control.controller import BatchController
    from graspmanifold.control.recall import RecallRule
    from graspmanifold.control.state import JOINT_FINGER
    from graspmanifold.sim.hand import FINGERS

    thumb = JOINT_FINGER == FINGERS.index("th")

    @dataclass(frozen=True)
    class ThumbOnly(RecallRule):
        name = "thumb-only"

        def preshape(self, c, worlds, postures):
            c.state.target[worlds] = np.where(thumb & c.steered_joint_mask, postures, c.state.target[worlds])

        def recall(self, c, worlds, winners, match, joints, touching_segments, fingers_touching):
            steered = np.where(thumb & c.steered_joint_mask, match, c.state.target[worlds])
            c.state.target[worlds] = np.clip(steered, *c.limits.T)

    source = ast.parse(textwrap.dedent(inspect.getsource(ThumbOnly)))
    assert not [n.attr for n in ast.walk(source) if isinstance(n, ast.Attribute) and n.attr.startswith("_")]

    database = gm.PostureDatabase(np.array([gm.closed_posture(), gm.open_posture()]))
    controller = BatchController(3, database, gm.ControllerParams(recall=ThumbOnly()))
    before = controller.state.target.copy()
    worlds = np.array([0, 2])
    controller.params.recall.recall(controller, worlds, np.array([0, 0]), np.tile(gm.closed_posture(), (2, 1)),
                                    np.tile(gm.open_posture(), (3, 1)), np.zeros((3, len(gm.SEGMENTS)), bool),
                                    np.zeros((3, 5), bool))
    changed = controller.state.target != before
    assert changed[worlds][:, thumb].any() and not changed[:, ~thumb].any() and not changed[1].any()

    from graspmanifold.trials.grid import check_grid

    poses = check_grid("quick", gm.get_object("cylinder"))[1][::12]
    result = gm.evaluate("cylinder", database, poses, seed=0, workers=1, progress=False,
                         params=gm.ControllerParams(recall=ThumbOnly()))
    assert len(result.trials) == len(poses) and sum(t.matches for t in result.trials) > 0


# -- files written by the previous version (tests/data/v0_1, made by main 6ef7e7f: "ours" named the hand and the
# hold test) load, resume and say the names of now

FIXTURES = Path(__file__).parent / "data" / "v0_1"


def test_the_hand_and_the_hold_test_have_names_that_say_what_they_are_and_the_old_ones_still_work():
    from graspmanifold.base.moved import current_name
    from graspmanifold.judging.protocols import DEFAULT_PROTOCOL, PROTOCOLS, get_protocol
    from graspmanifold.sim.hand_models import HAND_MODELS, hand_model, hand_name

    assert gm.SHADOW_HAND.name == "shadow-primitives" and "ours" not in HAND_MODELS
    assert DEFAULT_PROTOCOL == "hold-test" and "ours" not in PROTOCOLS and "hold-test-faded" in PROTOCOLS
    assert hand_name("ours") == "shadow-primitives" and hand_model("ours") is hand_model("shadow-primitives")
    assert get_protocol("ours") is PROTOCOLS["hold-test"] and get_protocol("ours-faded") is PROTOCOLS["hold-test-faded"]
    assert current_name("hand", "gymnasium-robotics") == "gymnasium-robotics" and current_name("protocol", 3) == 3
    assert gm.GeneratorParams(verify_protocol="ours", hand="ours") == gm.GeneratorParams()
    old = gm.TrialSetup(object="cylinder", hand="ours", protocol="ours")
    assert old.hand is gm.TrialSetup(object="cylinder").hand and old.protocol is PROTOCOLS["hold-test"]
    with pytest.raises(gm.InvalidInput, match="hand must be one of"):
        hand_name("theirs")


def test_a_posture_set_a_map_and_an_evaluation_of_the_previous_version_load_and_run_on():
    postures = gm.PostureSet.load(FIXTURES / "postures.npz")
    assert postures.metadata["hand"] == "ours" and postures.hand == "shadow-primitives" and len(postures) == 6
    som = gm.SOM.load(FIXTURES / "som.npz")
    result = gm.EvaluationResult.load(FIXTURES / "evaluation.npz")
    assert len(result.trials) == 2 and result.made_by["hand"]["name"] == "ours"
    # the old set is experience for trials of the hand as it is called now, and the map recalls as it did
    setup = gm.TrialSetup(object="cylinder", experience=postures)
    assert setup.experience is not None and setup.hand.name == "shadow-primitives"
    # the old map recalls (a best match is a nearest node) and runs the old file's poses (outcomes are not compared:
    # they were written on one processor, and a trial's start may turn on the physics' last bits on another)
    nearest = ((som.references[None] - postures.postures[:, None]) ** 2).sum(axis=2)
    chosen = som.best_match_batch(postures.postures)
    assert np.allclose(nearest[np.arange(len(chosen)), chosen], nearest.min(axis=1))
    poses = np.array([t.grid_pose for t in result.trials])
    again = gm.evaluate("cylinder", som, poses, seed=0, workers=1, progress=False)
    assert again.method == result.method == "som" and np.array_equal([t.grid_pose for t in again.trials], poses)


def test_an_experiment_file_and_a_run_folder_of_the_previous_version_resume(tmp_path):
    import json
    import shutil

    from graspmanifold.base.config_files import read_config
    from graspmanifold.paper.reproduce import ReproduceConfig, reproduce

    config = read_config(FIXTURES / "config.toml", ReproduceConfig(postures={"cylinder": 6}))
    assert config.hand == "shadow-primitives" and config.protocol == "hold-test"
    assert config.generator.verify_protocol == "hold-test" and config.generator.hand == "shadow-primitives"
    run = tmp_path / "run"
    shutil.copytree(FIXTURES / "run", run)  # the old run's record: the new run resumes it instead of refusing
    summary = reproduce(run, config, workers=1, log=lambda line: None)
    written = json.loads((run / "run.json").read_text())["config"]
    assert written["hand"] == "shadow-primitives" and written["protocol"] == "hold-test"
    assert written["generator"]["hand"] == "shadow-primitives"
    assert [r["method"] for r in summary["evaluation"]][:3] == ["none", "database", "som"]
    assert "ours" not in (run / "config.toml").read_text().replace("ours)", "")


def test_the_judging_protocol_is_not_mistaken_for_typings_and_its_old_name_answers_with_a_warning():
    from graspmanifold.judging import protocols

    assert protocols.PROTOCOLS["hold-test"].__class__ is protocols.JudgingProtocol
    with pytest.warns(DeprecationWarning, match="is now graspmanifold.judging.protocols.JudgingProtocol"):
        assert protocols.Protocol is protocols.JudgingProtocol
    with pytest.warns(DeprecationWarning, match="HOLD_TEST"):
        assert protocols.OURS is protocols.HOLD_TEST
    from graspmanifold.control import controller, recall

    with pytest.warns(DeprecationWarning, match="control.recall.BlendRecall"):
        assert controller.BlendRecall is recall.BlendRecall
    with pytest.raises(AttributeError):
        protocols.NoSuchThing  # noqa: B018


def test_recall_names_one_thing_and_the_old_names_of_the_others_answer_with_a_warning():
    """'Recall' is what a best match does (`RecallRule`, `ControllerParams.recall`); the experience's best-match
    base is `ReferenceMatcher`, the state's arrays `recalled_posture` and `closure_restarted`."""
    from graspmanifold.control.controller import BatchController
    from graspmanifold.manifold import nearest

    assert issubclass(gm.SOM, nearest.ReferenceMatcher) and issubclass(gm.UKR, nearest.ManifoldMatcher)
    with pytest.warns(DeprecationWarning, match="nearest.ReferenceMatcher"):
        assert nearest.Recall is nearest.ReferenceMatcher
    state = BatchController(2, None).state
    with pytest.warns(DeprecationWarning, match="recalled_posture"):
        assert state.recall is state.recalled_posture
    with pytest.warns(DeprecationWarning, match="closure_restarted"):
        assert state.recalled is state.closure_restarted


def test_the_environments_take_a_trial_setup_and_refuse_what_an_episode_does_not_run():
    """An episode is a trial whose controller is the agent: both environments take the `TrialSetup` (or its fields
    by name), and the same set-up gives the same first observation either way."""
    pytest.importorskip("gymnasium")
    from graspmanifold.envs.tactile_grasp import TactileGraspEnv, TactileGraspVectorEnv, episode_setup

    setup = gm.TrialSetup(object="box", protocol="hold-test", table=False)
    whole, by_name = TactileGraspEnv(setup), TactileGraspEnv(object="box", protocol="hold-test")
    np.testing.assert_array_equal(whole.reset(seed=3)[0], by_name.reset(seed=3)[0])
    vector = TactileGraspVectorEnv(2, setup=setup)
    np.testing.assert_array_equal(vector.reset(seed=3)[0][0], whole.reset(seed=3)[0])
    with pytest.raises(gm.InvalidInput, match=r"the set-up's \['experience'\] are a trial's"):
        episode_setup(gm.TrialSetup(object="box", experience=gm.PostureDatabase(np.array([gm.open_posture()]))))
    with pytest.raises(gm.InvalidInput, match="unknown argument"):
        TactileGraspEnv("box", margin=True)
    with pytest.raises(gm.InvalidInput, match="a TrialSetup is given whole"):
        TactileGraspEnv(setup, hand="shadow-primitives")
