"""The layer drawing in docs/guide/structure.md holds: every module in its subpackage, no import of a layer above,
no cycles, no private names across modules, no private modules of dependencies."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "graspmanifold"
DRAWING = ROOT / "docs" / "guide" / "structure.md"
MODULES = sorted(p for p in PACKAGE.rglob("*.py") if not (p.name == "__init__.py" and p.parent != PACKAGE))


def name_of(path: Path) -> str:
    """'sim.scene' for src/graspmanifold/sim/scene.py, 'cli' for a top-level module."""
    return ".".join(path.relative_to(PACKAGE).with_suffix("").parts)


def drawn_layers() -> dict[str, tuple[int, str]]:
    """Module -> (layer number, subpackage), from the drawing's code block (a continuation row has no number)."""
    block = DRAWING.read_text().split("```")[1]
    layers: dict[str, tuple[int, str]] = {}
    layer, package = None, None
    for line in block.splitlines()[2:]:
        numbered = re.match(r"\s+(\d+)\s+(\S+)\s+(.*)$", line)
        if numbered:
            layer, package, rest = int(numbered.group(1)), numbered.group(2), numbered.group(3)
        elif line.strip() and layer is not None:
            rest = line.strip()
        else:
            continue
        for module in re.split(r"\s{2,}", rest.strip())[0].split():
            qualified = module if package == "(top)" else f"{package}.{module}"
            assert qualified not in layers, f"{qualified} is drawn twice"
            layers[qualified] = (layer, package)
    return layers


def imports_of(path: Path, type_hints: bool = False) -> set[str]:
    """The package modules that a module imports (relative imports, as 'sub.module'), not counting
    TYPE_CHECKING blocks unless `type_hints`."""
    tree = ast.parse(path.read_text())
    type_only = set() if type_hints else {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                                          and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"
                                          for n in ast.walk(node)}
    here = path.parent.relative_to(PACKAGE).parts
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level >= 1 and id(node) not in type_only and node.module:
            base = here[: len(here) - (node.level - 1)]
            target = base + tuple(node.module.split("."))
            if (PACKAGE.joinpath(*target) / "__init__.py").exists():  # modules of a subpackage: from ..control import judge
                found.update(".".join(target + (alias.name,)) for alias in node.names)
            else:
                found.add(".".join(target))
    return found


def test_the_drawing_names_every_module_once_in_its_subpackage():
    drawn = drawn_layers()
    modules = {name_of(p) for p in MODULES}
    assert set(drawn) == modules, f"not drawn: {modules - set(drawn)}; drawn but missing: {set(drawn) - modules}"



def test_the_docs_count_the_subpackages_the_drawing_draws():
    """The architecture page said eight subpackages above a drawing of ten, and the guide's opening seven."""
    import re

    words = {"seven": 7, "eight": 8, "nine": 9, "ten": 10, "eleven": 11, "twelve": 12}
    drawn = {package for _, package in drawn_layers().values() if package != "(top)"}
    for page in (DRAWING, ROOT / "docs" / "guide" / "concepts.md"):
        said = re.findall(r"\b(seven|eight|nine|ten|eleven|twelve|\d+) subpackages", page.read_text())
        assert said, f"{page.name} does not say how many subpackages there are"
        assert {words.get(n, None) or int(n) for n in said} == {len(drawn)}, (page.name, said, sorted(drawn))

@pytest.mark.parametrize("path", MODULES, ids=name_of)
def test_no_module_imports_one_above_its_layer(path):
    layers = drawn_layers()
    module = name_of(path)
    above = {m: layers[m][0] for m in imports_of(path) if layers[m][0] > layers[module][0]}
    assert not above, f"{module} (layer {layers[module][0]}) imports modules above its layer: {above}"


def test_the_controller_and_the_judging_do_not_import_each_other():
    """control/ (the controller and its recall rules) and judging/ (how a grasp is judged) share one layer and no
    import: what both need about closing a hand lives below them (`sim.grip`); grasp synthesis, which uses both,
    sits above them."""
    layers = drawn_layers()
    packages = {"control", "judging"}
    crossing = [(name_of(p), m) for p in MODULES if name_of(p).split(".")[0] in packages
                for m in imports_of(p) if m.split(".")[0] in packages - {name_of(p).split(".")[0]}]
    assert not crossing, f"control/ and judging/ import each other: {crossing}"
    assert {layers[m][0] for m in layers if m.split(".")[0] in packages} == {4}
    assert all(layers[m][0] == 5 for m in layers if m.startswith("synthesis."))


