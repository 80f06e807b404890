"""Where a trial's time goes: physics steps and seconds per phase, on one core, in this process.

    python scripts/profile_trials.py [--out DIR] trials [--grid paper] [--every 9] [--margin]
    python scripts/profile_trials.py generator [--object cylinder] [--n 20]
    python scripts/profile_trials.py stepping [--worlds 16] [--threads 2]

`trials` runs the plain heuristic on every k-th pose of a grid (`paper`, `quick`, or `benchmark`: the
benchmark's test poses of every object and placement), each object's poses as one batch as `evaluate` runs
a chunk, and splits every world's control periods into its phases from its outcome (grasping until the
controller is done, then the hold test for `Judgement.hold_time`, then the margin's ramp): physics steps per
phase, seconds of `mj_step` (with the per-period health check) per phase, and the Python around the physics
(the controller, the tactile reads, epsilon at release, the judging loop). `generator` does the same for the
posture generator's phases: the walk (the hand gliding with its springs), the settling, the candidate test,
and the verifier's replay (pressing, then the hold test). `stepping` times one control period (10 steps) of
N grasping worlds three ways: the trials' Python loop of `mj_step`, `mujoco.rollout` (its own thread pool,
no Python between steps; the state copied in and out, and `mj_forward` for the contacts the tactile
reads need), and what a bare `mj_step` call costs on an empty model (the loop's ceiling on Python overhead).

The timings wrap the library's own methods (no copy of their code); the wrappers' own cost, a few
microseconds per call, is inside the Python share.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from collections.abc import Callable

import numpy as np

from ..base.io import markdown_table
from ..control.controller import BatchController
from ..judging import judge, replay
from ..sim.objects import PAPER_SHAPES, get_object
from ..sim.posture import closed_posture, open_posture
from ..sim.scene import facing_pose
from ..sim.worlds import CpuWorlds
from ..synthesis import springs
from ..synthesis.generator import generate_postures
from ..trials.benchmark import OBJECTS, PLACEMENTS, benchmark_grid
from ..trials.grid import check_grid, reachable
from ..trials.episode import run_trials
from ..trials.setup import TrialSetup
from .runner import run_study

SECONDS: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)


def timed(owner: object, name: str, label: str) -> None:
    """Replace `owner.name` by a wrapper that adds its seconds to SECONDS[label]."""
    original: Callable = getattr(owner, name)

    def wrapper(*args, **kwargs):
        started = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            SECONDS[label] += time.perf_counter() - started
            CALLS[label] += 1

    setattr(owner, name, wrapper)


def table(rows: list[tuple], header: tuple) -> str:
    return "\n".join(markdown_table(header, rows))


def profile_trials(grid: str, every: int, margin: bool) -> None:
    if grid == "benchmark":
        cells = [(o.object, benchmark_grid(o.object.name, p)) for o in OBJECTS.values() for p in PLACEMENTS]
    else:
        cells = [(get_object(name), check_grid(grid, get_object(name))[1]) for name in PAPER_SHAPES]
    per_world: list[list[float]] = []  # physics seconds of every advance of the current batch's worlds
    original_step = CpuWorlds.step

    def step(self, worlds, nstep):  # one world at a time, timed: what CpuWorlds.step does, in the same order
        failed = {}
        for world in worlds:
            started = time.perf_counter()
            failed.update(original_step(self, np.array([world]), nstep))
            per_world[world].append(time.perf_counter() - started)
        return failed

    setattr(CpuWorlds, "step", step)
    timed(BatchController, "step", "controller")
    timed(CpuWorlds, "segment_forces", "tactile reads")
    timed(CpuWorlds, "joints", "tactile reads")
    timed(CpuWorlds, "object_positions", "judging loop reads")
    timed(judge, "reading_epsilon", "epsilon at release")
    phases = ("grasp", "hold", "margin")
    steps: dict[str, int] = defaultdict(int)
    physics: dict[str, float] = defaultdict(float)
    trials, wall, judged_held = 0, 0.0, 0
    for obj, poses in cells:
        poses = poses[reachable(obj, poses)][::every]
        setup = TrialSetup(object=obj, margin=margin)
        per_world[:] = [[] for _ in poses]
        period = setup.params.control_period
        nstep = round(period / 0.002)
        started = time.perf_counter()
        results = run_trials(setup, poses, [np.random.default_rng([0, i]) for i in range(len(poses))])
        wall += time.perf_counter() - started
        trials += len(poses)
        for trial, periods in zip(results, per_world):
            judged_held += trial.hold
            grasp = int(round(trial.time_to_grasp / period)) if trial.valid else len(periods)
            hold = int(round(trial.hold_time / period)) if trial.valid else 0
            for phase, part in zip(phases, (periods[:grasp], periods[grasp:grasp + hold], periods[grasp + hold:])):
                steps[phase] += nstep * len(part)
                physics[phase] += sum(part)
    total_physics = sum(physics.values())
    python = {label: SECONDS[label] for label in ("controller", "tactile reads", "epsilon at release",
                                                  "judging loop reads")}
    python["other Python (judging loop, set-up, targets)"] = wall - total_physics - sum(python.values())
    rows = [(phase, f"{steps[phase] / trials:.0f}", f"{1000 * physics[phase] / trials:.1f}",
             f"{100 * physics[phase] / wall:.1f} %", f"{1e6 * physics[phase] / max(1, steps[phase]):.0f}")
            for phase in phases]
    rows += [(label, "", f"{1000 * seconds / trials:.1f}", f"{100 * seconds / wall:.1f} %", "")
             for label, seconds in python.items()]
    rows.append(("total", f"{sum(steps.values()) / trials:.0f}", f"{1000 * wall / trials:.1f}", "100 %",
                 f"{1e6 * total_physics / sum(steps.values()):.0f}"))
    print(f"{grid} grid, every {every}. pose: {trials} trials ({judged_held} held), "
          f"margin {'on' if margin else 'off'}, "
          f"{60 * trials / wall:.0f} trials/min on one core\n")
    print(table(rows, ("phase", "steps / trial", "ms / trial", "share of wall time", "us / step")))


def profile_generator(name: str, n: int) -> None:
    rig, verifier = springs.SpringRig, replay.GraspVerifier
    counts: dict[str, int] = defaultdict(int)
    context = ["walk"]
    original_simulate = rig.simulate

    def simulate(self, steps, on_step=None):
        counts[context[0]] += steps
        return original_simulate(self, steps, on_step)

    setattr(rig, "simulate", simulate)
    for method, label in (("move_to", "walk"), ("settle", "settle")):
        original = getattr(rig, method)

        def phase(self, *args, _original=original, _label=label, **kwargs):
            context[0] = _label
            started = time.perf_counter()
            try:
                return _original(self, *args, **kwargs)
            finally:
                SECONDS[_label] += time.perf_counter() - started

        setattr(rig, method, phase)
    timed(rig, "accepted_posture", "candidate test")
    timed(verifier, "__call__", "verification")
    original_judge = replay.judge_scene

    def judge_scene(scene, rules, period=0.02):
        judged = original_judge(scene, rules, period)
        counts["verification"] += round(scene.time / scene.model.opt.timestep)  # the approach and the hold
        return judged

    setattr(replay, "judge_scene", judge_scene)
    started = time.perf_counter()
    generate_postures(name, n, seed=0, workers=1, progress=False)
    wall = time.perf_counter() - started
    rows = [(label, f"{counts[label] / n:.0f}", f"{1000 * SECONDS[label] / n:.1f}",
             f"{100 * SECONDS[label] / wall:.1f} %")
            for label in ("walk", "settle", "candidate test", "verification")]
    rest = wall - sum(SECONDS[label] for label in ("walk", "settle", "candidate test", "verification"))
    rows += [("other (set-up, bookkeeping)", "", f"{1000 * rest / n:.1f}", f"{100 * rest / wall:.1f} %"),
             ("total", f"{sum(counts.values()) / n:.0f}", f"{1000 * wall / n:.1f}", "100 %")]
    print(f"generator, {name}, {n} verified postures, one worker: {wall:.1f} s\n")
    print(table(rows, ("phase", "steps / posture", "ms / posture", "share of wall time")))


def profile_stepping(worlds: int, threads: int, periods: int = 20) -> None:
    import mujoco
    from mujoco import rollout

    from ..judging.judge import supported_scene

    scenes = []
    for k in range(worlds):  # hands closing on the cylinder, each a little further along
        scene = supported_scene(get_object("cylinder"))
        scene.set_hand_pose(*facing_pose("cylinder", clearance=0.01))
        scene.set_posture(open_posture())
        scene.set_target(closed_posture())
        scene.step(300 + 10 * k)
        scenes.append(scene)
    models, spec = [s.model for s in scenes], mujoco.mjtState.mjSTATE_FULLPHYSICS

    def python_loop() -> None:
        for scene in scenes:
            for _ in range(10):
                mujoco.mj_step(scene.model, scene.data)

    def with_rollout(pool, datas) -> None:
        state = np.array([np.empty(mujoco.mj_stateSize(s.model, spec)) for s in scenes])
        for row, scene in zip(state, scenes):
            mujoco.mj_getState(scene.model, scene.data, row, spec)
        out, _ = pool.rollout(models, datas, state, np.array([s.data.ctrl for s in scenes])[:, None, :], nstep=10,
                              initial_warmstart=np.array([s.data.qacc_warmstart for s in scenes]))
        for row, scene in zip(out[:, -1], scenes):
            mujoco.mj_setState(scene.model, scene.data, row, spec)
            mujoco.mj_forward(scene.model, scene.data)

    def per_period(run: Callable[[], None]) -> float:
        run()
        started = time.perf_counter()
        for _ in range(periods):
            run()
        return 1000 * (time.perf_counter() - started) / periods

    rows = [("Python loop of mj_step (the trials')", f"{per_period(python_loop):.2f}")]
    for nthread in sorted({1, threads}):
        pool = rollout.Rollout(nthread=nthread)
        datas = [mujoco.MjData(models[0]) for _ in range(nthread)]
        rows.append((f"mujoco.rollout, {nthread} thread(s)", f"{per_period(lambda: with_rollout(pool, datas)):.2f}"))
        pool.close()
    empty = mujoco.MjModel.from_xml_string("<mujoco/>")
    data = mujoco.MjData(empty)
    started = time.perf_counter()
    for _ in range(100_000):
        mujoco.mj_step(empty, data)
    bare = 1e6 * (time.perf_counter() - started) / 100_000
    print(f"one control period (10 steps) of {worlds} grasping worlds; a bare mj_step call costs {bare:.1f} us\n")
    print(table(rows, ("stepping", "ms per period")))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="study-trial-profile", help="the folder its report (trial_profile_WHAT.md) "
                        "is kept in")
    sub = parser.add_subparsers(dest="what", required=True)
    trials = sub.add_parser("trials")
    trials.add_argument("--grid", default="paper", choices=("paper", "quick", "benchmark"))
    trials.add_argument("--every", type=int, default=9, help="every k-th reachable pose of each grid")
    trials.add_argument("--margin", action="store_true", help="measure the disturbance margin too")
    gen = sub.add_parser("generator")
    gen.add_argument("--object", default="cylinder")
    gen.add_argument("--n", type=int, default=20)
    stepping = sub.add_parser("stepping")
    stepping.add_argument("--worlds", type=int, default=16)
    stepping.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)

    def body(run: object) -> None:
        if args.what == "trials":
            profile_trials(args.grid, args.every, args.margin)
        elif args.what == "generator":
            profile_generator(args.object, args.n)
        else:
            profile_stepping(args.worlds, args.threads)

    run_study(args.out, 1, body, f"trial_profile_{args.what}.md")  # one process: what it profiles


if __name__ == "__main__":
    main()
