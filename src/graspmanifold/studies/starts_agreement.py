"""Whether the start search's outcome turns on the last bits: the shipped starting postures, searched again.

    python scripts/check_starts.py [--objects NAME ...] [--families five_fingertip grasp_types]
                                   [--other-processor] [--workers 2] [--out study_starts]
                                   [--doc docs/studies/starts_agreement.md]

For each object and design family that `assets/starting_postures.npz` ships (`scripts/find_starting_postures.py`'s
list; `--objects` a subset), the generator's own search (`start_cache.search_starting_postures`) runs on its inputs as
they are, and again with every design's palm position changed by 1e-12 (relatively); with `--other-processor` also
in a fresh interpreter with another x86 processor's arithmetic (`OTHER_PROCESSOR`: OpenBLAS's Haswell kernels,
numba compiling for Haswell, NumPy without AVX-512). The report gives per object and family the designs each run
kept, whether the runs agree, the largest difference of a kept design's posture between runs (rad) and the palm's
position (m), and how many of the shipped file's designs (made by the search before issue 50's) the search keeps
now. Each search is kept in `--out` under the key of what made it, so an interrupted check resumes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..base.checkpoints import result_key
from ..base.io import json_text, markdown_table, software_versions, write_text_atomic
from ..sim.family import FAMILY, HELD_OUT
from ..sim.objects import PAPER_OBJECTS, GraspObject, get_object
from ..synthesis.start_cache import search_starting_postures
from ..synthesis.starts import DESIGN_FAMILIES, shipped_starting_postures
from ..trials.benchmark import OBJECTS as BENCHMARK_OBJECTS
from .runner import StudyRun, run_command

#: the environment of another x86 processor's arithmetic: an AVX2 machine's BLAS kernels, compiled kernels and
#: NumPy loops (what issue 50's other processor computed with)
OTHER_PROCESSOR = {"OPENBLAS_CORETYPE": "Haswell", "NUMBA_CPU_NAME": "haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V4"}
#: the runs of each search: inputs as they are, the palm positions changed at the last bits, another processor
RUNS = ("as_is", "perturbed", "other_processor")


def named(name: str) -> GraspObject:
    """A paper, benchmark or family object by name."""
    return BENCHMARK_OBJECTS[name].object if name in BENCHMARK_OBJECTS else get_object(name)


def shipped_entries() -> list[tuple[str, str]]:
    """The (object, family) pairs the shipped file holds: every paper, benchmark and family object's five-fingertip
    starts, and the grasp-types starts of those not held out."""
    names = list(dict.fromkeys([*PAPER_OBJECTS, *BENCHMARK_OBJECTS, *FAMILY]))
    return [(name, family) for name in names for family in DESIGN_FAMILIES
            if family == "five_fingertip" or name not in HELD_OUT]


def search(name: str, family: str, perturbation: float, workers: int) -> dict[str, list[float]]:
    """One search's starts: design name -> posture (22, rad) and palm position (3, m)."""
    return {s.name: [*s.posture.tolist(), *s.hand_pos.tolist()]
            for s in search_starting_postures(named(name), family, perturbation=perturbation, progress=False,
                                              workers=workers)}


