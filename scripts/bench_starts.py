"""A new object's experience (issues 37, 67): `python scripts/bench_starts.py [--postures 12] [--objects ...]`.

A cylinder, the family's bottle 10 % larger (1,800 triangles), a capsule of 4,096 triangles, each in an empty cache
folder: the start search `starting_postures(obj, "grasp_types")` (default workers), `--postures` verified postures
(one worker, seed 0), closest points of five points (the springs' query) and signed distances of 1,000 points per
second. Runs against any version of the library (PYTHONPATH=OTHER/src) for a before/after pair."""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import timeit
import warnings

import numpy as np
import trimesh

import graspmanifold as gm
from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.sim.family import family_mesh


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--postures", type=int, default=12)
    parser.add_argument("--objects", nargs="+", default=["cylinder", "bottle_110", "capsule_4096"])
    args = parser.parse_args()
    meshes = {"bottle_110": (family_mesh("bottle_m"), 1.1), "capsule_4096": (trimesh.creation.capsule(0.1, 0.022), 1)}
    print(f"{os.cpu_count()} cores\n")
    print("\n".join(markdown_table(["object", "start search (s)", "starts", f"{args.postures} verified (s)",
                                    "5-point closest / s", "signed distances / s"], [])))
    points = np.random.default_rng(0).normal(0.0, 0.03, (1000, 3))
    for name in args.objects:
        obj = (gm.make_object("cylinder", radius=0.027, length=0.15) if name == "cylinder" else
               gm.make_object("mesh", mesh=meshes[name][0], scale=meshes[name][1], name=name))
        with tempfile.TemporaryDirectory() as cache, warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the "searching now" notice
            os.environ["GRASPMANIFOLD_CACHE"] = cache
            clock = [time.perf_counter(), len(gm.starting_postures(obj, "grasp_types")), time.perf_counter()]
            gm.generate_postures(obj, args.postures, seed=0, workers=1, progress=False)
            found, search, generation = clock[1], clock[2] - clock[0], time.perf_counter() - clock[2]
        rates = [calls / seconds for calls, seconds in (timeit.Timer(lambda: obj.closest_point(points[:5])).autorange(),
                                                         timeit.Timer(lambda: obj.signed_distance(points)).autorange())]
        print(markdown_row([name, f"{search:.1f}", found, f"{generation:.1f}", f"{rates[0]:.0f}",
                            f"{1000 * rates[1]:.0f}"]), flush=True)


if __name__ == "__main__":
    main()
