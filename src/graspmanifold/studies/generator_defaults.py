"""What `generate_postures(obj, n)` gives with its defaults: the designs, their grasp types and verified shares.

    python scripts/study_generator_defaults.py [--objects box cylinder sphere | --test-family | --held-out]
                                               [--n 40] [--workers 1] [--out DIR] [--doc docs/studies/generator_defaults.md]

For each object: the starting postures of the default design family (every grasp type, each start one that
holds and so do its neighbours: `start_cache.search_starting_postures`), found in the shipped file or searched
as for a new object (the time it took), then n verified postures with seed 0 (the time, and verified postures
per second), and per design the candidates drawn, the share that held (Wilson 95 %) and the postures kept.
`--test-family` takes the paper's objects and every family member not held out; `--held-out` the object
family's held-out members (`family.HELD_OUT`, chosen before any tuning of the defaults), whose starts are not
shipped: they are searched here exactly as a user's new object's are.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from ..base.errors import GenerationError
from ..base.io import markdown_table, write_text_atomic
from ..sim.family import FAMILY, HELD_OUT
from ..sim.objects import PAPER_OBJECTS, GraspObject, named_objects
from ..synthesis.generator import generate_postures, starting_postures
from ..synthesis.starts import designs_for
from ..trials.stats import rate_text
from .runner import StudyRun, run_study


def study(obj: GraspObject, n: int, workers: int) -> tuple[list[list], list]:
    """The rows of one object's table (one per design) and its summary row."""
    name = obj.name
    started = time.perf_counter()
    starts = starting_postures(obj, "grasp_types")
    searched = time.perf_counter() - started
    started = time.perf_counter()
    try:
        postures = generate_postures(obj, n, seed=0, workers=workers, progress=False)
    except GenerationError as error:
        return [], [name, len(starts), "–", "–", f"{searched:.0f}", "–", "–", f"GenerationError: {error}"]
    seconds = time.perf_counter() - started
    meta = postures.metadata
    types = {start.name: start.grasp_type for start in starts}
    rows = [[name, f"{design} ({types[design]})", meta["candidates_by_start"][design],
             rate_text(round(share * meta["candidates_by_start"][design]), meta["candidates_by_start"][design]),
             meta["kept_by_start"][design]] for design, share in meta["verified_by_start"].items()]
    used = [design for design, kept in meta["kept_by_start"].items() if kept]
    missing = [d.name for d in designs_for(obj, "grasp_types") if d.name not in types]
    summary = [name, len(starts), len(used), len({types[d] for d in used}), f"{searched:.0f}", f"{seconds:.0f}",
               f"{n / seconds:.2f}", ", ".join(missing) or "–"]
    return rows, summary


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="+", default=["box", "cylinder", "sphere"],
                        help="library objects by name, or mesh files of one's own (times --scale)")
    parser.add_argument("--scale", type=float, default=1.0, help="metres per unit of the mesh files (0.001 for mm)")
    parser.add_argument("--held-out", action="store_true", help="the object family's held-out members instead")
    parser.add_argument("--test-family", action="store_true",
                        help="instead the paper's objects and every family member not held out (the tests' family)")
    parser.add_argument("--n", type=int, default=40)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="study-generator-defaults", help="the study's folder (its log)")
    parser.add_argument("--doc", default="generator_defaults.md", help="the report")
    args = parser.parse_args(argv)
    run_study(args.out, 1, lambda run: _run(args, run), "generator_defaults.log")  # the generator has its own pool


def _run(args: argparse.Namespace, run: StudyRun) -> None:
    test_family = [*PAPER_OBJECTS, *(name for name in FAMILY if name not in HELD_OUT)]
    names = list(HELD_OUT) if args.held_out else test_family if args.test_family else args.objects
    # a fresh cache: objects that ship no starts are searched here, as for a new user
    os.environ["GRASPMANIFOLD_CACHE"] = tempfile.mkdtemp(prefix="graspmanifold-cache-")
    rows, summaries = [], []
    for obj in named_objects(names, args.scale):
        object_rows, summary = study(obj, args.n, args.workers)
        rows += object_rows
        summaries.append(summary)
        run.log(" | ".join(str(cell) for cell in summary))
    command = "python scripts/study_generator_defaults.py " + (
        "--held-out" if args.held_out else "--test-family" if args.test_family else "--objects " + " ".join(names)
    ) + f" --n {args.n} --workers {args.workers}"
    text = "\n".join([
        f"Generated by `{command}` ({os.cpu_count()} cores; seed 0; `generate_postures(obj, {args.n})` with its "
        "defaults: every grasp type, verified).", "",
        *markdown_table(["object", "starting postures", "designs in the set", "grasp types in the set",
                         "start search (s)", "generation (s)", "verified postures / s",
                         "designs with no start that holds"], summaries), "",
        *markdown_table(["object", "design (grasp type)", "candidates", "verified [95 % CI]", "kept"], rows), ""])
    write_text_atomic(args.doc, text)
    print(f"wrote {args.doc}")


if __name__ == "__main__":
    main()
