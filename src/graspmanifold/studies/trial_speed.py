"""Benchmark grasp trials: the batched CPU backend against one trial at a time, and the Warp backend.

    python scripts/bench_trials.py [--out DIR] cpu [--grids quick paper] [--workers 1 2]
    python scripts/bench_trials.py [--out DIR] agree [--objects box cylinder sphere] [--som MAP.npz]
    python scripts/bench_trials.py [--out DIR] gpu [--worlds 1024 4096 16384]
    python scripts/bench_trials.py [--out DIR] scale [--worlds 64 1024 8192]

`cpu`: trials per minute of `evaluate(backend="cpu")` (each checkpoint chunk one batch) and of the
same trials run one by one with `trial.run_trial` in the same process pool (the evaluation before
the batched backend), on the plain heuristic for the three paper objects; it checks that both give
the same trials bit for bit. `agree`: CPU against Warp trial by trial on a grid (force closure and
hold), with Wilson intervals and McNemar's test; Warp runs on the GPU, or on Warp's CPU device with
GRASPMANIFOLD_WARP_DEVICE=cpu. `gpu`: Warp trials per minute at several world counts (the paper
grid's poses repeated with pose noise), the first call's kernel compilation timed apart, and the
share of the wall time spent in the physics, then `agree` on the quick grid: the one command to run
the day a GPU is lent. `scale`: what does not need a GPU of trials at GPU scale (issue 71): the set-up at several
world counts, a scene per world against one scene and the starts as arrays, and the host's time per world per
control period, the physics left out (`bench_scale`); Warp on its CPU device where no GPU is lent.
"""

from __future__ import annotations

import argparse
import functools
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..base.io import json_text, markdown_row, markdown_table, software_versions, write_text_atomic
from ..base.workers import parallel_map, usable_cores
from ..control.controller import BatchController
from ..manifold.som import SOM
from ..sim.objects import PAPER_OBJECTS, get_object
from ..sim.posture import closed_posture, open_posture
from .runner import run_study
from ..trials.evaluation import evaluate
from ..trials.grid import check_grid
from ..trials.stats import mcnemar, rate_text
from ..trials.episode import run_trial, run_trials, trial_scene, trial_starts
from ..trials.setup import Noise, TrialSetup

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


def agreement(obj: str, grid: str | np.ndarray, experience: SOM | None = None, cpu_workers: int = 2) -> dict:
    """CPU against Warp, trial by trial, on one object's grid (seed 0).

    Args:
        obj: the object's name.
        grid: a grid preset or poses (n, 4).
        experience: the map both recall from (None: the plain heuristic).
        cpu_workers: the CPU evaluation's worker processes.

    Returns:
        {object, trials (valid on both), force closure and hold counts on each, the trials whose outcome is the
        same, McNemar's p of force closure, the Warp evaluation's wall s}.
    """
    cpu = evaluate(obj, experience, grid, seed=0, workers=cpu_workers)
    start = time.perf_counter()
    warp = evaluate(obj, experience, grid, seed=0, backend="warp")
    wall = time.perf_counter() - start
    valid = cpu.valid & warp.valid
    a, b = cpu.outcomes("force_closure")[valid], warp.outcomes("force_closure")[valid]
    ha, hb = cpu.outcomes("hold")[valid], warp.outcomes("hold")[valid]
    return {"object": obj, "trials": int(valid.sum()), "force_closure_cpu": int(a.sum()),
            "force_closure_warp": int(b.sum()), "same_force_closure": int((a == b).sum()), "hold_cpu": int(ha.sum()),
            "hold_warp": int(hb.sum()), "same_hold": int((ha == hb).sum()), "mcnemar_p_force_closure":
            float(mcnemar(a, b).p_value), "warp_wall_s": wall}


def bench_agree(args: argparse.Namespace) -> None:
    print("\n".join(markdown_table(["object", "trials", "force closure cpu", "warp", "same fc", "hold cpu", "warp",
                                     "same hold", "McNemar p (fc)", "warp wall (s)"], [])))
    total, same_fc = 0, 0
    for obj in args.objects:
        r = agreement(obj, args.grid, None if args.som is None else SOM.load(args.som.format(object=obj)),
                      args.cpu_workers)
        n = r["trials"]
        total, same_fc = total + n, same_fc + r["same_force_closure"]
        print(markdown_row([obj, n, *(rate_text(r[k], n) for k in ("force_closure_cpu", "force_closure_warp",
                                                                  "same_force_closure", "hold_cpu", "hold_warp",
                                                                  "same_hold")),
                            f"{r['mcnemar_p_force_closure']:.2f}", f"{r['warp_wall_s']:.0f}"]), flush=True)
    print(f"\nforce closure agrees trial by trial on {rate_text(same_fc, total)} of the valid trials")


