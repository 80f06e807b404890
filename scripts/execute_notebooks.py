"""Execute the example notebooks and store them with their outputs, and make the tutorial page of the
documentation from the getting-started notebook.

    python scripts/execute_notebooks.py            # execute examples/*.ipynb in place, write docs/tutorial.md
    python scripts/execute_notebooks.py --check    # only check that docs/tutorial.md is the stored notebook's

Each notebook runs from a clean kernel in a scratch directory (what it writes, a GIF, stays there) and is
stored executed, so its outputs and pictures show on a code host. The tutorial page is the stored
getting-started notebook as Markdown: its text, its code, its printed output and its pictures (written
beside the page as PNG and GIF files).
"""

from __future__ import annotations

import argparse
import base64
import tempfile
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PAGE = ROOT / "docs" / "tutorial.md"
PICTURES = PAGE.parent / "tutorial_files"
SOURCE = EXAMPLES / "getting_started.ipynb"


def execute(path: Path) -> None:
    """Run a notebook from a clean kernel and store it with its outputs."""
    from nbclient import NotebookClient

    notebook = nbformat.read(path, as_version=4)
    with tempfile.TemporaryDirectory() as scratch:
        NotebookClient(notebook, timeout=600, kernel_name="python3",
                       resources={"metadata": {"path": scratch}}).execute()
    for cell in notebook.cells:  # what differs from run to run (timings, progress bars) is not stored
        cell.get("metadata", {}).pop("execution", None)
        if "outputs" in cell:
            cell.outputs = [o for o in cell.outputs if not (o.get("output_type") == "stream" and o.get("name") == "stderr")]
    nbformat.write(notebook, path)


def tutorial(notebook_path: Path) -> tuple[str, dict[str, bytes]]:
    """The Markdown page of a stored, executed notebook and its pictures (file name -> PNG bytes)."""
    notebook = nbformat.read(notebook_path, as_version=4)
    parts, pictures = [f"<!-- made by scripts/execute_notebooks.py from examples/{notebook_path.name}; "
                       "do not edit -->"], {}
    for number, cell in enumerate(notebook.cells):
        if cell.cell_type == "markdown":
            parts.append(cell.source)
            continue
        if cell.cell_type != "code":
            continue
        parts.append(f"```python\n{cell.source}\n```")
        for k, output in enumerate(cell.get("outputs", [])):
            data = output.get("data", {})
            kind = next((kind for kind in ("png", "gif") if f"image/{kind}" in data), None)
            if kind:  # a plot, or an animation
                name = f"cell{number:02d}_{k}.{kind}"
                pictures[name] = base64.b64decode(data[f"image/{kind}"])
                parts.append(f"![output of cell {number}]({PICTURES.name}/{name})")
            elif output.get("output_type") == "stream" or "text/plain" in data:
                text = output.get("text", "") if output.get("output_type") == "stream" else data["text/plain"]
                parts.append("```text\n" + text.rstrip("\n") + "\n```")
    return "\n\n".join(parts) + "\n", pictures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check that the tutorial page is up to date")
    args = parser.parse_args()
    if not args.check:
        for path in sorted(EXAMPLES.glob("*.ipynb")):
            print(f"executing {path.name} ...", flush=True)
            execute(path)
    page, pictures = tutorial(SOURCE)
    if args.check:
        stale = [str(PAGE)] if not PAGE.exists() or PAGE.read_text() != page else []
        stale += [name for name, data in pictures.items()
                  if not (PICTURES / name).exists() or (PICTURES / name).read_bytes() != data]
        if stale:
            raise SystemExit(f"the tutorial page is not the stored notebook's: {', '.join(stale)}; "
                             "run python scripts/execute_notebooks.py")
        print("the tutorial page is up to date")
        return
    PICTURES.mkdir(parents=True, exist_ok=True)
    for old in [*PICTURES.glob("*.png"), *PICTURES.glob("*.gif")]:
        old.unlink()
    for name, data in pictures.items():
        (PICTURES / name).write_bytes(data)
    PAGE.write_text(page)
    print(f"wrote {PAGE.relative_to(ROOT)} and {len(pictures)} pictures")


if __name__ == "__main__":
    main()
