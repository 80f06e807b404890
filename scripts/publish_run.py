"""Publish a finished `reproduce` run as the documentation's one source of results.

    python scripts/publish_run.py RUN_DIR [--to docs/studies/paper_run]

Copies the run's report.md, summary.json, run.json and its PNG figures into one folder, replacing
what was there, so that the docs/studies/results.md's tables and gallery (which quote and link that folder; a test
checks every docs/studies/results.md table row against report.md) all come from one run whose configuration and
library version are recorded beside them.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a finished graspmanifold reproduce directory")
    parser.add_argument("--to", default=str(Path(__file__).resolve().parents[1] / "docs" / "studies" / "paper_run"))
    args = parser.parse_args()
    run, target = Path(args.run), Path(args.to)
    for name in ("report.md", "summary.json", "run.json"):
        if not (run / name).exists():
            raise SystemExit(f"error: {run} is not a finished reproduce run (no {name})")
    staging = target.with_name(target.name + ".new")
    shutil.rmtree(staging, ignore_errors=True)
    (staging / "figures").mkdir(parents=True)
    for name in ("report.md", "summary.json", "run.json"):
        shutil.copy2(run / name, staging / name)
    for figure in sorted((run / "figures").glob("*.png")):
        shutil.copy2(figure, staging / "figures" / figure.name)
    previous = target.with_name(target.name + ".old")  # the published run stays whole until the new one is in place
    shutil.rmtree(previous, ignore_errors=True)
    if target.exists():
        target.rename(previous)
    staging.rename(target)
    shutil.rmtree(previous, ignore_errors=True)
    config = json.loads((target / "run.json").read_text())
    print(f"published {run} (library {config['library_version']}) to {target}")


if __name__ == "__main__":
    main()
