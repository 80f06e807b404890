"""Trials per minute on one core: the plain heuristic on a sample of a grid, in this process.

    python scripts/bench_trials_per_minute.py [--object cylinder] [--grid paper] [--every 3]

Run it beside another checkout (`PYTHONPATH=OTHER/src python scripts/bench_trials_per_minute.py`),
alternating, to compare two commits on one machine; it prints the outcomes' counts so that the runs can be
checked to agree.
"""

from __future__ import annotations

import argparse
import time

import graspmanifold as gm
from graspmanifold.trials.grid import check_grid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="cylinder")
    parser.add_argument("--grid", default="paper")
    parser.add_argument("--every", type=int, default=3, help="every k-th pose of the grid")
    args = parser.parse_args()
    poses = check_grid(args.grid, gm.get_object(args.object))[1][::args.every]
    started = time.perf_counter()
    result = gm.evaluate(args.object, None, poses, seed=0, workers=1, progress=False)
    seconds = time.perf_counter() - started
    print(f"{gm.__file__.split('/src/')[0]}: {len(poses)} trials in {seconds:.1f} s = {60 * len(poses) / seconds:.0f} "
          f"trials/min; hold {int(result.outcomes('hold').sum())}, force closure "
          f"{int(result.outcomes('force_closure').sum())}")


if __name__ == "__main__":
    main()
