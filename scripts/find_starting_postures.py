"""Find the starting postures of the paper's three objects and ship them in assets/.

    python scripts/find_starting_postures.py [--out assets/starting_postures.npz]

Deterministic: a least-squares search from each grasp design (graspmanifold.starts.GRASP_DESIGNS).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from graspmanifold.objects import PAPER_OBJECTS
from graspmanifold.starts import (
    GRASP_DESIGNS,
    STARTS_FILE,
    find_starting_postures,
    save_starting_postures,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "assets" / STARTS_FILE))
    args = parser.parse_args()
    found = {}
    for name, obj in PAPER_OBJECTS.items():
        start = time.perf_counter()
        found[name] = find_starting_postures(obj)
        print(f"{name}: {len(found[name])} of {len(GRASP_DESIGNS[obj.shape])} designs are valid five-fingertip "
              f"grasps ({', '.join(s.name for s in found[name])}) in {time.perf_counter() - start:.1f} s")
    save_starting_postures(args.out, found)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