class _StepCounter:
    """Counts the world-steps and times the physics of every `WarpWorlds.step` while it is entered (the real step,
    wrapped: what a benchmark reads of it)."""

    def __enter__(self) -> _StepCounter:
        from ..sim import warp_worlds

        self.world_steps, self.physics_s, self._kind = 0, 0.0, warp_worlds.WarpWorlds
        step = self._step = warp_worlds.WarpWorlds.step

        def counted(worlds: Any, live: np.ndarray, nstep: int) -> dict[int, str]:  # Any: Warp is optional
            start = time.perf_counter()
            try:
                return step(worlds, live, nstep)
            finally:
                self.world_steps += worlds.n * nstep
                self.physics_s += time.perf_counter() - start

        setattr(self._kind, "step", counted)
        return self

    def __exit__(self, *exc: object) -> None:
        setattr(self._kind, "step", self._step)


def warp_speed(obj: str, worlds: int, seed: int = 1) -> dict:
    """Warp trials of the plain heuristic at `worlds` worlds at once: the paper grid's poses repeated, each with
    pose noise (3 mm, 0.05 rad), all in one batch.

    Args:
        obj: the object's name.
        worlds: the worlds.
        seed: the trials' seed.

    Returns:
        {worlds, wall_s, trials_per_minute, world_steps_per_s (of the wall time), physics_share, hold and force
        closure rates}.
    """
    _, paper = check_grid("paper", get_object(obj))
    with _StepCounter() as counter:
        start = time.perf_counter()
        result = evaluate(obj, None, np.resize(paper, (worlds, 4)), seed=seed, noise=Noise(position=0.003, yaw=0.05),
                          backend="warp", batch_size=worlds)
        wall = time.perf_counter() - start
    s = result.summary
    return {"worlds": worlds, "wall_s": wall, "trials_per_minute": 60 * worlds / wall,
            "world_steps_per_s": counter.world_steps / wall, "physics_share": counter.physics_s / wall,
            "hold_rate": s["hold_rate"], "force_closure_rate": s["force_closure_rate"]}


def bench_gpu(args: argparse.Namespace) -> None:
    start = time.perf_counter()
    warp_speed(args.object, 8)
    print(f"first call (8 worlds, kernel compilation included): {time.perf_counter() - start:.0f} s")
    print("\n".join(markdown_table(["worlds", "wall (s)", "trials / min", "world-steps / s", "physics share", "hold",
                                     "force closure"], [])))
    for worlds in args.worlds:
        r = warp_speed(args.object, worlds)
        print(markdown_row([worlds, f"{r['wall_s']:.1f}", f"{r['trials_per_minute']:.0f}",
                            f"{r['world_steps_per_s']:.3g}", f"{r['physics_share']:.0%}", f"{r['hold_rate']:.0%}",
                            f"{r['force_closure_rate']:.0%}"]), flush=True)
    if args.agree_grid == "none":
        return
    print(f"\nagreement with the CPU on the {args.agree_grid} grid:\n")
    bench_agree(argparse.Namespace(objects=list(PAPER_OBJECTS), grid=args.agree_grid, som=None,
                                   cpu_workers=usable_cores()))