def test_no_import_cycles():
    """None, counting the imports made only for type hints too (render's of the scene was the last circle)."""
    graph = {name_of(p): imports_of(p, type_hints=True) for p in MODULES}
    state: dict[str, str] = {}

    def visit(module: str, path: tuple[str, ...]) -> None:
        if state.get(module) == "done":
            return
        assert state.get(module) != "open", f"import cycle: {' -> '.join(path + (module,))}"
        state[module] = "open"
        for dependency in graph[module]:
            visit(dependency, path + (module,))
        state[module] = "done"

    for module in graph:
        visit(module, ())


def test_no_module_imports_the_package_init():
    for path in MODULES:
        if path != PACKAGE / "__init__.py":
            tree = ast.parse(path.read_text())
            bare = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level >= 1 and not n.module]
            assert not bare, f"{path.name} imports from a package's __init__ (from . import ...)"
            absolute = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                        and any((a.name if isinstance(n, ast.Import) else n.module or "").startswith("graspmanifold")
                                for a in n.names)]
            assert not absolute, f"{path.name} imports the package by its absolute name"


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))  # not __future__


def _private_imports() -> tuple[list[str], list[str]]:
    """Private names imported from another module of the package; private modules of dependencies imported."""
    crossing, reaching = [], []
    for path in MODULES:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level >= 1:
                    crossing += [f"{name_of(path)}: {a.name} from {node.module}" for a in node.names
                                 if a.name.startswith("_") and not a.name.startswith("__")]
                elif any(_private(part) for part in (node.module or "").split(".")):
                    reaching.append(f"{name_of(path)}: from {node.module}")
            elif isinstance(node, ast.Import):
                reaching += [f"{name_of(path)}: import {a.name}" for a in node.names
                             if any(_private(part) for part in a.name.split("."))]
    return crossing, reaching


def test_no_module_imports_a_private_name_of_another():
    """A module's `_names` are its own: what two modules share is public (the judge and the controller share
    `sim.grip.row_norms`)."""
    crossing, _ = _private_imports()
    assert not crossing, f"private names imported from another module: {crossing}"


#: private names of other code that their owners document as public API
DOCUMENTED_PRIVATES = {"_exit"}  # os._exit: the documented way out of a forked child without its parent's cleanup


def private_reads(source: str) -> list[str]:
    """Attributes `x._name` read in a module whose `_name` the module does not define itself (as a function, class,
    assignment, attribute set or parameter): another module's private member, or a dependency's."""
    tree = ast.parse(source)
    defined = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, (ast.Name, ast.Attribute)) and isinstance(node.ctx, ast.Store):
            defined.add(node.id if isinstance(node, ast.Name) else node.attr)
        elif isinstance(node, ast.arg):
            defined.add(node.arg)
    return [f"line {node.lineno}: {ast.unparse(node)}" for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and _private(node.attr) and node.attr not in defined
            and node.attr not in DOCUMENTED_PRIVATES]


def test_no_module_reads_a_private_name_of_another():
    """Beside imports: no `other._member` read either (the recall rules read the controller's public view, the
    profiling study the generator's public `SpringRig`, the vector environment builds its own infos)."""
    reads = {name_of(p): found for p in MODULES if (found := private_reads(p.read_text()))}
    assert not reads, f"private names of other modules read: {reads}"
    assert private_reads("def f(c):\n    return c._steered\n")  # the check sees a read
    assert not private_reads("class A:\n    def __init__(self):\n        self._x = 1\n    def f(self, o):\n"
                             "        return o._x\n")  # a module's own private member, on another instance


def test_no_module_imports_a_private_module_of_a_dependency():
    _, reaching = _private_imports()
    assert not reaching, f"private modules of dependencies imported: {reaching}"


