"""Find the starting postures of the paper's objects, the benchmark's and the object family, and ship them
in assets/.

    python scripts/find_starting_postures.py [--workers 2] [--out assets/starting_postures.npz] [--recompute]
                                             [--all]

Deterministic: a least-squares search from each grasp design (graspmanifold.control.starts.designs_for): the
five-fingertip family for the paper's objects, the benchmark's and the object family, the grasp-types
family for the paper's and the benchmark's objects (with --all for the family's meshes too, which
takes tens of minutes). Starting postures
already in --out are kept as they are unless --recompute (a search repeated on another machine can
differ in the last digits, and everything generated from them would change with it). Objects not
shipped (other sizes, the user's meshes) get theirs searched on first use, the same way, and kept in the user's cache (starts.cache_directory).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from graspmanifold.base.io import load_npz
from graspmanifold.base.workers import parallel_map
from graspmanifold.control.starts import (
    DESIGN_FAMILIES,
    STARTS_FILE,
    StartingPosture,
    designs_for,
    find_starting_postures,
    save_starting_postures,
)
from graspmanifold.sim.family import FAMILY
from graspmanifold.sim.objects import PAPER_OBJECTS, get_object
from graspmanifold.trials.benchmark import OBJECTS as BENCHMARK_OBJECTS


def shipped(path: Path) -> dict[tuple[str, str], list[StartingPosture]]:
    """The starting postures already in a shipped file, by (object name, family)."""
    if not path.exists():
        return {}
    arrays, meta = load_npz(path, "starting_postures", {})
    found = {}
    for key, entry in meta["objects"].items():
        name, _, family = key.partition("@")
        family = family or "five_fingertip"
        count = len(entry["names"])
        contacts = entry.get("contacts")
        types = entry.get("grasp_types")
        found[(name, family)] = [
            StartingPosture(n, arrays[f"{key}/pos"][i], arrays[f"{key}/quat"][i], arrays[f"{key}/posture"][i],
                            *(() if contacts is None else (tuple(contacts[i]), types[i])))
            for i, n in enumerate(entry["names"])] if count else []
    return found


def named(name: str):
    """A paper, benchmark or family object by name."""
    return BENCHMARK_OBJECTS[name].object if name in BENCHMARK_OBJECTS else get_object(name)


def search(task: tuple[str, str]) -> list[StartingPosture]:
    name, family = task
    return find_starting_postures(named(name), family)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "assets" / STARTS_FILE))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--recompute", action="store_true", help="search again what the file already holds")
    parser.add_argument("--all", action="store_true", help="the grasp-types family for the object family's meshes too")
    args = parser.parse_args()
    names = list(dict.fromkeys([*PAPER_OBJECTS, *BENCHMARK_OBJECTS, *FAMILY]))
    wanted = [(name, family) for name in names for family in DESIGN_FAMILIES
              if family == "five_fingertip" or args.all or name not in FAMILY]
    kept = {} if args.recompute else shipped(Path(args.out))
    tasks = [key for key in wanted if key not in kept]
    start = time.perf_counter()

    def report(index: int, starts: list) -> None:
        name, family = tasks[index]
        print(f"{name} ({family}): {len(starts)} of {len(designs_for(named(name), family))} designs are valid grasps "
              f"({', '.join(s.name for s in starts)}); {time.perf_counter() - start:.0f} s so far", flush=True)

    found = dict(zip(tasks, parallel_map(search, tasks, args.workers, report)))
    everything = {(named(name), family): kept.get((name, family), found.get((name, family)))
                  for name, family in wanted if (name, family) in kept or (name, family) in found}
    save_starting_postures(args.out, everything)
    print(f"wrote {args.out}: {len(kept)} object/family entries kept, {len(found)} searched")


if __name__ == "__main__":
    main()