def device_check(out: Path, worlds: list[int], *, budget: float = 420.0, agree_poses: int | None = None,
                 obj: str = "cylinder") -> dict:
    """The one prepared device check (`scripts/gpu_check.sh`): Warp trials per minute at each world count (a size
    that would not end inside `budget` s, judged from the last size's time per world, is skipped and said so), then
    CPU against Warp trial by trial on the quick grid of the paper's objects; written to `out` as JSON with what
    made it (the device, the versions, the buffers, whether CUDA graphs were captured).

    Args:
        out: the JSON file.
        worlds: the world counts, in order.
        budget: s the whole check may take.
        agree_poses: the quick grid's first this many poses per object (None: all).
        obj: the object of the speed runs.

    Returns:
        What was written.
    """
    import warp as wp

    from ..sim.warp_worlds import CONSTRAINTS_PER_WORLD, CONTACTS_PER_WORLD, WarpWorlds

    started = time.perf_counter()
    device = WarpWorlds(*trial_starts(TrialSetup(object=get_object(obj), backend="warp"),
                                      np.array([[0.0, 0.0, 0.01, 0.0]]), [np.random.default_rng(0)],
                                      open_posture())).device
    record: dict = {"device": str(device), "device_name": getattr(device, "name", str(device)),
                    "cuda_graphs": bool(device.is_cuda), "buffers_per_world": {
                        "contacts": CONTACTS_PER_WORLD, "constraint_rows": CONSTRAINTS_PER_WORLD},
                    "versions": {**software_versions(), "warp": wp.config.version}, "budget_s": budget,
                    "speed_runs": {"object": obj, "grid": "paper, repeated", "noise": [0.003, 0.05], "seed": 1,
                                   "controller": "the plain heuristic", "protocol": "hold-test"},
                    "agreement_runs": {"grid": "quick", "poses_per_object": agree_poses, "seed": 0,
                                       "controller": "the plain heuristic", "protocol": "hold-test"},
                    "speed": [], "skipped": [], "agreement": []}
    start = time.perf_counter()
    warp_speed(obj, 8)
    record["first_call_s"] = time.perf_counter() - start  # the kernels' compilation with it
    per_world = None
    for n in worlds:
        left = budget - (time.perf_counter() - started)
        if per_world is not None and per_world * n > 0.6 * left:  # the agreement needs the rest
            record["skipped"].append({"worlds": n, "why": f"{per_world * n:.0f} s expected, {left:.0f} s left"})
            continue
        r = warp_speed(obj, n)
        per_world = r["wall_s"] / n
        record["speed"].append(r)
        print(r, flush=True)
    for name in PAPER_OBJECTS:
        grid = check_grid("quick", get_object(name))[1][:agree_poses]
        record["agreement"].append(agreement(name, grid, None, usable_cores()))
        print(record["agreement"][-1], flush=True)
    record["seconds"] = time.perf_counter() - started
    write_text_atomic(out, json_text(record))
    return record


def _map_of_paper_size(seed: int = 0) -> SOM:
    """A 25 x 25 map (the paper's size: what a best match searches) of postures between the open and the closed
    hand; what the host's time depends on is the map's size, not where its postures came from."""
    rng = np.random.default_rng(seed)
    share = rng.random((2000, 1)) * rng.random((2000, 22))
    postures = open_posture() + share * (closed_posture() - open_posture())
    return SOM(25, 25, 22, seed=seed, epochs=5).fit(postures, progress=False)


