"""Benchmark grasp trials: the batched CPU backend against one trial at a time, and the Warp backend.

    python scripts/bench_trials.py [--out DIR] cpu [--grids quick paper] [--workers 1 2]
    python scripts/bench_trials.py [--out DIR] agree [--objects box cylinder sphere] [--som MAP.npz]
    python scripts/bench_trials.py [--out DIR] gpu [--worlds 1024 4096 16384]

`cpu`: trials per minute of `evaluate(backend="cpu")` (each checkpoint chunk one batch) and of the
same trials run one by one with `trial.run_trial` in the same process pool (the evaluation before
the batched backend), on the plain heuristic for the three paper objects; it checks that both give
the same trials bit for bit. `agree`: CPU against Warp trial by trial on a grid (force closure and
hold), with Wilson intervals and McNemar's test; Warp runs on the GPU, or on Warp's CPU device with
GRASPMANIFOLD_WARP_DEVICE=cpu. `gpu`: Warp trials per minute at several world counts (the paper
grid's poses repeated with pose noise), the first call's kernel compilation timed apart, and the
share of the wall time spent in the physics, then `agree` on the quick grid: the one command to run
the day a GPU is lent.
"""

from __future__ import annotations

import argparse
import functools
import time
from pathlib import Path

import numpy as np

from ..base.io import markdown_row, markdown_table
from ..base.workers import parallel_map, usable_cores
from ..manifold.som import SOM
from ..sim.objects import PAPER_OBJECTS, get_object
from .runner import run_study
from ..trials.evaluation import evaluate
from ..trials.grid import check_grid
from ..trials.stats import mcnemar, rate_text
from ..trials.trial import Noise, TrialSetup, run_trial

FIELDS = ("posture", "touching", "epsilon", "hold", "hold_displacement", "time_to_grasp", "matches", "margin",
          "penetration", "fault")


def _one_by_one(task: tuple[list[int], np.ndarray], *, obj: str) -> list:
    indices, poses = task
    setup = TrialSetup(object=get_object(obj))
    return [run_trial(setup, pose, np.random.default_rng([0, i])) for i, pose in zip(indices, poses)]


