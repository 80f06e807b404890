"""How long a new object's starting postures take: the search `starting_postures(obj, "grasp_types")` runs the
first time an object that ships none is used (issue 37, "starting postures for a new object in seconds").

    python scripts/bench_starts.py

Objects no file ships: a cylinder of other sizes (a primitive) and the family's bottle made 10 % larger (a mesh
of 1,800 triangles). Each search runs in an empty cache folder (`$GRASPMANIFOLD_CACHE`), so nothing stored is
read; the row gives the wall time of the call (its default workers: two on a machine of two cores or more) and
what it found.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings

import graspmanifold as gm
from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.control.starts import designs_for
from graspmanifold.sim.family import family_mesh


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    objects = [gm.make_object("cylinder", radius=0.027, length=0.15),
               gm.make_object("mesh", mesh=family_mesh("bottle_m"), scale=1.1, name="bottle_110")]
    print(f"{os.cpu_count()} cores\n")
    print("\n".join(markdown_table(["object", "search (s)", "designs tried", "starts found", "grasp types"], [])))
    for obj in objects:
        with tempfile.TemporaryDirectory() as cache:
            os.environ["GRASPMANIFOLD_CACHE"] = cache
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the "searching now" notice
                found = gm.starting_postures(obj, "grasp_types")
            seconds = time.perf_counter() - start
        tried = len(designs_for(obj, "grasp_types"))
        print(markdown_row([obj.name, f"{seconds:.1f}", tried, len(found), len({s.grasp_type for s in found})]),
              flush=True)


if __name__ == "__main__":
    main()
