"""The layer drawing in docs/structure.md holds: no module imports one above its layer, no cycles."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "graspmanifold"
DRAWING = ROOT / "docs" / "structure.md"


def drawn_layers() -> dict[str, int]:
    """Module -> layer number, from the drawing's code block (a continuation row has no number)."""
    block = DRAWING.read_text().split("```")[1]
    layers: dict[str, int] = {}
    layer = None
    for line in block.splitlines()[2:]:
        numbered = re.match(r"\s+(\d+)\s+\w+\s{2,}(.*)$", line)
        if numbered:
            layer, rest = int(numbered.group(1)), numbered.group(2)
        elif line.strip() and layer is not None:
            rest = line.strip()
        else:
            continue
        modules = re.split(r"\s{2,}", rest.strip())[0].split()
        for module in modules:
            assert module not in layers, f"{module} is drawn twice"
            layers[module] = layer
    return layers


def imports_of(path: Path) -> set[str]:
    """The package modules that a module imports (relative imports), not counting TYPE_CHECKING blocks."""
    tree = ast.parse(path.read_text())
    type_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                 and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"
                 for n in ast.walk(node)}
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 1 and id(node) not in type_only:
            found |= {node.module.split(".")[0]} if node.module else {a.name for a in node.names}
    return found


def test_the_drawing_names_every_module_once():
    modules = {p.stem for p in PACKAGE.glob("*.py")}
    drawn = drawn_layers()
    assert set(drawn) == modules, f"not drawn: {modules - set(drawn)}; drawn but missing: {set(drawn) - modules}"


@pytest.mark.parametrize("module", sorted(p.stem for p in PACKAGE.glob("*.py")))
def test_no_module_imports_one_above_its_layer(module):
    layers = drawn_layers()
    above = {m: layers[m] for m in imports_of(PACKAGE / f"{module}.py") if layers[m] > layers[module]}
    assert not above, f"{module} (layer {layers[module]}) imports modules above its layer: {above}"


def test_no_import_cycles():
    graph = {p.stem: imports_of(p) for p in PACKAGE.glob("*.py")}
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
    for path in PACKAGE.glob("*.py"):
        if path.stem != "__init__":
            tree = ast.parse(path.read_text())
            bare = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level == 1 and not n.module]
            assert not bare, f"{path.name} imports from the package's __init__ (from . import ...)"
            absolute = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                        and any((a.name if isinstance(n, ast.Import) else n.module or "") == "graspmanifold"
                                for a in n.names)]
            assert not absolute, f"{path.name} imports the package itself"