def _readings(obj: str, experience: SOM | None, worlds: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """What a controller of `worlds` trials on the paper grid sensed, period by period (CPU MuJoCo): its joints
    (worlds, 22) and segment forces (worlds, segments)."""
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    def factory(n: int, hand: object) -> BatchController:
        controller = BatchController(n, experience)
        step = controller.step

        def logged(joints: np.ndarray, forces: np.ndarray) -> np.ndarray:
            seen.append((np.array(joints), np.array(forces)))
            return step(joints, forces)

        setattr(controller, "step", logged)  # the benchmark logs the real controller's inputs
        return controller

    _, paper = check_grid("paper", get_object(obj))
    poses = np.resize(paper, (worlds, 4))
    run_trials(TrialSetup(object=get_object(obj), controller=factory, method="logged"), poses,
               [np.random.default_rng([0, k]) for k in range(worlds)])
    return seen


def _host_seconds(readings: list[tuple[np.ndarray, np.ndarray]], experience: SOM | None, n: int) -> float:
    """s per control period the controller of n worlds takes on the recorded readings, tiled to n worlds."""
    controller = BatchController(n, experience)
    tiled = [(np.resize(j, (n, j.shape[1])), np.resize(f, (n, f.shape[1]))) for j, f in readings]
    start = time.perf_counter()
    for joints, forces in tiled:
        controller.step(joints, forces)
    return (time.perf_counter() - start) / len(tiled)


def bench_scale(args: argparse.Namespace) -> None:
    """Set-up and host time at several world counts, the physics left out (module doc of `sim.warp_worlds`):
    the set-up a scene per world (`trial_scene`, `WarpWorlds.from_scenes`) against one scene and the starts as
    arrays (`trial_starts`), in the same run; the host's share of a control period (the controller on real
    readings, and the worlds' own reads and writes: `set_targets` and a step of no physics)."""
    from ..sim.warp_worlds import CONSTRAINTS_PER_WORLD, CONTACTS_PER_WORLD, WarpWorlds

    obj, setup = get_object(args.object), TrialSetup(object=get_object(args.object), backend="warp")
    _, paper = check_grid("paper", obj)
    initial = open_posture()
    som = _map_of_paper_size()
    readings = {"none": _readings(args.object, None, 64), "som": _readings(args.object, som, 64)}
    print(f"buffers per world: {CONTACTS_PER_WORLD} contacts, {CONSTRAINTS_PER_WORLD} constraint rows; readings of "
          f"{len(readings['none'])} and {len(readings['som'])} periods (64 worlds, {args.object}, CPU MuJoCo)\n")
    print("\n".join(markdown_table(["worlds", "set-up, scene each (s)", "set-up, starts (s)", "of which the starts (s)",
                                     "host: controller (us / world / period)", "with the SOM", "worlds' reads and "
                                     "writes (us / world / period)"], [])))
    WarpWorlds(*trial_starts(setup, paper[:2], [np.random.default_rng(0)] * 2, initial))  # Warp's kernels loaded
    for n in args.worlds:
        poses, rngs = np.resize(paper, (n, 4)), [np.random.default_rng([1, k]) for k in range(n)]
        before = float("nan")
        if n <= args.scenes_up_to:
            start = time.perf_counter()
            WarpWorlds.from_scenes([trial_scene(setup, pose, rng, initial) for pose, rng in zip(poses, rngs)])
            before = time.perf_counter() - start
        rngs = [np.random.default_rng([1, k]) for k in range(n)]  # the trials' streams: made by either set-up's caller
        start = time.perf_counter()
        scene, starts = trial_starts(setup, poses, rngs, initial)
        placed = time.perf_counter() - start
        worlds = WarpWorlds(scene, starts)
        after = time.perf_counter() - start
        everyone, targets = np.arange(n), np.tile(initial, (n, 1))
        start = time.perf_counter()
        for _ in range(args.periods):
            worlds.set_targets(everyone, targets)
            worlds.step(everyone, 0)
        own = (time.perf_counter() - start) / args.periods
        plain, recalled = (_host_seconds(readings[k], None if k == "none" else som, n) for k in ("none", "som"))
        print(markdown_row([n, f"{before:.2f}", f"{after:.2f}", f"{placed:.3f}", f"{1e6 * plain / n:.2f}",
                            f"{1e6 * recalled / n:.2f}", f"{1e6 * own / n:.2f}"]), flush=True)


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
    scale = sub.add_parser("scale")
    scale.add_argument("--object", default="cylinder")
    scale.add_argument("--worlds", nargs="+", type=int, default=[64, 1024, 8192])
    scale.add_argument("--periods", type=int, default=20, help="control periods the worlds' reads and writes are timed")
    scale.add_argument("--scenes-up-to", type=int, default=8192, help="time the set-up of a scene each up to this many "
                       "worlds (8,192 scenes take minutes)")
    check = sub.add_parser("device-check", help="the one prepared check of a lent GPU (scripts/gpu_check.sh)")
    check.add_argument("--json", default="gpu_check.json", help="the JSON written")
    check.add_argument("--worlds", nargs="+", type=int, default=[2048, 8192, 32768])
    check.add_argument("--budget", type=float, default=420.0, help="s the whole check may take")
    check.add_argument("--dry-run", action="store_true", help="4 and 8 worlds, 2 poses per object, Warp's CPU device")
    args = parser.parse_args(argv)
    if args.what == "device-check" and args.dry_run:
        os.environ.setdefault("GRASPMANIFOLD_WARP_DEVICE", "cpu")

    def body(run: object) -> None:
        print(f"graspmanifold from {Path(__file__).resolve().parents[1]}")
        {"cpu": bench_cpu, "agree": bench_agree, "gpu": bench_gpu, "scale": bench_scale,
         "device-check": lambda a: device_check(Path(a.json), [4, 8] if a.dry_run else a.worlds, budget=a.budget,
                                                agree_poses=2 if a.dry_run else None)}[args.what](args)

    run_study(args.out, 1, body, f"trial_speed_{args.what}.md")  # its own pools: the workers are what it times


if __name__ == "__main__":
    main()
