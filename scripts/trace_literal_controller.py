"""Why the paper's literal controller loses where the blend holds: every trial of one benchmark cell traced, both
controllers on the same poses, the same experience.

    python scripts/trace_literal_controller.py [--experience study-uncertainty] [--object pen] [--placement palm]

The experience is the verified postures a study kept (`experience_<object>.npz` in its folder: the experience or the
uncertainty study), one SOM trained on all of them as the studies train it. Each control cycle of every world is
logged: the sensed joints and touch, the targets, and whether a finger is on its way to a recalled posture (the
literal reading moves a free finger to each new recall at the heuristic's speed before phase D closes it on from
there, its closure from 0). Prints, per controller: the hold rate, when the first contact came, how often the grasp
ended at the timeout, how many segments touched at the end, the share of control cycles in which some finger was
on its way to a recall instead of closing, and how far the targets opened after the first contact.
"""

import argparse
import glob

import numpy as np

from graspmanifold.control.controller import (BLEND, CLOSING_RECALL, FINGER_JOINT_MASKS, BatchController,
                                              ControllerParams)
from graspmanifold.manifold.postureset import PostureSet
from graspmanifold.trials.benchmark import OBJECTS, benchmark_split
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experience", default="study-uncertainty", help="a study's folder with experience_*.npz")
    parser.add_argument("--object", default="pen", choices=list(OBJECTS))
    parser.add_argument("--placement", default="palm", choices=["palm", "fingertips"])
    args = parser.parse_args()
    files = sorted(glob.glob(f"{args.experience}/experience_*.npz"))
    if not files:
        raise SystemExit(f"error: no experience_*.npz in {args.experience}: run a study there first")
    som = train_experience_map(np.concatenate([PostureSet.load(f).postures for f in files]))
    poses = benchmark_split()["test"][(args.object, args.placement)]
    opened, closed = BatchController(1, None).initial, BatchController(1, None).closed
    span = np.where(closed == opened, 1.0, closed - opened)
    outcomes = {}
    print(f"{args.object} at the {args.placement}, {len(poses)} test poses, experience of {len(files)} objects")
    for label, params in (("paper's controller", ControllerParams()), ("closing recall", CLOSING_RECALL),
                          ("blend", BLEND)):
        trials, log = traced(TrialSetup(OBJECTS[args.object].object, som, params=params), poses)
        times = np.array([entry[0] for entry in log])
        touched = np.array([(entry[2] > 0).any(axis=1) for entry in log])  # (cycles, worlds)
        first = np.array([times[np.argmax(touched[:, w])] if touched[:, w].any() else np.nan
                          for w in range(len(poses))])
        on_way = np.array([entry[4].any(axis=1) for entry in log])
        closure = np.array([[((entry[3][:, m] - opened[m]) / span[m]).mean(axis=1) for m in FINGER_JOINT_MASKS]
                            for entry in log])  # (cycles, fingers, worlds): how far each finger's target is closed
        after = times[:, None] >= first[None, :]
        opening = (np.maximum(0.0, -np.diff(closure, axis=0)).sum(axis=1) * after[1:]).sum(axis=0)
        held = np.array([t.hold for t in trials])
        timeout = np.array([t.time_to_grasp >= params.timeout - 1e-9 for t in trials])
        segments = np.array([t.touching.sum() for t in trials])
        outcomes[label] = held
        print(f"- {label}: holds {held.sum()} of {len(held)}; first contact at {np.nanmedian(first):.2f} s (median); "
              f"timeout {timeout.mean():.0%}; segments touching at the end {segments.mean():.1f}; cycles with a finger "
              f"on its way to a recall: {on_way[~after].mean():.0%} before the first contact, {on_way[after].mean():.0%} "
              f"after; targets opened after the first contact by {opening.mean():.2f} closure units (summed over "
              f"fingers); best-match queries {np.median([t.matches for t in trials]):.0f} (median)")
    paper = outcomes["paper's controller"]
    for label in ("closing recall", "blend"):
        print(f"- poses {label} holds and the paper's controller drops: {int((outcomes[label] & ~paper).sum())}; the "
              f"reverse: {int((paper & ~outcomes[label]).sum())}")


if __name__ == "__main__":
    main()
