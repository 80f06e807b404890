"""Benchmark and results of the grasp controller on the quick grid, every object and method.

    python scripts/bench_evaluate.py [--data DIR] [--workers 2] [--grid quick]

Uses the paper-size posture sets in DIR (generated there first if missing), trains one 25 x 25
SOM per object and one for all objects (paper schedule, online), then evaluates none / database /
SOM per object, the multi-object SOM per object, and the resumed learning. Prints markdown tables.
"""

from __future__ import annotations

import argparse
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
            r = gm.evaluate(name, experience, args.grid, seed=0, workers=args.workers)
            seconds = time.perf_counter() - start
            results[(name, label)] = r
            m = r.summary
            print(f"| {name} | {label} | {m['trials']} | {m['force_closure_rate']:.0%} | {m['hold_rate']:.0%} | "
                  f"{m['mean_epsilon']:.4f} | {m['mean_time_to_grasp']:.2f} | {seconds:.1f} |", flush=True)

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
