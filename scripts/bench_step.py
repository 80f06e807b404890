"""Benchmark: MuJoCo step time of the hand scene, without contact and while grasping.

    python scripts/bench_step.py [--seconds 5]

Prints microseconds per step and the real-time factor for each object, one core.
"""

from __future__ import annotations

import argparse
import platform
import time

import mujoco

import graspmanifold as gm
from graspmanifold.base.io import markdown_row, markdown_table


def time_steps(scene: gm.Scene, seconds: float) -> float:
    """Wall seconds per physics step over `seconds` of simulated time."""
    steps = round(seconds / scene.model.opt.timestep)
    start = time.perf_counter()
    scene.step(steps)
    return (time.perf_counter() - start) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="simulated seconds per case")
    args = parser.parse_args()
    print(f"mujoco {mujoco.__version__}, python {platform.python_version()}, {platform.processor() or platform.machine()}")
    print(f"timestep {gm.load_hand().opt.timestep * 1e3:.1f} ms")
    print("\n".join(markdown_table(["case", "contacts", "µs / step", "× real time"], [])))
    for name in ("cylinder", "box", "sphere"):
        free = gm.Scene(name)
        free.set_hand_pose([0.5, 0, 0], [1, 0, 0, 0])
        free.set_target(gm.closed_posture())
        grasp = gm.Scene(name)
        grasp.set_hand_pose(*gm.facing_pose(name, clearance=0.01))
        grasp.set_posture(gm.open_posture())
        grasp.set_target(gm.closed_posture())
        grasp.run(1.0)  # closed: measure the steady grasp
        for label, scene in ((f"{name}: hand closing in free air", free), (f"{name}: hand grasping", grasp)):
            per_step = time_steps(scene, args.seconds)
            contacts = len(scene.tactile().forces)
            dt = scene.model.opt.timestep
            print(markdown_row([label, contacts, f"{per_step * 1e6:.1f}", f"{dt / per_step:.0f}"]))


if __name__ == "__main__":
    main()
