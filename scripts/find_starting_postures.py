"""Find the starting postures of the paper's objects, the benchmark's and the object family, and ship them
in assets/.

    python scripts/find_starting_postures.py [--workers 2] [--out assets/starting_postures.npz]
                                             [--recompute [FAMILY ...]]

Deterministic: a least-squares search from each grasp design (graspmanifold.synthesis.generator.search_starting_postures)
of both families for the paper's objects, the benchmark's and the object family, but the grasp-types family of
the members held out (family.HELD_OUT: those are searched on first use, as a new object's are).
Starting postures already in --out are kept as they are unless their object changed or their family is
recomputed (--recompute alone:
every family; a search repeated on another machine can differ in the last digits, and everything generated
from them would change with it). Objects not shipped (other sizes, the user's meshes) get theirs searched on
first use, the same way, and kept in the user's cache (generator.cache_directory).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from graspmanifold.base.io import load_npz
from graspmanifold.base.workers import parallel_map
from graspmanifold.synthesis.start_cache import search_starting_postures
from graspmanifold.synthesis.starts import (
    DESIGN_FAMILIES,
    STARTS_FILE,
    StartingPosture,
    designs_for,
    save_starting_postures,
)
from graspmanifold.sim.family import FAMILY, HELD_OUT
from graspmanifold.sim.objects import PAPER_OBJECTS, get_object
from graspmanifold.trials.benchmark import OBJECTS as BENCHMARK_OBJECTS


def shipped(path: Path) -> dict[tuple[str, str], tuple[dict, list[StartingPosture]]]:
    """The starting postures already in a shipped file, with the parameters of the object they were found
    for, by (object name, family)."""
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
        found[(name, family)] = entry["object"], [
            StartingPosture(n, arrays[f"{key}/pos"][i], arrays[f"{key}/quat"][i], arrays[f"{key}/posture"][i],
                            *(() if contacts is None else (tuple(contacts[i]), types[i])))
            for i, n in enumerate(entry["names"])] if count else []
    return found


def named(name: str):
    """A paper, benchmark or family object by name."""
    return BENCHMARK_OBJECTS[name].object if name in BENCHMARK_OBJECTS else get_object(name)


def search(task: tuple[str, str]) -> list[StartingPosture]:
    name, family = task
    return search_starting_postures(named(name), family, workers=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "assets" / STARTS_FILE))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--recompute", nargs="*", choices=DESIGN_FAMILIES,
                        help="search again what the file holds of these families (none named: of every family)")
    args = parser.parse_args()
    recompute = set(DESIGN_FAMILIES if args.recompute == [] else args.recompute or ())
    names = list(dict.fromkeys([*PAPER_OBJECTS, *BENCHMARK_OBJECTS, *FAMILY]))
    wanted = [(name, family) for name in names for family in DESIGN_FAMILIES
              if family == "five_fingertip" or name not in HELD_OUT]
    # an object whose parameters changed (a mesh made anew) is searched again
    kept = {key: starts for key, (params, starts) in shipped(Path(args.out)).items()
            if key[1] not in recompute and key in wanted and params == named(key[0]).params()}
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
