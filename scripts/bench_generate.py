"""Benchmark the spring-based posture generator on the paper's dataset sizes.

    python scripts/bench_generate.py [--workers 2] [--preset paper] [--out DIR]
    python scripts/bench_generate.py --defaults [--n 40] [--workers 1] [--objects box cylinder sphere]
    python scripts/bench_generate.py --defaults --replay-floor [--n 40] [--workers 1] [--objects box cylinder]

Generates the box, cylinder and sphere sets, and reports wall time, accepted postures per second
per worker, the acceptance ratio and how clustered the data is around its starting postures.
`--defaults`: `generate_postures(obj, n)` with the library's defaults (verified postures), the verified
postures per second, the candidates drawn and their verified share; it runs against any version of the
library (PYTHONPATH=OTHER/src) for a before/after pair.
`--replay-floor` adds the seconds the verifier (`GraspVerifier`) takes to replay the kept postures alone: the
verification's cost of the grasps that are kept, a floor under the generation's time.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from graspmanifold.base.errors import GenerationError
from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.synthesis.generator import DATASET_PRESETS, GeneratorParams, generate_postures, verify_postures
from graspmanifold.sim.objects import get_object


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--preset", choices=sorted(DATASET_PRESETS), default="paper")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="directory to save the sets in (optional)")
    parser.add_argument("--defaults", action="store_true", help="verified postures with the defaults instead")
    parser.add_argument("--n", type=int, default=40, help="postures per object with --defaults")
    parser.add_argument("--objects", nargs="+", default=list(DATASET_PRESETS["paper"]), help="with --defaults")
    parser.add_argument("--replay-floor", action="store_true",
                        help="time the verifier's replays of the kept postures alone")
    args = parser.parse_args()
    if args.defaults or args.replay_floor:
        return bench_defaults(args.objects, args.n, args.workers, args.seed, args.replay_floor)
    print(f"{os.cpu_count()} cores, {args.workers} workers, preset {args.preset}\n")
    print("\n".join(markdown_table(["object", "postures", "wall (s)", "postures / s / worker", "acceptance", "starts", "within-start (°)", "between starts (°)"], [])))
    total_n, total_t = 0, 0.0
    for name, n in DATASET_PRESETS[args.preset].items():
        start = time.perf_counter()
        candidates = generate_postures(name, n, seed=args.seed, workers=args.workers,
                                       params=GeneratorParams(verify=False))
        postures = verify_postures(candidates, name, args.workers)  # n candidates walked and verified
        seconds = time.perf_counter() - start
        total_n, total_t = total_n + n, total_t + seconds
        sep = postures.cluster_separation()
        print(markdown_row([name, n, f"{seconds:.1f}", f"{n / seconds / args.workers:.1f}",
                            f"{postures.metadata['acceptance_ratio']:.2f}", sep["starts"], f"{sep['within_deg']:.1f}",
                            f"{sep['between_deg']:.1f}"]), flush=True)
        if args.out:
            postures.save(Path(args.out) / f"{name}.npz")
    print(markdown_row(["all", total_n, f"{total_t:.1f}", f"{total_n / total_t / args.workers:.1f}", "", "", "", ""]))


def bench_defaults(names: list[str], n: int, workers: int, seed: int, replay_floor: bool = False) -> None:
    """Verified postures per second of `generate_postures(obj, n)` with its defaults, per object; with
    `replay_floor`, the seconds of replaying the kept postures alone (one core)."""
    print(f"{os.cpu_count()} cores, {workers} workers, generate_postures(obj, {n}) with its defaults\n")
    print("\n".join(markdown_table(["object", "postures", "wall (s)", "verified postures / s", "candidates", "verified share",
                                   *(["kept replayed (s)"] if replay_floor else [])], [])))
    for name in names:
        start = time.perf_counter()
        try:
            postures = generate_postures(name, n, seed=seed, workers=workers, progress=False)
        except GenerationError as error:
            seconds = time.perf_counter() - start
            print(markdown_row([name, n, f"{seconds:.1f}", "–", f"GenerationError: {error}", ""]), flush=True)
            continue
        seconds, meta, floor = time.perf_counter() - start, postures.metadata, []
        if replay_floor:  # imported here: --defaults runs on versions without it
            from graspmanifold.judging.replay import GraspVerifier
            verifier, start = GraspVerifier(get_object(name)), time.perf_counter()
            assert all(verifier(q, pose[:3], pose[3:]).hold for q, pose in zip(postures.postures, postures.hand_poses))
            floor = [f"{time.perf_counter() - start:.1f}"]
        print(markdown_row([name, n, f"{seconds:.1f}", f"{n / seconds:.2f}", meta["candidates"],
                            f"{meta['verified_ratio']:.0%}", *floor]), flush=True)

if __name__ == "__main__":
    main()
