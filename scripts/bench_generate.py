"""Benchmark the spring-based posture generator on the paper's dataset sizes.

    python scripts/bench_generate.py [--workers 2] [--preset paper] [--out DIR]

Generates the box, cylinder and sphere sets, and reports wall time, accepted postures per second
per worker, the acceptance ratio and how clustered the data is around its starting postures.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from graspmanifold.control.generator import DATASET_PRESETS, GeneratorParams, generate_postures, verify_postures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--preset", choices=sorted(DATASET_PRESETS), default="paper")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="directory to save the sets in (optional)")
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores, {args.workers} workers, preset {args.preset}\n")
    print("| object | postures | wall (s) | postures / s / worker | acceptance | starts | within-start (°) | between starts (°) |")
    print("|---|---|---|---|---|---|---|---|")
    total_n, total_t = 0, 0.0
    for name, n in DATASET_PRESETS[args.preset].items():
        start = time.perf_counter()
        candidates = generate_postures(name, n, seed=args.seed, workers=args.workers, params=GeneratorParams(verify=False))
        postures = verify_postures(candidates, name, args.workers)  # n candidates walked and verified
        seconds = time.perf_counter() - start
        total_n, total_t = total_n + n, total_t + seconds
        sep = postures.cluster_separation()
        print(f"| {name} | {n} | {seconds:.1f} | {n / seconds / args.workers:.1f} | "
              f"{postures.metadata['acceptance_ratio']:.2f} | {sep['starts']} | {sep['within_deg']:.1f} | "
              f"{sep['between_deg']:.1f} |", flush=True)
        if args.out:
            postures.save(Path(args.out) / f"{name}.npz")
    print(f"| all | {total_n} | {total_t:.1f} | {total_n / total_t / args.workers:.1f} | | | | |")


if __name__ == "__main__":
    main()
