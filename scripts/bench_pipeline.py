"""Benchmark the whole pipeline through its own stages: `reproduce`, timed stage by stage.

    python scripts/bench_pipeline.py [--preset quick|paper] [--workers 2] [--out DIR]

Runs `graspmanifold.paper.reproduce.reproduce` into DIR (a fresh temporary directory by default, so
every stage runs) and prints, from the stage manifests it writes, the wall time of each stage,
postures or trials per second where a stage makes them, and the evaluation rates from its summary.
There is no second pipeline here: what is timed is what `graspmanifold reproduce` runs.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from graspmanifold.base.io import markdown_table
from graspmanifold.paper.reproduce import PRESETS, reproduce


def stage_rows(out: Path, summary: dict) -> list[tuple[str, float, str]]:
    """(stage, seconds, throughput) for every stage, in the order they ran."""
    trials = {(r["object"], r["method"]): r["trials"] + r.get("invalid_trials", 0) for r in summary["evaluation"]}
    candidates = json.loads((out / "run.json").read_text())["config"]["postures"]
    rows = []
    for manifest in sorted((out / "stages").glob("*.json"), key=lambda p: p.stat().st_mtime):
        name, seconds = manifest.stem, json.loads(manifest.read_text())["seconds"]
        kind, _, rest = name.partition("_")
        if kind == "generate":
            rate = f"{candidates[rest] / seconds:.1f} candidates/s"
        elif kind == "evaluate":
            obj, _, method = rest.partition("_")
            rate = f"{trials[(obj, method)] / seconds:.1f} trials/s"
        else:
            rate = ""
        rows.append((name, seconds, rate))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=sorted(PRESETS), default="quick")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", help="run directory (default: a fresh temporary one); stages already "
                        "finished there are reused and keep the time they took when they ran")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(args.out or scratch)
        start = time.perf_counter()
        summary = reproduce(out, args.preset, args.workers, log=lambda line: None)
        wall = time.perf_counter() - start
        print(f"{os.cpu_count()} cores, {args.workers} workers, preset {args.preset}: {wall:.1f} s wall\n")
        print("\n".join(markdown_table(["stage", "wall (s)", "throughput"], [
            [name, f"{seconds:.1f}", rate] for name, seconds, rate in stage_rows(out, summary)])))
        print()
        print("\n".join(markdown_table(["object", "method", "trials", "hold", "force closure"], [
            [r["object"], r["method"], r["trials"], f"{r['hold_rate']:.0%}", f"{r['force_closure_rate']:.0%}"]
            for r in summary["evaluation"]])))


if __name__ == "__main__":
    main()
