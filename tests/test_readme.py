"""The README's Python blocks run as written, from a directory outside the checkout."""

import re
import subprocess
import sys
import textwrap
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"
GUIDE = README.parent / "docs" / "guide"
#: the guide's pages but the recipes (tests/test_recipes.py runs those)
GUIDE_TEXT = "".join(page.read_text() for page in sorted(GUIDE.glob("*.md")) if page.name != "recipes.md")
RESULTS = README.parent / "docs" / "studies" / "results.md"
VERIFIED_SECTION = "## Beside it: `graspmanifold reproduce --preset verified`"


def test_the_front_page_is_short_and_every_python_block_runs_verbatim(tmp_path):
    """The README was 512 lines with its quick start near line 400; the long form is the guide (docs/guide/).
    The Python blocks of both run as written, from a directory outside the checkout."""
    assert len(README.read_text().splitlines()) < 120  # about 100 lines: the findings one line each, the rest in docs/
    assert README.read_text().index("## Quick start") < README.read_text().index("## Status")
    text = README.read_text() + GUIDE_TEXT
    blocks = [textwrap.dedent(b) for b in re.findall(r"```python\n(.*?)```", text, flags=re.S)]  # a block
    # in a list item is indented with it
    assert len(blocks) >= 3
    outputs = []
    for number, block in enumerate(blocks):
        done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, f"README block {number} failed:\n{block}\n{done.stderr[-3000:]}"
        outputs.append(done.stdout.splitlines())
    worked = outputs[next(i for i, b in enumerate(blocks) if "GraspController" in b)]
    assert len(worked) == 2 and "distal" in worked[1]
    assert (tmp_path / "grasp.gif").stat().st_size > 1000


def test_every_results_table_row_comes_from_the_published_paper_run():
    """One provenance: the README's result tables and gallery come from docs/studies/paper_run/, one reproduce run
    whose configuration and library version are recorded beside its report."""
    import json

    readme = RESULTS.read_text()
    section = readme[readme.index("## Results of `graspmanifold reproduce --preset paper`"):
                     readme.index(VERIFIED_SECTION)]
    published = README.parent / "docs" / "studies" / "paper_run"
    report_rows = set((published / "report.md").read_text().splitlines())
    rows = [line for line in section.splitlines() if line.startswith("|") and not line.startswith("|---")]
    assert len(rows) > 30
    assert [row for row in rows if row not in report_rows] == []
    run = json.loads((published / "run.json").read_text())
    assert run["config"]["postures"] == {"box": 4069, "cylinder": 4220, "sphere": 1885} and run["library_version"]
    assert run["config"]["procedure"] == "paper" and run["datasets"]["cylinder"]["trained_on"] == 4220
    figures = re.findall(r"\]\((paper_run/figures/\w+\.png)\)", section)
    assert len(figures) == 9 and all((RESULTS.parent / f).exists() for f in figures)


def test_the_verified_runs_verdicts_come_from_its_published_run():
    """The verified procedure's verdicts stand beside the paper procedure's, from docs/studies/verified_run/."""
    import json

    readme = RESULTS.read_text()
    section = readme[readme.index(VERIFIED_SECTION):]
    published = README.parent / "docs" / "studies" / "verified_run"
    report_rows = set((published / "report.md").read_text().splitlines())
    rows = [line for line in section.splitlines() if line.startswith("|") and not line.startswith("|---")]
    assert len(rows) >= 12 and [row for row in rows if row not in report_rows] == []
    run = json.loads((published / "run.json").read_text())
    assert run["config"]["procedure"] == "verified"
    assert all(d["trained_on"] < d["candidates"] for d in run["datasets"].values())


def test_every_finding_quotes_numbers_of_the_study_it_links():
    """The README's first screen once quoted one run's numbers beside another's for the same thing. Each finding is
    one item with the link of the report that made it, and every number it quotes stands in that report (spaces
    before a percent sign aside)."""
    readme = README.read_text()
    findings = readme[readme.index("## What was found"):readme.index("## Where to read")]
    items = [item for item in findings.split("\n- ")[1:]]
    assert len(items) >= 6
    for item in items:
        links = re.findall(r"\]\((docs/studies/[\w/]+\.md)\)", item)
        assert len(links) == 1, f"a finding links one study: {item[:80]}"
        study = re.sub(r"\s+%", "%", (README.parent / links[0]).read_text())
        numbers = re.findall(r"[+-]?\d[\d,.]*(?:\s?%|°)?", re.sub(r"(\d)-(\d)", r"\1 \2", re.sub(r"\]\(docs/studies/[^)]*\)", "", item)))  # a range's ends
        missing = [n for n in numbers if re.sub(r"\s+%", "%", n).rstrip(".,") not in study
                   and n.strip("+-").rstrip(".,°% ") not in study]  # a table's cell has the bare number
        assert not missing, f"{links[0]} does not say {missing}"


def test_every_name_the_readme_shows_at_gm_is_there():
    """The README said every public name was at `graspmanifold.*`, but `compare`, `wilson_interval`, `mcnemar`,
    `holm` and `lattice_figure` were only in subpackages."""
    import graspmanifold as gm

    shown = set(re.findall(r"\bgm\.([A-Za-z_][A-Za-z0-9_]*)", README.read_text() + GUIDE_TEXT))
    assert {"compare", "wilson_interval", "mcnemar", "holm", "headroom", "lattice_figure"} <= shown
    assert [name for name in sorted(shown) if not hasattr(gm, name)] == []

