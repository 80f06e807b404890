"""Seconds per scene picture: the kept drawing process (and MUJOCO_GL set before import: in this
process) against a fresh child process per picture (the library's path before issue 25).

    python scripts/bench_render.py [--pictures 5]
    DISPLAY=:0 python scripts/bench_render.py       # no backend chosen on import: the kept drawing process

Prints the first picture's time and the median of the following ones for each path.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import graspmanifold as gm
from graspmanifold.sim import render


def seconds(scene: gm.Scene, pictures: int, fresh: bool) -> list[float]:
    times = []
    for _ in range(pictures):
        start = time.perf_counter()
        if fresh:  # no kept child: each picture starts its own child process, as every picture did before
            render._close_drawing()
            render.render_states(scene, scene.state()[None], backends=render.BACKENDS)
        else:
            scene.render()
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pictures", type=int, default=5)
    args = parser.parse_args()
    scene = gm.Scene("cylinder")
    in_process = os.environ.get("MUJOCO_GL") in render.BACKENDS
    now = "in this process (MUJOCO_GL set)" if in_process else "kept drawing process"
    for label, fresh in ((now, False), ("a fresh child process per picture (before)", True)):
        times = seconds(scene, args.pictures, fresh)
        print(f"{label}: first {times[0]:.2f} s, then median {statistics.median(times[1:]):.3f} s "
              f"(min {min(times[1:]):.3f}, max {max(times[1:]):.3f}) over {len(times) - 1} pictures")


if __name__ == "__main__":
    main()
