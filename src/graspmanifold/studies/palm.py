"""The palm that follows touch (issue 66): does moving the palm on an arm's flange, from touch or from where the
recalled grasp had the object, hold the grasps a fixed palm loses?

    python scripts/study_palm.py [--quick] [--workers 2] [--seeds 2 3 4] [--plans 34] [--displaced 3] [--draw 0]
                                 [--out study-palm] [--doc docs/studies/palm_follows_touch.md]

Two parts, every arm on the same flange (`sim.flange.FlangeLimits`: one physics for all):

1. **The planned-grasp benchmark** (`trials.planned`, `studies.planned_grasps` with the palm family): per object of
   the experience benchmark and per seed, `--plans` verified grasps train the object's experience (a 10 x 10 SOM
   carrying where each grasp had the object and how hard it pressed: `SOM.carry_places`, `carry_squeezes`); those
   the study verifies again on the flange (`trials.planned.verify_plans` with `flange-open-loop`) are the plans, of
   which `--displaced` are drawn at random (`--draw`), each run with the object displaced 0, 1, 2, 3 and 5 cm in 8
   directions of the palm's plane, with yaw. The arms (`trials.planned.PALM_ARMS`): the plan open loop, once and
   with two attempts; the oracles (the only arms that read the displacement): the palm moved by the true
   displacement before the open loop, by its translation alone, and before the approach execution (the ceiling is
   each trial's best of the first and the last); the approach execution with fingers only, with the palm
   re-centred from touch alone, with the palm steered by the recalled object place, and the last three with two
   attempts. The palm's phases (`control.controller.PALM_TOUCH`) were chosen on probes of generator seed 0 (the
   selection split); the test split is seeds 2, 3, 4, run once.
2. **The paper's grid** (`grid_preset('paper')`, the box, the cylinder and the sphere, the seed's experience of
   part 1): the paper's controller (`CONTROLLERS['paper']`) with its palm still, re-centred from touch and steered by
   the recalled place; the share of poses unheld without the palm and with the best single arm with it.

Reported: hold rates with Wilson intervals, McNemar on the same trials with Holm over each part's family beside a
cluster bootstrap over plans (the first comparison the primary one), each arm's share of the ceiling's headroom over
the open loop, rates by start and by design, each difference's sign seed by seed, where touch placed the object
against where it lay, and the verdicts on the issue's targets. Writes `--out/study.json`, the report `--doc` and its figure beside it.
"""

from __future__ import annotations

import argparse
import functools
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..base.checkpoints import result_key
from ..base.io import markdown_table
from ..control.controller import CONTROLLERS
from ..manifold.experience import object_places
from ..manifold.postureset import PostureSet
from ..manifold.som import SOM
from ..sim.flange import FlangeLimits
from ..trials.evaluation import EvaluationResult, evaluate
from ..trials.grid import grid_preset
from ..control.controller import PALM_EXPERIENCE, PALM_TOUCH
from ..trials.planned import PALM_ARMS
from ..trials.stats import mcnemar, rate_text
from .planned_grasps import FAMILIES, Family, Headroom, PlannedStudyConfig, figure, generate, postures_key
from .planned_grasps import report as planned_report
from .planned_grasps import run as run_planned
from .runner import StudyRun, comparison_table, holm_family, publish, run_study, study_config

