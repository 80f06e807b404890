"""Benchmark: grasps judged per second per core under DexGraspBench's external-force test, on our hand.

    python scripts/bench_dexgraspbench.py [--grasps 24] [--object box]

Open-loop grasps from our verified postures (`replay.open_loop_grasps`: the stages they were verified with,
by default the touching segments 2 cm out along the object's normals, the posture, 1 cm in), each judged by both versions of the protocol in this
process (one core); beside them the same number of grasps that fail at once (the hand 15 cm away), the
kind that made up 99.8 % of DexGraspBench's one public log (8,000 grasps in about 55 s on 48 workers: about
3 grasps per second per worker). Prints one markdown table.
"""

from __future__ import annotations

import argparse
import platform
import time

import mujoco
import numpy as np

import graspmanifold as gm
from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.judging.plans import OpenLoopGrasp, open_loop_grasps
from graspmanifold.judging.push_test import external_force_test
from graspmanifold.judging.protocols import PROTOCOLS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grasps", type=int, default=24)
    parser.add_argument("--object", default="box")
    args = parser.parse_args()
    postures = gm.generate_postures(args.object, args.grasps, seed=0, workers=1, progress=False)
    verified = open_loop_grasps(postures, obj=args.object)
    away = [OpenLoopGrasp(g.poses + [0.0, 0.0, 0.15, 0, 0, 0, 0], np.tile(gm.open_posture(), (3, 1))) for g in verified]
    print(f"mujoco {mujoco.__version__}, python {platform.python_version()}, {platform.processor() or platform.machine()}"
          f"; {args.object}, {args.grasps} grasps per row, one core")
    print("\n".join(markdown_table(["protocol", "grasps", "succeeded", "physics steps per grasp", "grasps / s / core"], [])))
    for name, protocol in ((name, p.push_test) for name, p in PROTOCOLS.items() if p.push_test is not None):
        for label, grasps in (("our verified grasps", verified), ("grasps failing at once", away)):
            scene = gm.Scene(args.object, free_object=True)
            start = time.perf_counter()
            results = [external_force_test(scene, g, protocol) for g in grasps]
            seconds = time.perf_counter() - start
            held = sum(r.success for r in results)
            steps = np.mean([r.steps for r in results])
            print(markdown_row([name, label, f"{held} / {len(results)}", f"{steps:.0f}", f"{len(results) / seconds:.1f}"]))


if __name__ == "__main__":
    main()