def test_the_studies_are_library_code_and_write_tables_one_way():
    """scripts/ held 2.4k lines of experiment machinery (study classes, caches without keys, hand-written markdown
    tables in twelve scripts, the paired comparison spelled five times); now each script is a thin command over
    `graspmanifold.studies`, and `base.io.markdown_table` is the one writer of a table's rule."""
    scripts = sorted((ROOT / "scripts").glob("*.py"))
    assert sum(len(p.read_text().splitlines()) for p in scripts) < 1000
    writers = [p for p in [*PACKAGE.rglob("*.py"), *scripts] if "---|" in p.read_text()]
    assert writers == [PACKAGE / "base" / "io.py"], writers
    by_hand = [p.name for p in [*PACKAGE.rglob("*.py"), *scripts] if "[va & vb]" in p.read_text()
               or "oa[both]" in p.read_text()]
    assert by_hand == [], f"paired comparisons spelled by hand (use stats.mcnemar(..., valid=)): {by_hand}"


def test_every_study_runs_on_the_one_study_template():
    """A study is a command over `studies.runner.StudyRun`: every module of studies/ with a `main` runs it through
    `run_study` or `run_command` (its folder locked, its log, its transcript, Ctrl-C ending in how to resume);
    none makes its folder or writes its report by hand."""
    studies = sorted(p for p in (PACKAGE / "studies").glob("*.py") if "\ndef main(" in p.read_text())
    assert len(studies) >= 16
    off = [p.name for p in studies if not re.search(r"\brun_(study|command)\(", p.read_text())]
    assert not off, f"studies not on the template (runner.run_study / run_command): {off}"
    by_hand = [p.name for p in studies if ".mkdir(" in p.read_text() or ".write_text(" in p.read_text()]
    assert not by_hand, f"studies that make their folder or write a report by hand: {by_hand}"


def _functions() -> list[tuple[str, ast.FunctionDef]]:
    return [(name_of(p), node) for p in MODULES for node in ast.walk(ast.parse(p.read_text()))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))]


def test_no_function_is_longer_than_eighty_lines():
    """A function reads in one sitting: every one in src/ (its docstring included) is at most 80 lines; a longer
    one is split into its named steps (`BatchController.step`, `generate_postures`, the studies' measures and
    reports)."""
    long = [f"{module}.{node.name} ({node.end_lineno - node.lineno + 1} lines)" for module, node in _functions()
            if node.end_lineno - node.lineno + 1 > 80]
    assert not long, long



def test_no_module_of_the_trials_the_judging_or_the_synthesis_is_over_600_lines():
    """trials/trial.py (929 lines) held seven ideas, judging/replay.py (621) six, synthesis/generator.py (898) the
    spring rig and the start cache: each idea has its room now, and a room that grows past 600 lines is split."""
    long = {name_of(p): n for p in MODULES if name_of(p).split(".")[0] in ("trials", "judging", "synthesis")
            and (n := len(p.read_text().splitlines())) > 600}
    assert not long, long


#: the most fields each wide value may have: the counts when the cap was set (0.3). A new feature brings a value of
#: its own (where a trial starts, a stage's settings on the stage) rather than one more field on these
FIELD_CAPS = {"trials.setup.TrialSetup": 18, "control.controller.ControllerParams": 19, "control.state.GraspState": 28,
              "synthesis.springs.GeneratorParams": 22, "judging.stages.JudgingRules": 15}


def test_the_wide_values_stop_widening():
    """In one day `ControllerParams` went from 14 to 19 fields, `GraspState` from 21 to 28, `TrialSetup` from 15 to
    18: every feature was one more field on a wide value."""
    import dataclasses
    import importlib

    wide = {}
    for dotted, cap in FIELD_CAPS.items():
        module, name = dotted.rsplit(".", 1)
        fields = dataclasses.fields(getattr(importlib.import_module(f"graspmanifold.{module}"), name))
        if len(fields) > cap:
            wide[dotted] = f"{len(fields)} fields, capped at {cap}"
    assert not wide, wide

def test_no_public_function_takes_more_than_eight_parameters():
    """A public function (or method) of src/ takes at most eight parameters (self, cls not counted; *args and
    **kwargs one each): what belongs together is one value (`TrialSetup`, `GeneratorParams`, `StartingPosture`, a
    kernel's model tuple)."""
    wide = []
    for module, node in _functions():
        arguments = node.args
        names = [a.arg for a in arguments.posonlyargs + arguments.args + arguments.kwonlyargs
                 if a.arg not in ("self", "cls")] + [a.arg for a in (arguments.vararg, arguments.kwarg) if a]
        if len(names) > 8 and not node.name.startswith("_"):
            wide.append(f"{module}.{node.name} ({len(names)})")
    assert not wide, wide