#: m, the levels the targets read
TARGET_LEVELS = (0.02, 0.03, 0.05)
#: the palm family's questions: (label, arm, against arm, levels)
QUESTIONS: tuple[tuple[str, str, str, tuple[float, ...]], ...] = (
    ("palm steered by experience against the open loop at 2-5 cm (target +15 pts)", "palm-experience",
     "flange-open-loop", TARGET_LEVELS),
    ("experience pays: steered by the recalled place against re-centred from touch alone at 2-5 cm (target +5 pts)",
     "palm-experience", "palm-touch", TARGET_LEVELS),
    ("palm re-centred from touch against fingers only at 2-5 cm", "palm-touch", "fingers-only", TARGET_LEVELS),
    ("palm steered by experience against fingers only at 2-5 cm", "palm-experience", "fingers-only", TARGET_LEVELS),
    ("fingers only against the open loop at 2-5 cm", "fingers-only", "flange-open-loop", TARGET_LEVELS),
    ("the oracle correction against the open loop at 2-5 cm (what palm motion can be worth)", "oracle-correction",
     "flange-open-loop", TARGET_LEVELS),
    ("the translation-only oracle against the full one at 2-5 cm", "oracle-translation", "oracle-correction",
     TARGET_LEVELS),
    ("the oracle moving the palm for the approach execution against the one for the open loop at 2-5 cm",
     "oracle-fingers", "oracle-correction", TARGET_LEVELS),
    ("two attempts: palm steered by experience against fingers only at 2-5 cm", "palm-experience-x2",
     "fingers-only-x2", TARGET_LEVELS),
    ("two attempts against one: palm steered by experience at 2-5 cm", "palm-experience-x2", "palm-experience",
     TARGET_LEVELS),
    ("two attempts, palm steered by experience, against the open loop with two attempts at 2-5 cm",
     "palm-experience-x2", "flange-open-loop-x2", TARGET_LEVELS),
    ("two attempts, palm re-centred from touch, against the open loop with two attempts at 2-5 cm",
     "palm-touch-x2", "flange-open-loop-x2", TARGET_LEVELS),
    ("the open loop: two attempts against one at 2-5 cm", "flange-open-loop-x2", "flange-open-loop", TARGET_LEVELS),
)
#: the paper grid's arms: the paper's controller with its palm still, re-centred from touch, steered by experience
GRID_ARMS = {"paper-fingers-only": CONTROLLERS["paper"],
             "paper-palm-touch": replace(CONTROLLERS["paper"], palm=PALM_TOUCH),
             "paper-palm-experience": replace(CONTROLLERS["paper"], palm=PALM_EXPERIENCE)}
#: the paper's objects, on its grid
GRID_OBJECTS = ("box", "cylinder", "sphere")


def _pooled(info: dict, arm: str, levels: tuple[float, ...] = TARGET_LEVELS) -> tuple[int, int]:
    """(held, trials) of an arm over these levels (m) of the displaced plans."""
    rows = [info["by_level"][arm][info["levels"].index(level)] for level in levels]
    return sum(r[0] for r in rows), sum(r[1] for r in rows)


def palm_verdict(info: dict) -> str:
    """The verdicts on issue 66's targets from the planned part's numbers.

    Args:
        info: `planned_grasps.summarise` of the palm family (its "by_level" counts and Holm "comparisons").

    Returns:
        One paragraph: the rates at 2-5 cm, the share of the oracle's, each target met or not.
    """
    rows = {row["label"]: row for row in info["comparisons"]}
    main, pays = rows[QUESTIONS[0][0]], rows[QUESTIONS[1][0]]
    held, n = _pooled(info, "palm-experience")
    oracle = _pooled(info, "oracle-correction")
    fingers = _pooled(info, "oracle-fingers")
    share = info["headroom"]["palm-experience"]
    spread = main["bootstrap"]
    first = main["difference"] >= 0.15 and main["n"] >= 600 and spread["low"] > 0 and share["value"] >= 0.8
    second = pays["difference"] >= 0.05 and pays["bootstrap"]["low"] > 0
    best = max(((arm, share) for arm, share in info["headroom"].items() if "oracle" not in arm),
               key=lambda item: item[1]["value"])
    return (f"At 2-5 cm, one attempt, the palm steered by experience holds {rate_text(held, n)} against the open "
            f"loop's {rate_text(*_pooled(info, 'flange-open-loop'))} ({100 * main['difference']:+.1f} pts, "
            f"{100 * spread['low']:+.1f} to {100 * spread['high']:+.1f} over {spread['clusters']} plans, n = "
            f"{main['n']}) and takes {100 * share['value']:.0f} % [{100 * share['low']:.0f}, {100 * share['high']:.0f}] "
            f"of the ceiling's headroom over the open loop (the ceiling a trial's best of the oracle correction, "
            f"{rate_text(*oracle)}, and the oracle before the approach execution, {rate_text(*fingers)}; target "
            f"+15 pts and 80 %: {'met' if first else 'not met'}); the best single arm, {best[0]}, takes "
            f"{100 * best[1]['value']:.0f} %. Steering by the recalled place against re-centring from touch alone: "
            f"{100 * pays['difference']:+.1f} pts ({100 * pays['bootstrap']['low']:+.1f} to "
            f"{100 * pays['bootstrap']['high']:+.1f} over plans; target +5 pts: {'met' if second else 'not met'}).")


PALM = Family("palm", "The palm that follows touch: a wrist the controller moves, on planned grasps and the paper's "
              "grid", PALM_ARMS, QUESTIONS, False, palm_verdict, "issue 66", "study-palm",
              "docs/studies/palm_follows_touch.md", "scripts/study_palm.py", floor="flange-open-loop",
              headroom=Headroom("flange-open-loop", ("oracle-correction", "oracle-fingers"), (0.02, 0.03, 0.05)))
