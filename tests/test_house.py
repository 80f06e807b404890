"""Issue 70, the house: control/ as its three ideas (control, judging, synthesis), the old import paths kept for
one release, the names that say what a thing is."""

import importlib
import sys
import warnings

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

    from graspmanifold.control.controller import JOINT_FINGER, BatchController, RecallRule
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
