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