FAMILIES[PALM.name] = PALM


def _grid_experience(study: StudyRun, name: str, seed: int, config: PlannedStudyConfig) -> SOM:
    """The object's experience of part 1 (the same verified grasps, kept in the study folder), carrying places."""
    plans = config.sizes[0]
    postures: PostureSet = study.postures(
        f"postures/{name}_{seed}", postures_key(name, plans, seed, config.quick),
        functools.partial(generate, name, plans, seed, study.workers, config.quick))
    som = SOM(10, 10, seed=seed).fit(postures.postures)
    som.carry_places(postures.postures, object_places(postures))
    return som


def run_grid(config: PlannedStudyConfig, study: StudyRun) -> dict:
    """Part 2: the paper's grid, every arm of `GRID_ARMS` on the flange, per seed and object.

    Args:
        config: the study's configuration (its seeds; a quick run: the quick grid on the cylinder).
        study: the run (its folder keeps every evaluation; its workers).

    Returns:
        `grid_summary` of the outcomes.
    """
    objects = ("cylinder",) if config.quick else GRID_OBJECTS  # a smoke run: one of part 1's objects
    grids = {name: grid_preset("quick" if config.quick else "paper", name) for name in objects}
    held: dict[str, dict[tuple[str, int], np.ndarray]] = {arm: {} for arm in GRID_ARMS}
    for seed in config.run_seeds:
        for name in objects:
            experience, poses = _grid_experience(study, name, seed, config), grids[name]
            for arm, params in GRID_ARMS.items():
                def make(parts: Path, params=params, arm=arm) -> EvaluationResult:
                    return evaluate(name, experience, poses, seed=seed, workers=study.executor or study.workers,
                                    checkpoint_dir=parts, progress=False, params=params, palm=FlangeLimits(),
                                    method=arm)
                key = result_key({"grid": poses.tolist(), "object": name, "seed": seed, "arm": arm,
                                  "params": params.to_table()}, np.asarray(experience.references),
                                 np.asarray(experience.places))
                result = study.evaluation(f"grid_{name}_{seed}_{arm}", key, make)
                held[arm][name, seed] = result.outcomes("hold") & np.array([t.valid for t in result.trials])
            study.log(f"paper grid, {name}, seed {seed}: " + ", ".join(
                f"{arm} {int(held[arm][name, seed].sum())}/{len(grids[name])}" for arm in GRID_ARMS))
    return grid_summary(held, config.run_seeds)


def grid_summary(held: dict[str, dict[tuple[str, int], np.ndarray]], seeds: tuple[int, ...]) -> dict:
    """What the report shows of the paper's grid.

    Args:
        held: {arm of `GRID_ARMS`: {(object, seed): (poses,) bool, held without a fault}}.
        seeds: the seeds run.

    Returns:
        {"arms", "objects", "poses" ({object: poses}), "held" ({arm: [[held, poses] per cell]}), "cells" ([object,
        seed] each), "no_method" ({"fingers_only", "with_palm": [poses held by no such arm, poses]}), "comparisons"
        (the Holm family's rows, each with "by_seed" and "same_sign"), "verdict"}.
    """
    keys = list(held["paper-fingers-only"])
    stack = {arm: np.concatenate([held[arm][k] for k in keys]) for arm in GRID_ARMS}
    fingers = stack["paper-fingers-only"]
    with_palm = np.any(np.array(list(stack.values())), axis=0)
    pairs, signs = [], []
    for arm in ("paper-palm-touch", "paper-palm-experience"):
        pairs.append((f"paper's grid: {arm} against paper-fingers-only", mcnemar(stack[arm], fingers)))
        signs.append([float(np.mean(held[arm][k]) - np.mean(held["paper-fingers-only"][k])) for k in keys])
    comparisons = holm_family(pairs, "issue 66, the paper's grid")
    for row, per_key in zip(comparisons, signs):
        per_seed = [float(np.mean([d for k, d in zip(keys, per_key) if k[1] == seed])) for seed in seeds]
        row["by_seed"], row["same_sign"] = per_seed, bool(all(d > 0 for d in per_seed) or all(d < 0 for d in per_seed))
    objects = list(dict.fromkeys(name for name, _ in keys))
    summary = {"arms": list(GRID_ARMS), "objects": objects,
               "poses": {name: int(len(held["paper-fingers-only"][name, seeds[0]])) for name in objects},
               "held": {arm: [[int(held[arm][k].sum()), int(len(held[arm][k]))] for k in keys] for arm in GRID_ARMS},
               "cells": [[name, seed] for name, seed in keys],
               "no_method": {"fingers_only": [int((~fingers).sum()), int(len(fingers))],
                             "with_palm": [int((~with_palm).sum()), int(len(with_palm))]},
               "comparisons": comparisons}
    summary["verdict"] = grid_verdict(summary)
    return summary


