"""Benchmark the continuous manifold (UKR): training on the paper's dataset size and masked completion, on one core,
beside the 25 x 25 SOM and the database in the same run.

    python scripts/bench_ukr.py [--data postures.npz] [--sizes 625 1512 4000] [--queries 10000] [--out DIR]

The postures: `--data` (a posture set), else 4,000 of the cylinder's candidates from the spring generator with the
paper preset (`generate_postures("cylinder", 4000, params=PRESET_PARAMS["paper"])`: the paper's procedure, about
the paper's ~4,000 per object); each size is the set's first n. Per size: the UKR's training time (2 latent
dimensions, the defaults: `UKR().fit`), the SOM's (the paper's schedule), and the masked completion of `--queries`
Partial Contact Postures (`som_speed.pcp_queries`) by each, in one batch and one at a time (the mean of 500); the
whole benchmark pinned to one core (the process's affinity), so that no thread pool counts.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from typing import Any

import numba
import numpy as np

from ..base.io import markdown_table
from ..manifold.experience import PostureDatabase
from ..manifold.postureset import PostureSet
from ..manifold.som import SOM
from ..manifold.ukr import UKR
from ..synthesis.generator import generate_postures
from ..synthesis.springs import PRESET_PARAMS
from .runner import run_study
from .som_speed import pcp_queries


def _seconds(call: object) -> float:
    start = time.perf_counter()
    call()  # type: ignore[operator]
    return time.perf_counter() - start


def measure(args: argparse.Namespace) -> None:
    """The benchmark's table, printed (see the module doc)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    data = (PostureSet.load(args.data) if args.data else
            generate_postures("cylinder", max(args.sizes), seed=0, params=PRESET_PARAMS["paper"], workers=1,
                              progress=False)).postures
    print(f"python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
          f"{platform.machine()}, one core; {len(data)} postures, {args.queries} masked queries\n")
    rows = []
    for n in args.sizes:
        train = data[:n]
        queries, masks = pcp_queries(train, args.queries)
        made: dict[str, Any] = {}
        seconds = {"ukr": _seconds(lambda: made.setdefault("ukr", UKR().fit(train, progress=False))),
                   "som": _seconds(lambda: made.setdefault("som", SOM(25, 25, 22, seed=0).fit(train, progress=False))),
                   "database": _seconds(lambda: made.setdefault("database", PostureDatabase(train)))}
        for name, experience in made.items():
            experience.complete_batch(queries[:10], masks[:10])  # compiled on first use
            batch = _seconds(lambda: experience.complete_batch(queries, masks))
            single = _seconds(lambda: [experience.complete(q, m) for q, m in zip(queries[:500], masks[:500])]) / 500
            fit = f"{seconds[name]:.1f}" if name != "database" else "–"
            extra = f"{made['ukr'].history[0]['iterations']} L-BFGS iterations" if name == "ukr" else ""
            rows.append([n, name, fit, f"{1e3 * single:.3f}", f"{batch:.2f}", extra])
            print(f"n={n} {name}: training {fit} s, completion {1e3 * single:.3f} ms each, {batch:.2f} s for "
                  f"{args.queries}", flush=True)
    print()
    print("\n".join(markdown_table(["postures", "representation", "training (s)", "one completion (ms)",
                                    f"batch of {args.queries} (s)", ""], rows)))


def main(argv: list[str] | None = None) -> None:
    """The benchmark's command (see the module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", help="a posture set (.npz) instead of the generated cylinder candidates")
    parser.add_argument("--sizes", type=int, nargs="+", default=[625, 1512, 4000])
    parser.add_argument("--queries", type=int, default=10_000)
    parser.add_argument("--out", default="study-ukr-speed", help="the folder its report (ukr_speed.md) is kept in")
    args = parser.parse_args(argv)
    run_study(args.out, 1, lambda run: measure(args), "ukr_speed.md")