def search_elsewhere(name: str, family: str, workers: int) -> dict[str, list[float]]:
    """`search` in a fresh interpreter with another processor's arithmetic (`OTHER_PROCESSOR`)."""
    done = subprocess.run([sys.executable, "-m", __name__, "--emit", name, family, "--workers", str(workers)],
                          capture_output=True, text=True, env={**os.environ, **OTHER_PROCESSOR})
    if done.returncode:
        raise RuntimeError(f"the search of {name} ({family}) with another processor's arithmetic failed: "
                           f"{done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _read(path: Path) -> tuple[dict, dict]:
    try:
        stored = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: {error}") from error
    return stored["starts"], stored["meta"]


def _write(starts: dict, path: Path, meta: dict) -> None:
    write_text_atomic(path, json_text({"starts": starts, "meta": meta}, indent=None))


def largest_difference(a: dict[str, list[float]], b: dict[str, list[float]]) -> tuple[float, float]:
    """The largest posture (rad) and palm-position (m) difference of the designs both runs kept."""
    common = [name for name in a if name in b]
    if not common:
        return 0.0, 0.0
    gaps = np.abs(np.array([a[n] for n in common]) - np.array([b[n] for n in common]))
    return float(gaps[:, :22].max()), float(gaps[:, 22:].max())


def row(name: str, family: str, found: dict[str, dict]) -> dict:
    """One object's and family's comparison of its runs and of the shipped file."""
    base = found["as_is"]
    shipped = [s.name for s in shipped_starting_postures(named(name), family) or []]
    result: dict[str, Any] = {"object": name, "family": family, "kept": list(base), "shipped": shipped,
              "shipped_kept": sum(n in base for n in shipped), "runs": {}}
    for run, other in found.items():
        if run != "as_is":
            posture, palm = largest_difference(base, other)
            result["runs"][run] = {"same_designs": list(other) == list(base),
                                   "differing": sorted(set(other) ^ set(base)), "posture": posture, "palm": palm}
    return result


def report(rows: list[dict], runs: list[str]) -> str:
    """The markdown report."""
    agree = {run: sum(r["runs"][run]["same_designs"] for r in rows) for run in runs}
    designs = sum(len(r["kept"]) for r in rows)
    lines = ["# The shipped starting postures, searched again (issue 50)", "",
             "Made by `python scripts/check_starts.py " + ("--other-processor" if "other_processor" in runs else "")
             + "` (graspmanifold.studies.starts_agreement): each object's and family's search run on its inputs as "
             "they are and " + " and ".join({"perturbed": "with every design's palm position changed by 1e-12",
                                              "other_processor": "with another x86 processor's arithmetic "
                                              "(OpenBLAS Haswell kernels, numba for Haswell, NumPy without "
                                              "AVX-512)"}[r] for r in runs) + ".", "",
             f"Machine and libraries: {json.dumps(software_versions())}", "",
             "## Summary", "",
             *(f"- {run.replace('_', ' ')}: the same designs in {agree[run]} of {len(rows)} object/family searches"
               f" ({designs} designs kept in all); the largest posture difference of a design both kept "
               f"{max((r['runs'][run]['posture'] for r in rows), default=0):.1e} rad" for run in runs),
             f"- the shipped file's designs kept now: {sum(r['shipped_kept'] for r in rows)} of "
             f"{sum(len(r['shipped']) for r in rows)} (the shipped file was made by the search before issue 50's; "
             "it stays as shipped, and everything published was made from it)", "",
             "## By object and family", ""]
    header = ["object", "family", "designs kept", *[f"{run.replace('_', ' ')}: same / differing / rad"
                                                      for run in runs], "shipped kept"]
    body = [[r["object"], r["family"], len(r["kept"]),
             *["{} / {} / {:.0e}".format("yes" if r["runs"][run]["same_designs"] else "no",
                                         ", ".join(r["runs"][run]["differing"]) or "–", r["runs"][run]["posture"])
               for run in runs], f"{r['shipped_kept']} of {len(r['shipped'])}"] for r in rows]
    return "\n".join(lines + markdown_table(header, body)) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="+", help="a subset of the shipped objects (default: all)")
    parser.add_argument("--families", nargs="+", choices=DESIGN_FAMILIES, default=list(DESIGN_FAMILIES))
    parser.add_argument("--other-processor", action="store_true",
                        help="also search with another x86 processor's arithmetic, in a fresh interpreter")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study_starts")
    parser.add_argument("--doc", default=None, help="also write the report here (e.g. docs/studies/starts_agreement.md)")
    parser.add_argument("--emit", nargs=2, metavar=("OBJECT", "FAMILY"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.emit:  # one search, printed as JSON (what `search_elsewhere` runs in a fresh interpreter)
        name, family = args.emit
        print(json.dumps(search(name, family, 0.0, args.workers)))
        return
    entries = [(n, f) for n, f in shipped_entries() if f in args.families and (not args.objects or n in args.objects)]
    if not entries:
        parser.error(f"--objects: none of {args.objects} is shipped; expected some of "
                     f"{sorted({n for n, _ in shipped_entries()})}")
    runs = ["perturbed"] + (["other_processor"] if args.other_processor else [])
    study = StudyRun(args.out, workers=1)

    def body() -> None:
        study.check_writable(args.doc)
        rows = []
        with study.session():
            for name, family in entries:
                found = {}
                for run in ["as_is", *runs]:
                    key = result_key({"object": named(name).params(), "family": family, "run": run})
                    compute = {"as_is": lambda: search(name, family, 0.0, args.workers),
                               "perturbed": lambda: search(name, family, 1e-12, args.workers),
                               "other_processor": lambda: search_elsewhere(name, family, args.workers)}[run]
                    found[run] = study.keep(f"{name}@{family}@{run}.json", key, compute, _read, _write)
                rows.append(row(name, family, found))
                agreement = ", ".join(f"{run}: {'same' if rows[-1]['runs'][run]['same_designs'] else 'DIFFERENT'}"
                                      for run in runs)
                study.log(f"{name} ({family}): {len(found['as_is'])} designs; {agreement}")
        text = report(rows, runs)
        write_text_atomic(study.out / "report.md", text)
        write_text_atomic(study.out / "agreement.json", json_text(rows))
        if args.doc:
            write_text_atomic(Path(args.doc), text)
        study.log(f"wrote {study.out / 'report.md'}" + (f" and {args.doc}" if args.doc else ""))

    run_command(study.out, body)


if __name__ == "__main__":
    main()