def grid_verdict(grid: dict) -> str:
    """The verdict on the paper grid's target, the share of poses unheld falling by half, read for the best single
    arm with the palm (a union of arms is no method one can run; it is said beside).

    Args:
        grid: `grid_summary`'s dict (its per-arm "held" counts and "no_method" counts).

    Returns:
        One sentence.
    """
    (before, n), (anyone, _) = grid["no_method"]["fingers_only"], grid["no_method"]["with_palm"]
    unheld = {arm: n - sum(held for held, _ in cells) for arm, cells in grid["held"].items()
              if arm != "paper-fingers-only"}
    arm, after = min(unheld.items(), key=lambda item: item[1])
    met = "met" if 0 < before and after <= before / 2 else "not met" if before else "nothing to halve"
    return (f"On the paper's grid the paper's controller with its palm still leaves {rate_text(before, n)} of {n} "
            f"poses unheld; the best single arm with the palm, {arm}, leaves {rate_text(after, n)} (target: half as "
            f"many: {met}); no arm of the three holds {rate_text(anyone, n)}.")


def report(info: dict) -> str:
    """The markdown report: the planned part (`planned_grasps.report`), then the paper's grid.

    Args:
        info: the planned part's numbers with the grid's under "grid".

    Returns:
        The report's text.
    """
    text = planned_report(info)
    grid = info["grid"]
    lines = ["", "## The paper's grid", "",
             f"**{grid['verdict']}**", "",
             "Every arm on the flange, the object's experience of the planned part (the seed's verified grasps); "
             "poses per object and seed: " + ", ".join(f"{name} {n}" for name, n in grid["poses"].items()) + ":", ""]
    lines += markdown_table(["arm"] + [f"{name}, seed {seed}" for name, seed in grid["cells"]] + ["pooled"],
                            [[arm] + [f"{h}/{n}" for h, n in grid["held"][arm]] + [rate_text(
                                sum(h for h, _ in grid["held"][arm]), sum(n for _, n in grid["held"][arm]))]
                             for arm in grid["arms"]])
    lines += ["", "Paired (McNemar on the same poses, Holm over the two):", ""]
    lines += comparison_table(grid["comparisons"])
    lines += ["", "Seed by seed: " + "; ".join(
        f"{row['label']}: " + " / ".join(f"{100 * d:+.1f}" for d in row["by_seed"]) + " pts"
        + ("" if row["same_sign"] else " (signs differ)") for row in grid["comparisons"])]
    return text + "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: two objects, 6 plans, 2 displaced, one seed; the quick grid on the cylinder")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seeds", type=int, nargs="+", default=[2, 3, 4],
                        help="generator, map and trial seeds, one run each (seed 0 chose the palm's phases)")
    parser.add_argument("--plans", type=int, default=34, help="grasps per object and seed the generator verifies: "
                        "the experience")
    parser.add_argument("--displaced", type=int, default=3, help="plans per object and seed run displaced, drawn "
                        "among those the study's verification passes")
    parser.add_argument("--draw", type=int, default=0, help="seeds the draw of the displaced plans")
    parser.add_argument("--out", default="", help=f"the study's folder (default {PALM.default_out}[-quick])")
    parser.add_argument("--doc", default="", help=f"the report (default {PALM.default_doc}, or OUT/ for --quick)")
    args = parser.parse_args(argv)
    config = study_config(lambda: PlannedStudyConfig(args.quick, args.workers, tuple(args.seeds), args.plans,
                                                     args.displaced, "palm", args.draw))
    out = Path(args.out or (PALM.default_out + ("-quick" if args.quick else "")))
    doc = Path(args.doc or (out / Path(PALM.default_doc).name if args.quick else PALM.default_doc))

    def body(study: StudyRun) -> None:
        study.check_writable(doc)
        info = run_planned(config, study)
        info["grid"] = run_grid(config, study)
        info["verdict"] += " " + info["grid"]["verdict"]
        publish(study, doc, config.quick, info, report, figure)

    run_study(out, args.workers, body, "palm.log")


if __name__ == "__main__":
    main()
