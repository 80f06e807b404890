"""Benchmark and results of the grasp controller on a grid (quick by default), every object and method.

    python scripts/bench_evaluate.py [--data DIR] [--workers 2] [--grid quick|paper|wide]

Uses the paper-size posture sets in DIR (generated there first if missing), trains one 25 x 25
SOM per object and one for all objects (paper schedule, online), then evaluates none / database /
SOM per object, the multi-object SOM per object, and the resumed learning. Prints markdown tables.

`--grid wide` asks where experience could matter: the reachable poses of a grid well beyond the
presets (x +-3 cm, z +-4 cm, gaps 1-5 cm, yaws +-1 rad), with force closure broken down by grid axis.
"""

from __future__ import annotations

import argparse
import itertools
import time
from pathlib import Path

import numpy as np

import graspmanifold as gm
from graspmanifold.evaluation import run_trial


def posture_sets(directory: Path, workers: int) -> dict[str, gm.PostureSet]:
    sets = {}
    for name, n in gm.PRESETS["paper"].items():
        path = directory / f"{name}.npz"
        if not path.exists():
            gm.generate_postures(name, n, seed=0, workers=workers).save(path)
        sets[name] = gm.PostureSet.load(path)
    return sets


def wide_grid(obj: str) -> np.ndarray:
    """Reachable poses of a grid beyond the presets: x, z, gap, yaw (m, rad)."""
    yaws = [0.0] if gm.get_object(obj).shape == "sphere" else [-1.0, -0.5, 0.0, 0.5, 1.0]
    axes = ([-0.03, -0.015, 0.0, 0.015, 0.03], [-0.04, -0.02, 0.0, 0.02, 0.04], [0.01, 0.03, 0.05], yaws)
    poses = np.array(list(itertools.product(*axes)))
    return poses[gm.reachable(obj, poses)]


def axis_breakdown(results: dict[str, gm.EvaluationResult]) -> None:
    """Force-closure rate of each method for every value of every grid axis."""
    labels = list(results)
    print(f"| axis | value | trials | {' | '.join(labels)} |\n|---|---|---|{'---|' * len(labels)}")
    grid = np.array([t.grid_pose for t in results[labels[0]].trials])
    for column, axis in enumerate(("x", "z", "gap", "yaw")):
        for value in np.unique(grid[:, column]):
            rows = grid[:, column] == value
            rates = [np.mean([t.force_closure for t, row in zip(results[m].trials, rows) if row]) for m in labels]
            print(f"| {axis} | {value:+.3f} | {rows.sum()} | {' | '.join(f'{r:.0%}' for r in rates)} |")


def trial_speed(obj: str, experience) -> tuple[float, float]:
    """Simulated seconds per wall second of one trial (grasp and hold test), and its wall time."""
    start = time.perf_counter()
    trial = run_trial(gm.get_object(obj), experience, np.array([0.0, 0.0, 0.01, 0.0]), np.random.default_rng(0))
    wall = time.perf_counter() - start
    simulated = trial.time_to_grasp + 6 * 0.5
    return simulated / wall, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="data", help="directory with (or for) box/cylinder/sphere.npz")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--grid", default="quick")
    args = parser.parse_args()
    sets = posture_sets(Path(args.data), args.workers)
    maps = {name: gm.SOM(25, 25, 22, seed=0).fit(s.postures) for name, s in sets.items()}
    everything = gm.PostureSet.concatenate(list(sets.values())).postures
    maps["all"] = gm.SOM(25, 25, 22, seed=0).fit(everything)

    speed, wall = trial_speed("cylinder", maps["cylinder"])
    print(f"one trial (cylinder, SOM, grasp + 3 s hold test): {wall:.2f} s wall, {speed:.1f} simulated s per wall s\n")
    print("| object | method | trials | force closure | hold | mean ε | time to grasp (s) | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    results = {}
    for name, s in sets.items():
        methods = {"none": None, "database": gm.PostureDatabase(s.postures), "som": maps[name], "som (all objects)": maps["all"]}
        for label, experience in methods.items():
            start = time.perf_counter()
            grid = wide_grid(name) if args.grid == "wide" else args.grid
            r = gm.evaluate(name, experience, grid, seed=0, workers=args.workers)
            seconds = time.perf_counter() - start
            results[(name, label)] = r
            m = r.summary
            print(f"| {name} | {label} | {m['trials']} | {m['force_closure_rate']:.0%} | {m['hold_rate']:.0%} | "
                  f"{m['mean_epsilon']:.4f} | {m['mean_time_to_grasp']:.2f} | {seconds:.1f} |", flush=True)

    if args.grid == "wide":
        for name in sets:
            print(f"\n{name}: force closure by grid axis\n")
            axis_breakdown({label: r for (n, label), r in results.items() if n == name})
    print("\nresumed learning (10 epochs, lr 0.1 -> 0.05, sigma 3 -> 0.7) with the SOM's successful postures:\n")
    print("| object | postures | distance CV before → after | max distance (°) before → after | "
          "unsupported by evaluation before → after | evaluation on training-unsupported nodes |")
    print("|---|---|---|---|---|---|")
    for name, s in sets.items():
        successes = results[(name, "som")].successful_postures()
        if len(successes) == 0:
            print(f"| {name} | 0 | | | | |")
            continue
        _, report = gm.resume_learning(maps[name], successes, training=s.postures)
        b, a = report["before"], report["after"]
        print(f"| {name} | {len(successes)} | {b['distance_cv']:.2f} → {a['distance_cv']:.2f} | "
              f"{b['distance_max_deg']:.1f} → {a['distance_max_deg']:.1f} | {b['unsupported_by_evaluation']} → "
              f"{a['unsupported_by_evaluation']} | {b['evaluation_on_unsupported_nodes']:.0%} |")


if __name__ == "__main__":
    main()
