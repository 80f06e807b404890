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
from dataclasses import replace
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


def our_finger_servo() -> tuple[float, float]:
    """Our finger servos' gain (N m/rad) and force limit (N m)."""
    actuator = gm.SHADOW_HAND.model.actuator("A_FFJ3")
    return float(actuator.gainprm[0]), float(actuator.forcerange[1])


def with_our_servos(hand: gm.HandModel) -> gm.HandModel:
    """The model with our finger servos in place of its own."""
    gain, limit = our_finger_servo()

    def spec():
        spec = hand.spec()
        for actuator in spec.actuators:
            if actuator.name not in [hand.actuators[row] for row in hand.wrist_rows]:
                actuator.gainprm[0], actuator.biasprm[1] = gain, -gain
                actuator.forcerange = [-limit, limit]
        return spec

    return replace(hand, loader=spec)


def servo_rows(hand_name: str) -> list[str]:
    """The heuristic on the quick grid with the model's own finger servos and with ours (this process: the
    changed model is not registered by name), beside our hand."""
    hand, (gain, limit) = gm.sim.hand_models.hand_model(hand_name), our_finger_servo()
    lines = ["", f"Why the hands differ, one cause tried: {hand_name} with our finger servos (kp "
             f"{gain:g} N m/rad, force limit {limit:g} N m) instead of its own; the plain "
             "controller on the quick grid, seed 0:", "",
             "| object | its servos | our servos | p (McNemar) | our hand |", "|---|---|---|---|---|"]
    for obj in OBJECTS:
        grid = gm.grid_preset("quick", obj)
        own, swapped, ours = (gm.evaluate(obj, None, grid, workers=1, hand=h)
                              for h in (hand, with_our_servos(hand), gm.SHADOW_HAND))
        both = own.valid() & swapped.valid()
        lines.append(f"| {obj} | {rate_text(int(own.outcomes()[own.valid()].sum()), int(own.valid().sum()))} | "
                     f"{rate_text(int(swapped.outcomes()[swapped.valid()].sum()), int(swapped.valid().sum()))} | "
                     f"{mcnemar(swapped.outcomes()[both], own.outcomes()[both]).p_value:.3g} | "
                     f"{rate_text(int(ours.outcomes()[ours.valid()].sum()), int(ours.valid().sum()))} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grid", default="paper", choices=GRID_PRESETS)
    parser.add_argument("--hands", nargs="+", default=["ours", "gymnasium-robotics"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study-hands")
    parser.add_argument("--doc", default="docs/hands.md")
    parser.add_argument("--servos", action="store_true", help="also run the other hands with our finger servos")
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
             f"`python scripts/study_hands.py --grid {args.grid} --hands {' '.join(args.hands)} --workers {args.workers}"
             f"{' --servos' if args.servos else ''}` (SECONDS s for what this run computed; the project's 2-core "
             "machine).",
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
    if args.servos:
        for hand in args.hands[1:]:
            lines += servo_rows(hand)
    text = "\n".join(lines).replace("SECONDS", f"{time.perf_counter() - started:.0f}")
    Path(args.doc).write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
