"""Benchmark one grasp trial: the plain heuristic on the quick grid of every object, one process.

    python scripts/bench_trials.py [--repeats 3]

A trial is the grasp, the six-direction hold test and the margin ramp (`trial.run_trial`).
Prints the best of `--repeats` wall times per object and trials per second; run it with another
checkout's `src` on PYTHONPATH to compare two versions on the same machine.
"""

from __future__ import annotations

import argparse
import time

import graspmanifold as gm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"graspmanifold from {gm.__file__}")
    print("| object | trials | best wall (s) | trials / s |\n|---|---|---|---|")
    total_trials, total_wall = 0, 0.0
    for obj in ("box", "cylinder", "sphere"):
        walls = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            result = gm.evaluate(obj, None, "quick", seed=0, workers=1)
            walls.append(time.perf_counter() - start)
        n = len(result.trials)
        total_trials, total_wall = total_trials + n, total_wall + min(walls)
        print(f"| {obj} | {n} | {min(walls):.2f} | {n / min(walls):.2f} |")
    print(f"| all | {total_trials} | {total_wall:.2f} | {total_trials / total_wall:.2f} |")


if __name__ == "__main__":
    main()
