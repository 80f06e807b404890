"""The library on the community's Shadow Hand beside ours: the cross-model table (issue 28).

    python scripts/study_hands.py [--grid paper] [--hands ours gymnasium-robotics] [--workers 2]

For each hand model and each of the paper's objects: the spring generator's candidates (the paper's
procedure, the quick preset's dataset sizes) and the share of them that hold when replayed (`verify_postures`);
a map trained on them with the paper's schedule; the plain tactile controller and the SOM controller on the grid,
trial by trial on the same poses and seeds. Hold rates carry 95 % Wilson intervals; the SOM is compared with the
heuristic on each hand, and the hands with each other under each controller, by McNemar's exact test, with
Holm's correction over the whole family. Results are kept in --out (a rerun reuses finished files) and the
table is written to docs/hands.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import graspmanifold as gm
from graspmanifold.base.paper_numbers import MAP_SIZE
from graspmanifold.control.generator import DATASET_PRESETS, remove_checkpoints
from graspmanifold.trials.evaluation import EvaluationResult
from graspmanifold.trials.grid import GRID_PRESETS
from graspmanifold.trials.stats import holm, mcnemar, rate_text

OBJECTS = ("box", "cylinder", "sphere")


def experience(out: Path, hand: str, obj: str, workers: int) -> gm.PostureSet:
    path = out / f"{hand}_{obj}_postures.npz"
    if path.exists():
        return gm.PostureSet.load(path)
    postures = gm.generate_postures(obj, DATASET_PRESETS["quick"][obj], seed=0, workers=workers, hand=hand,
                                    params=gm.GeneratorParams(verify=False))
    postures.save(path)
    return postures


def verified_share(out: Path, postures: gm.PostureSet, obj: str, workers: int) -> tuple[int, int]:
    path = out / f"{postures.metadata['hand']}_{obj}_held.npz"
    held = gm.PostureSet.load(path) if path.exists() else gm.verify_postures(postures, obj, workers=workers)
    if not path.exists():
        held.save(path)
    return len(held), len(postures)


def evaluation(out: Path, hand: str, obj: str, method: str, postures: gm.PostureSet, grid: str,
               workers: int) -> EvaluationResult:
    path = out / f"{hand}_{obj}_{method}_{grid}.npz"
    if path.exists():
        return EvaluationResult.load(path)
    som = None if method == "none" else gm.SOM(*MAP_SIZE, seed=0).fit(postures.postures)
    parts = out / f"{path.stem}.parts"
    result = gm.evaluate(obj, som, grid, seed=0, workers=workers, hand=hand, method=method, checkpoint_dir=parts)
    result.save(path)
    remove_checkpoints(parts)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grid", default="paper", choices=GRID_PRESETS)
    parser.add_argument("--hands", nargs="+", default=["ours", "gymnasium-robotics"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study-hands")
    parser.add_argument("--doc", default="docs/hands.md")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    results, shares = {}, {}
    for hand in args.hands:
        for obj in OBJECTS:
            postures = experience(out, hand, obj, args.workers)
            shares[(hand, obj)] = verified_share(out, postures, obj, args.workers)
            for method in ("none", "som"):
                results[(hand, obj, method)] = evaluation(out, hand, obj, method, postures, args.grid, args.workers)
    comparisons = []  # (what, object, PairedComparison)
    for obj in OBJECTS:
        for hand in args.hands:
            a, b = results[(hand, obj, "som")], results[(hand, obj, "none")]
            valid = a.valid() & b.valid()
            comparisons.append((f"{hand}: SOM vs heuristic", obj, mcnemar(a.outcomes()[valid], b.outcomes()[valid])))
        for method in ("none", "som"):
            first, *others = args.hands
            for other in others:
                a, b = results[(other, obj, method)], results[(first, obj, method)]
                valid = a.valid() & b.valid()
                comparisons.append((f"{method}: {other} vs {first}", obj,
                                    mcnemar(a.outcomes()[valid], b.outcomes()[valid])))
    adjusted = holm([c.p_value for _, _, c in comparisons])
    lines = ["# The library on another Shadow Hand model (issue 28)", "",
             f"`python scripts/study_hands.py --grid {args.grid} --hands {' '.join(args.hands)} --workers {args.workers}`"
             f" ({time.perf_counter() - started:.0f} s for what this run computed; the project's 2-core machine).",
             "", "Experience: the spring generator's candidates (the paper's procedure) at the quick preset's sizes; "
             "verified share: of those candidates, how many hold when replayed with the controller's squeeze. "
             f"Trials: the {args.grid} grid, seed 0, the same poses and noise draws on every hand; hold rates over "
             "the valid trials with 95 % Wilson intervals.", "",
             "| hand | object | candidates (acceptance) | verified share | heuristic hold | SOM hold | invalid |",
             "|---|---|---|---|---|---|---|"]
    for hand in args.hands:
        for obj in OBJECTS:
            postures_meta = gm.PostureSet.load(out / f"{hand}_{obj}_postures.npz").metadata
            held, total = shares[(hand, obj)]
            none, som = results[(hand, obj, "none")], results[(hand, obj, "som")]
            lines.append(f"| {hand} | {obj} | {total} ({postures_meta['acceptance_ratio']:.1%}) | {rate_text(held, total)} | "
                         f"{rate_text(int(none.outcomes()[none.valid()].sum()), int(none.valid().sum()))} | "
                         f"{rate_text(int(som.outcomes()[som.valid()].sum()), int(som.valid().sum()))} | "
                         f"{int((~none.valid()).sum())} / {int((~som.valid()).sum())} |")
    lines += ["", "Paired comparisons (McNemar's exact test on the poses valid for both; Holm over all "
              f"{len(comparisons)}):", "", "| comparison | object | n | only first holds | only second holds | p | Holm p |",
              "|---|---|---|---|---|---|---|"]
    for (what, obj, c), p_holm in zip(comparisons, adjusted):
        lines.append(f"| {what} | {obj} | {c.n} | {c.only_a} | {c.only_b} | {c.p_value:.3g} | {p_holm:.3g} |")
    Path(args.doc).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
