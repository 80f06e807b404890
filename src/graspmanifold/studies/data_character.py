"""Which generator mode gives data of the paper's character? Data statistics and map distances per mode.

    python scripts/study_data_character.py [--modes settled recording] [--objects box cylinder sphere]
                                           [--record-every 5] [--no-verify] [--workers 2] [--out data_character]
                                           [--cache DIR]

For each object and generator mode (`GeneratorParams.mode`), the paper preset's number of spring
candidates (seed 0, verified as the reproduction does), the data's character (nearest-neighbour
distances, cluster spread, distance between cluster means) and the 25 x 25 map of the paper's
schedule trained on it: its minimum and maximum inter-node distance beside the paper's. Posture sets
are kept in OUT under the key of what made them (or read from `--cache`, e.g. a bench_unseen directory of settled sets). With
`--no-verify` every candidate is kept, as the paper kept every recorded posture: it shows what the
verification (which keeps only grasps that hold) does to the clusters and the map.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict
from pathlib import Path

from ..base.checkpoints import result_key
from ..base.io import markdown_table, write_text_atomic
from ..base.paper_numbers import MAX_DISTANCE_DEG, MIN_DISTANCE_DEG
from ..manifold.analysis import nearest_neighbour_deg
from ..manifold.postureset import PostureSet
from ..synthesis.generator import DATASET_PRESETS, GeneratorParams, generate_postures, verify_postures
from ..trials.experience_pays import train_experience_map
from .runner import StudyRun, run_study


def posture_set(run: StudyRun, cache: Path | None, name: str, mode: str, record_every: int, verify: bool
                ) -> PostureSet:
    """The paper preset's candidates of one object and mode (those that hold, with `verify`), kept in the run's
    folder under the key of what made them, or read from `cache` (settled, verified sets named <object>.npz)."""
    if cache and mode == "settled" and verify and (cache / f"{name}.npz").exists():
        return PostureSet.load(cache / f"{name}.npz")
    params = GeneratorParams(mode=mode, record_every=record_every, verify=False)
    n = DATASET_PRESETS["paper"][name]
    key = result_key({"object": name, "n": n, "seed": 0, "params": asdict(params), "verify": verify})

    def make(parts: Path) -> PostureSet:
        postures = generate_postures(name, n, seed=0, workers=run.workers, params=params, checkpoint_dir=parts,
                                     progress=True)
        return verify_postures(postures, name, run.workers) if verify else postures  # the candidates that hold

    label = (mode if mode == "settled" else f"{mode}{record_every}") + ("" if verify else "_unverified")
    return run.postures(f"{name}_{label}", key, make)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", nargs="+", default=["settled", "recording"])
    parser.add_argument("--objects", nargs="+", default=list(DATASET_PRESETS["paper"]))
    parser.add_argument("--record-every", type=int, default=GeneratorParams.record_every,
                        help="physics steps between recorded postures in recording mode")
    parser.add_argument("--no-verify", action="store_true", help="keep every candidate, as the paper did")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="data_character")
    parser.add_argument("--cache", help="a directory with settled-mode paper sets named <object>.npz")
    args = parser.parse_args(argv)
    run_study(args.out, args.workers, lambda run: _run(args, run), pool=False)  # the generator's own pool


def _run(args: argparse.Namespace, run: StudyRun) -> None:
    rows = []
    for name in args.objects:
        for mode in args.modes:
            postures = posture_set(run, Path(args.cache) if args.cache else None, name, mode, args.record_every,
                                   not args.no_verify)
            near, clusters = nearest_neighbour_deg(postures.postures), postures.cluster_separation()
            stats = train_experience_map(postures.postures).distance_stats(degrees=True)
            label = (mode if mode == "settled" else f"{mode}, every {args.record_every} steps") + (
                ", unverified" if args.no_verify else "")
            rows.append([name, label, f"{len(postures)} of {postures.metadata['candidates']}",
                         f"{clusters['starts']} of {len(postures.start_names)}",
                         f"{near['min']:.3g} / {near['median']:.3g} / {near['p90']:.3g}", f"{clusters['within_deg']:.3g}",
                         f"{clusters['between_deg']:.3g}", f"{stats['min']:.3g}", MIN_DISTANCE_DEG[name],
                         f"{stats['max']:.3g}", MAX_DISTANCE_DEG[name]])
            run.log(" | ".join(str(cell) for cell in rows[-1]))
    lines = markdown_table(["object", "mode", "kept postures", "starting postures with data",
                            "nearest neighbour min / median / p90 (°)", "within-start (°)", "between starts (°)",
                            "map min (°)", "paper min", "map max (°)", "paper max"], rows)
    lines += ["", f"{time.perf_counter() - run.started:.0f} s with {args.workers} workers."]
    write_text_atomic(run.out / f"data_character_{'_'.join(args.modes)}{args.record_every}"
                            f"{'_unverified' if args.no_verify else ''}.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