def one_by_one(obj: str, grid: str, workers: int) -> list:
    """The trials of `evaluate(obj, None, grid, seed=0, workers=workers)`, one `run_trial` at a time."""
    _, poses = check_grid(grid, get_object(obj))
    size = max(1, min(16, -(-len(poses) // (4 * workers))))
    tasks = [(list(range(i, min(i + size, len(poses)))), poses[i: i + size]) for i in range(0, len(poses), size)]
    return [t for chunk in parallel_map(functools.partial(_one_by_one, obj=obj), tasks, workers) for t in chunk]


def bench_cpu(args: argparse.Namespace) -> None:
    print("\n".join(markdown_table(["grid", "workers", "trials", "one by one (s)", "trials / min", "batched (s)", "trials / min", "speed-up", "same"], [])))
    for grid in args.grids:
        for workers in args.workers:
            counts, old, new, same = 0, 0.0, 0.0, True
            for obj in args.objects:
                start = time.perf_counter()
                reference = one_by_one(obj, grid, workers)
                old += time.perf_counter() - start
                start = time.perf_counter()
                batched = evaluate(obj, None, grid, seed=0, workers=workers).trials
                new += time.perf_counter() - start
                counts += len(batched)
                same &= all(np.array_equal(getattr(a, f), getattr(b, f)) for a, b in zip(reference, batched)
                            for f in FIELDS)
            print(markdown_row([grid, workers, counts, f"{old:.1f}", f"{60 * counts / old:.0f}", f"{new:.1f}",
                                f"{60 * counts / new:.0f}", f"{old / new:.2f}x", "yes" if same else "NO"]), flush=True)


def bench_agree(args: argparse.Namespace) -> None:
    print("\n".join(markdown_table(["object", "trials", "force closure cpu", "warp", "same fc", "hold cpu", "warp", "same hold", "McNemar p (fc)", "warp wall (s)"], [])))
    total, same_fc = 0, 0
    for obj in args.objects:
        experience = None if args.som is None else SOM.load(args.som.format(object=obj))
        cpu = evaluate(obj, experience, args.grid, seed=0, workers=args.cpu_workers)
        start = time.perf_counter()
        warp = evaluate(obj, experience, args.grid, seed=0, backend="warp")
        wall = time.perf_counter() - start
        valid = cpu.valid & warp.valid
        n = int(valid.sum())
        a, b = cpu.outcomes("force_closure")[valid], warp.outcomes("force_closure")[valid]
        ha, hb = cpu.outcomes("hold")[valid], warp.outcomes("hold")[valid]
        total, same_fc = total + n, same_fc + int((a == b).sum())
        print(markdown_row([obj, n, rate_text(int(a.sum()), n), rate_text(int(b.sum()), n),
                            rate_text(int((a == b).sum()), n), rate_text(int(ha.sum()), n), rate_text(int(hb.sum()), n),
                            rate_text(int((ha == hb).sum()), n), f"{mcnemar(a, b).p_value:.2f}", f"{wall:.0f}"]),
              flush=True)
    print(f"\nforce closure agrees trial by trial on {rate_text(same_fc, total)} of the valid trials")


def bench_gpu(args: argparse.Namespace) -> None:
    from ..sim import warp_worlds

    physics = {"s": 0.0}
    step = warp_worlds.WarpWorlds.step

    def timed_step(self, worlds, nstep):
        start = time.perf_counter()
        try:
            return step(self, worlds, nstep)
        finally:
            physics["s"] += time.perf_counter() - start

    warp_worlds.WarpWorlds.step = timed_step  # type: ignore[method-assign]  # the benchmark times the real step
    obj = get_object(args.object)
    _, paper = check_grid("paper", obj)
    noise = Noise(position=0.003, yaw=0.05)
    start = time.perf_counter()
    evaluate(obj, None, paper[:8], seed=0, noise=noise, backend="warp")
    print(f"first call (8 worlds, kernel compilation included): {time.perf_counter() - start:.0f} s")
    print("\n".join(markdown_table(["worlds", "wall (s)", "trials / min", "physics share", "hold", "force closure"], [])))
    for worlds in args.worlds:
        poses = np.resize(paper, (worlds, 4))
        physics["s"] = 0.0
        start = time.perf_counter()
        result = evaluate(obj, None, poses, seed=1, noise=noise, backend="warp", batch_size=worlds)
        wall = time.perf_counter() - start
        s = result.summary
        print(markdown_row([worlds, f"{wall:.1f}", f"{60 * worlds / wall:.0f}", f"{physics['s'] / wall:.0%}",
                            f"{s['hold_rate']:.0%}", f"{s['force_closure_rate']:.0%}"]), flush=True)
    if args.agree_grid == "none":
        return
    print(f"\nagreement with the CPU on the {args.agree_grid} grid:\n")
    bench_agree(argparse.Namespace(objects=list(PAPER_OBJECTS), grid=args.agree_grid, som=None,
                                   cpu_workers=usable_cores()))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="study-trial-speed", help="the folder its report (trial_speed_WHAT.md) is "
                        "kept in")
    sub = parser.add_subparsers(dest="what", required=True)
    cpu = sub.add_parser("cpu")
    cpu.add_argument("--grids", nargs="+", default=["quick", "paper"])
    cpu.add_argument("--workers", nargs="+", type=int, default=[1, 2])
    cpu.add_argument("--objects", nargs="+", default=list(PAPER_OBJECTS))
    agree = sub.add_parser("agree")
    agree.add_argument("--objects", nargs="+", default=list(PAPER_OBJECTS))
    agree.add_argument("--grid", default="quick")
    agree.add_argument("--cpu-workers", type=int, default=2)
    agree.add_argument("--som", help="recall from this map (the paper's reading), e.g. run/maps/{object}.npz")
    gpu = sub.add_parser("gpu")
    gpu.add_argument("--object", default="cylinder")
    gpu.add_argument("--worlds", nargs="+", type=int, default=[1024, 4096, 16384])
    gpu.add_argument("--agree-grid", default="quick", help="the grid of the CPU agreement that follows ('none': none)")
    args = parser.parse_args(argv)

    def body(run: object) -> None:
        print(f"graspmanifold from {Path(__file__).resolve().parents[1]}")
        {"cpu": bench_cpu, "agree": bench_agree, "gpu": bench_gpu}[args.what](args)

    run_study(args.out, 1, body, f"trial_speed_{args.what}.md")  # its own pools: the workers are what it times


if __name__ == "__main__":
    main()
