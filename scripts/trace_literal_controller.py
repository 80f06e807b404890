"""Why the paper's literal controller loses where the blend holds: every trial of one benchmark cell traced, both
controllers on the same poses, the same experience.

    python scripts/trace_literal_controller.py [--experience study-uncertainty] [--object pen] [--placement palm]
    python scripts/trace_literal_controller.py --all   # every cell of the test split, and the pooled comparisons

The experience is the verified postures a study kept (`experience_<object>.npz` in its folder: the experience or the
uncertainty study), one SOM trained on all of them as the studies train it. Each control cycle of every world is
logged: the sensed joints and touch, the targets, and whether a finger is on its way to a recalled posture (the
literal reading moves a free finger to each new recall at the heuristic's speed before phase D closes it on from
there, its closure from 0). Prints, per controller: the hold rate, when the first contact came, how often the grasp
ended at the timeout, how many segments touched at the end, the share of control cycles in which some finger was
on its way to a recall instead of closing, and how far the targets opened after the first contact. With `--all`,
every (object, placement) of the test split, then the pooled paired comparisons (McNemar, Holm within the family).
"""

import argparse
import glob

import numpy as np

from graspmanifold.control.controller import (
    BLEND,
    CLOSING_RECALL,
    FINGER_JOINT_MASKS,
    BatchController,
    ControllerParams,
)
from graspmanifold.manifold.postureset import PostureSet
from graspmanifold.studies.runner import comparison_table, holm_family
from graspmanifold.trials.benchmark import OBJECTS, PLACEMENTS, benchmark_split
from graspmanifold.trials.stats import mcnemar, rate_text
from graspmanifold.trials.study import train_experience_map
from graspmanifold.trials.trial import TrialSetup, run_trials


def traced(setup: TrialSetup, poses: np.ndarray) -> tuple[list, list]:
    """The trials and, per control cycle, (time, joints, forces, targets, fingers on their way to a recall)."""
    log, step = [], BatchController.step

    def logging_step(self, joints, forces):
        targets = step(self, joints, forces)
        log.append((self.time, joints.copy(), forces.copy(), targets.copy(), self._approaching.copy()))
        return targets

    BatchController.step = logging_step
    try:
        trials = run_trials(setup, poses, [np.random.default_rng([0, i]) for i in range(len(poses))])
    finally:
        BatchController.step = step
    return trials, log


READINGS = (("paper's controller", ControllerParams()), ("closing recall", CLOSING_RECALL), ("blend", BLEND))


def trace_cell(som, name: str, placement: str) -> dict[str, np.ndarray]:
    """Every test pose of one cell under each reading; prints one line per reading. Returns the outcomes (held,
    valid) per reading."""
    poses = benchmark_split()["test"][(name, placement)]
    opened, closed = BatchController(1, None).initial, BatchController(1, None).closed
    span = np.where(closed == opened, 1.0, closed - opened)
    outcomes = {}
    print(f"\n### {name} at the {placement} ({len(poses)} test poses)\n")
    for label, params in READINGS:
        trials, log = traced(TrialSetup(OBJECTS[name].object, som, params=params), poses)
        times = np.array([entry[0] for entry in log])
        touched = np.array([(entry[2] > 0).any(axis=1) for entry in log])  # (cycles, worlds)
        first = np.array([times[np.argmax(touched[:, w])] if touched[:, w].any() else np.inf
                          for w in range(len(poses))])
        on_way = np.array([entry[4].any(axis=1) for entry in log])
        closure = np.array([[((entry[3][:, m] - opened[m]) / span[m]).mean(axis=1) for m in FINGER_JOINT_MASKS]
                            for entry in log])  # (cycles, fingers, worlds): how far each finger's target is closed
        after = times[:, None] >= first[None, :]
        opening = (np.maximum(0.0, -np.diff(closure, axis=0)).sum(axis=1) * after[1:]).sum(axis=0)
        held = np.array([t.hold for t in trials])
        valid = np.array([t.valid for t in trials])
        timeout = np.array([t.time_to_grasp >= params.timeout - 1e-9 for t in trials])
        segments = np.array([t.touching.sum() for t in trials])
        outcomes[label] = (held, valid)
        touched_at = first[np.isfinite(first)]
        print(f"- {label}: holds {rate_text(int(held[valid].sum()), int(valid.sum()))}; first contact at "
              f"{np.median(touched_at) if len(touched_at) else float('nan'):.2f} s (median); timeout {timeout.mean():.0%}; "
              f"segments touching at the end {segments.mean():.1f}; cycles with a finger on its way to a recall: "
              f"{on_way[~after].mean() if (~after).any() else 0:.0%} before the first contact, "
              f"{on_way[after].mean() if after.any() else 0:.0%} after; targets opened after the first contact by "
              f"{opening.mean():.2f} closure units (summed over fingers); best-match queries "
              f"{np.median([t.matches for t in trials]):.0f} (median)")
    return outcomes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experience", default="study-uncertainty", help="a study's folder with experience_*.npz")
    parser.add_argument("--object", default="pen", choices=list(OBJECTS))
    parser.add_argument("--placement", default="palm", choices=list(PLACEMENTS))
    parser.add_argument("--all", action="store_true", help="every cell of the test split, and pooled comparisons")
    args = parser.parse_args()
    files = sorted(glob.glob(f"{args.experience}/experience_*.npz"))
    if not files:
        raise SystemExit(f"error: no experience_*.npz in {args.experience}: run a study there first")
    som = train_experience_map(np.concatenate([PostureSet.load(f).postures for f in files]))
    print(f"Experience: {sum(len(PostureSet.load(f)) for f in files)} verified postures of {len(files)} objects "
          f"({args.experience}), one SOM.")
    cells = [(o, p) for o in OBJECTS for p in PLACEMENTS] if args.all else [(args.object, args.placement)]
    runs = [trace_cell(som, *cell) for cell in cells]
    pooled = {label: tuple(np.concatenate([r[label][k] for r in runs]) for k in (0, 1)) for label, _ in READINGS}
    paper = pooled["paper's controller"]

    def versus(a, b):
        return mcnemar(a[0], b[0], valid=a[1] & b[1])

    print("\n### Pooled\n")
    for label, (held, valid) in pooled.items():
        print(f"- {label}: {rate_text(int(held[valid].sum()), int(valid.sum()))}")
    print()
    print("\n".join(comparison_table(holm_family([
        ("closing recall against the paper's controller", versus(pooled["closing recall"], paper)),
        ("the blend against the paper's controller", versus(pooled["blend"], paper)),
        ("the blend against the closing recall", versus(pooled["blend"], pooled["closing recall"]))]))))


if __name__ == "__main__":
    main()
