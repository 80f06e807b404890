"""What was renamed keeps working: modules that moved keep their old import paths for one release, with a
`DeprecationWarning`; names that files, flags and experiment files once wrote are read as their names now.

`MOVED_MODULES` maps an old dotted name to the module that now holds its code (0.2: control/ split into
control/, judging/ and synthesis/, and modules renamed after their idea). `install()` puts one finder at the end
of `sys.meta_path`: an import of an old name that no file answers gets the new module itself (the same object,
so its classes and registries are the ones the rest of the package uses), with a warning that names the new path.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from collections.abc import Callable, Sequence
from typing import Any, TypeVar, cast

Named = TypeVar("Named")

#: old module -> the module that holds its code now (both within `graspmanifold`)
MOVED_MODULES: dict[str, str] = {
    "control.judge": "judging.judge",
    "control.stages": "judging.stages",
    "control.protocols": "judging.protocols",
    "control.quality": "judging.quality",
    "control.dexgraspbench": "judging.replay",
    "control.contact_offset": "sim.normal_offsets",
    "control.search_geometry": "synthesis.start_geometry",
    "control.refinement": "synthesis.refinement",
    "control.starts": "synthesis.starts",
    "control.generator": "synthesis.generator",
    "control.grasp_files": "synthesis.grasp_files",
    "trials.study": "trials.experience_pays",
    "trials.selector": "trials.strategy_selector",
    "trials.uncertainty": "trials.pose_errors",
    "studies.experience": "studies.experience_study",
    "studies.protocols": "studies.protocol_study",
}
#: the release after which the old module names go
REMOVED_IN = "0.3"
#: names a kind of value once had (in saved files, run.json, TOML files, flags) -> its name now (0.2: "ours" named
#: both the hand model and the hold test)
RENAMED_VALUES: dict[str, dict[str, str]] = {
    "hand": {"ours": "shadow-primitives"},
    "protocol": {"ours": "hold-test", "ours-faded": "hold-test-faded"},
}
_PACKAGE = __name__.split(".")[0]


def new_name(old: str) -> str | None:
    """The module that holds an old module's code now.

    Args:
        old: a dotted module name, with or without the package's own name in front.

    Returns:
        The new dotted name within the package, or None where `old` did not move.
    """
    return MOVED_MODULES.get(old.removeprefix(f"{_PACKAGE}."))


#: names that left a module that stays -> where they live now ('module:name', within the package)
MOVED_NAMES: dict[str, dict[str, str]] = {
    "control.controller": {name: f"control.recall:{name}" for name in ("BlendRecall", "REST_SPEED", "palm_shift")},
    "judging.protocols": {"Protocol": "judging.protocols:JudgingProtocol", "OURS": "judging.protocols:HOLD_TEST",
                          "OURS_FADED": "judging.protocols:HOLD_TEST_FADED"},
    "manifold.nearest": {"Recall": "manifold.nearest:ReferenceMatcher",
                         "ManifoldRecall": "manifold.nearest:ManifoldMatcher"},
    # 0.3: judging/replay.py held six ideas; the plan value, the push test and Q1 have rooms of their own, and the
    # open-loop controller, a trial's controller, lives with the trials
    "judging.replay": {
        **{name: f"judging.quality:{name}" for name in ("q1", "Q1_CONTACT_DISTANCE")},
        **{name: f"judging.plans:{name}" for name in ("STAGE_NAMES", "MAX_REACH", "PREGRASP_BACK_OFF",
                                                       "open_loop_grasps")},
        **{name: f"judging.push_test:{name}" for name in ("ForceTest",)},
        **{name: f"trials.open_loop:{name}" for name in ("APPROACH_TARGET_SECONDS", "OpenLoopController", "OpenLoop")},
    },
    "trials.experience_pays": {"compare": "trials.stats:compare"},  # 0.3: with the statistics
    "judging.judge": {"judge_worlds": "judging.judge:episode_loop"},  # 0.3: the loop named as the loop
    "trials.episode": {"Episodes": "trials.episode:EpisodeWorlds"},  # 0.3: what it holds, the episodes' worlds
    # 0.3: the spring rig and its walk, and the start cache, left the generator for rooms of their own
    "synthesis.generator": {
        **{name: f"synthesis.springs:{name}" for name in ("SpringRig", "holds_with_neighbours",
                                                           "NEIGHBOURS", "MODES", "PRESET_PARAMS")},
        **{name: f"synthesis.start_cache:{name}" for name in ("search_starting_postures", "cache_directory",
                                                               "starts_cache_path")},
    },
}


def moved_attribute(module: str, name: str) -> object:
    """A name that left `module` (`MOVED_NAMES`), from where it lives now, with a `DeprecationWarning`; the
    `__getattr__` of a module that names moved out of calls it.

    Args:
        module: the module's `__name__`.
        name: the attribute asked for.

    Returns:
        The object.

    Raises:
        AttributeError: a name that never was the module's.
    """
    short = module.removeprefix(f"{_PACKAGE}.")
    where = MOVED_NAMES.get(short, {}).get(name)
    if where is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    new_module, new_name = where.split(":")
    warnings.warn(f"{module}.{name} is now {_PACKAGE}.{new_module}.{new_name}; the old name goes in {REMOVED_IN}",
                  DeprecationWarning, stacklevel=3)
    return getattr(importlib.import_module(f"{_PACKAGE}.{new_module}"), new_name)


def current_name(kind: str, name: Named) -> Named:
    """A value's name as the library calls it now: an old one (`RENAMED_VALUES`) read from a file written before
    the rename, or given by a user, becomes the new one; anything else is returned as it is (checked later).

    Args:
        kind: 'hand' or 'protocol'.
        name: the name read or given.

    Returns:
        The current name.
    """
    return cast(Named, RENAMED_VALUES[kind].get(name, name)) if isinstance(name, str) else name


def upgrade_config(config: dict) -> dict:
    """A run's configuration (run.json's `config`, a config.toml's table) as this version writes it, in place: the
    hand's and the protocols' names before 0.2 (`RENAMED_VALUES`), and the generator's hand, which its settings name
    since 0.2 (the run's hand).

    Args:
        config: the configuration read (a dict; the keys it lacks stay missing but the generator's hand).

    Returns:
        The same dict.
    """
    for key, kind in (("hand", "hand"), ("protocol", "protocol")):
        if key in config:
            config[key] = current_name(kind, config[key])
    generator = config.get("generator")
    if isinstance(generator, dict):
        if "hand" in config:
            generator.setdefault("hand", config["hand"])
        for key, kind in (("hand", "hand"), ("verify_protocol", "protocol")):
            if key in generator:
                generator[key] = current_name(kind, generator[key])
    return config


def moved_warning(old: str, new: str) -> None:
    """Warn, once per call site, that `old` is now `new` (both dotted names within the package).

    Args:
        old: the old name.
        new: the name to use.
    """
    warnings.warn(f"{_PACKAGE}.{old} moved to {_PACKAGE}.{new}; the old name goes in {REMOVED_IN}",
                  DeprecationWarning, stacklevel=3)


Call = TypeVar("Call", bound=Callable[..., Any])


def moved_keyword(old: str, new: str, move: Callable[[dict[str, Any], Any], None]) -> Callable[[Call], Call]:
    """A keyword a function took before and that moved into one of its values: a call that still passes it works
    for one release, with a `DeprecationWarning` that says where it went.

    Args:
        old: the keyword's old name ('hand').
        new: where it is now, in words for the message ('params=GeneratorParams(hand=...)').
        move: puts the old keyword's value where it belongs now, given the call's other keywords (changed in place).

    Returns:
        The decorator.
    """
    def decorate(function: Call) -> Call:
        @functools.wraps(function)
        def call(*args: Any, **kwargs: Any) -> Any:
            if old in kwargs:
                warnings.warn(f"{function.__name__}({old}=...) is now {function.__name__}({new}); the old keyword "
                              f"goes in {REMOVED_IN}", DeprecationWarning, stacklevel=2)
                move(kwargs, kwargs.pop(old))
            return function(*args, **kwargs)

        return cast(Call, call)

    return decorate


class _MovedFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, fullname, path=None, target=None):  # noqa: ANN001 (the import system's signature)
        if not fullname.startswith(f"{_PACKAGE}.") or new_name(fullname) is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec):  # noqa: ANN001
        return None

    def exec_module(self, module: ModuleType) -> None:
        new = new_name(module.__name__)
        assert new is not None
        moved_warning(module.__name__.removeprefix(f"{_PACKAGE}."), new)
        # the import system hands out what sys.modules holds under the name after this call: the new module itself
        sys.modules[module.__name__] = importlib.import_module(f"{_PACKAGE}.{new}")


def install() -> None:
    """Let the old module names import (once per process; the package's `__init__` calls it)."""
    if not any(isinstance(finder, _MovedFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedFinder())


class OldFlag(argparse.Action):
    """A command-line option's old name, for one release: it sets the new option's value and says on stderr that it
    is the old name (`parser.add_argument("--manifold", dest=..., action=OldFlag, new="--experience")`; 0.3: what
    the controller recalls from is `--experience` on every command).

    Args:
        option_strings: the old option's names.
        dest: the new option's destination.
        new: the new option, as the message names it.
        **kwargs: argparse's (choices, default, help).
    """

    def __init__(self, option_strings: Sequence[str], dest: str, new: str = "", **kwargs: Any):
        self.new = new
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        print(f"warning: {option_string} is now {self.new}; the old name goes in {REMOVED_IN}", file=sys.stderr)
        setattr(namespace, self.dest, values)
