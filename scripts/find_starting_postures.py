"""Find the starting postures of the paper's objects and the object family, and ship them in assets/.

    python scripts/find_starting_postures.py [--workers 2] [--out assets/starting_postures.npz]

Deterministic: a least-squares search from each grasp design (graspmanifold.starts.designs_for).
Objects not shipped (other sizes, the user's meshes) get theirs computed on first use, the same way.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from graspmanifold.family import FAMILY
from graspmanifold.objects import PAPER_OBJECTS, get_object
from graspmanifold.starts import (
    STARTS_FILE,
    designs_for,
    find_starting_postures,
    save_starting_postures,
)
from graspmanifold.workers import parallel_map


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "assets" / STARTS_FILE))
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    names = [*PAPER_OBJECTS, *FAMILY]
    start = time.perf_counter()

    def report(index: int, starts: list) -> None:
        obj = get_object(names[index])
        print(f"{obj.name}: {len(starts)} of {len(designs_for(obj))} designs are valid five-fingertip grasps "
              f"({', '.join(s.name for s in starts)}); {time.perf_counter() - start:.0f} s so far", flush=True)

    found = parallel_map(find_starting_postures, names, args.workers, report)
    save_starting_postures(args.out, dict(zip(names, found)))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
