"""Why the paper's literal controller loses where the blend holds: every trial of a benchmark cell traced, three
readings of the recall on the same poses with the same experience.

    python scripts/trace_literal_controller.py [--experience study-uncertainty] [--object pen] [--placement palm]
    python scripts/trace_literal_controller.py --all   # every cell of the test split, and the pooled comparisons
    python scripts/trace_literal_controller.py --quick  # a smoke run: the first QUICK_POSES test poses of one cell
    (the report kept in --out DIR, default study-recall-trace, as recall_trace.md)

The experience is the verified postures a study kept (`experience_<object>.npz` in its folder: the experience or the
uncertainty study), one SOM trained on all of them as the studies train it. The readings (`READINGS`): the paper's
literal controller (`ControllerParams()`), the same with recalls that only close a finger (`CLOSING_RECALL`), and
the blend (`BLEND`). Each control cycle of every world is logged by a `TracedController` around ours: the sensed
touch, the targets, and which fingers are on their way to a recalled posture (the literal reading moves a free
finger to each new recall at the heuristic's speed before phase D closes it on from there, its closure from 0).
Printed per reading, as markdown: the hold rate, when the first contact came, how often the grasp ended at the
timeout, how many segments touched at the end, the share of control cycles in which some finger was on its way to
a recall instead of closing, and how far the targets opened after the first contact; with `--all`, every (object,
placement) of the test split, then the pooled paired comparisons (McNemar, Holm within the family).
"""

from __future__ import annotations

import argparse
import glob
from typing import Any

import numpy as np

from ..control.controller import BLEND, CLOSING_RECALL, BatchController, ControllerParams
from ..control.state import FINGER_JOINT_MASKS
from ..manifold.postureset import PostureSet
from ..manifold.som import SOM
from ..sim.hand import HandModel
from ..trials.benchmark import OBJECTS, PLACEMENTS, benchmark_split
from ..trials.experience_pays import train_experience_map
from ..trials.stats import mcnemar, rate_text
from ..trials.episode import run_trials
from ..trials.setup import TrialSetup
from .runner import comparison_table, holm_family, run_study

#: the readings of the recall traced side by side
READINGS: tuple[tuple[str, ControllerParams], ...] = (
    ("paper's controller", ControllerParams()), ("closing recall", CLOSING_RECALL), ("blend", BLEND))
#: test poses of a `--quick` run's cell
QUICK_POSES = 3


class TracedController:
    """Our controller with every control cycle logged: (s since the start, segment forces (N, S), targets (N, 22),
    fingers on their way to a recall (N, 5)); everything else is the controller's own.

    Args:
        controller: the controller traced.
    """

    def __init__(self, controller: BatchController):
        self.controller = controller
        self.log: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []

    def __getattr__(self, name: str) -> Any:  # every other member is the controller's, as it types it
        return getattr(self.controller, name)

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """The controller's step, logged."""
        targets = self.controller.step(joints, segment_forces)
        self.log.append((self.controller.time, np.array(segment_forces, copy=True), targets.copy(),
                         self.controller.state.approaching.copy()))
        return targets


def trace_cell(som: SOM, name: str, placement: str,
               poses: int | None = None) -> tuple[list[str], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Every test pose of one cell (or its first `poses`) under each reading.

    Args:
        som: the experience.
        name: a benchmark object.
        placement: 'palm' or 'fingertips'.
        poses: trace only the first this many test poses (None: all).

    Returns:
        (markdown lines, {reading: (held, valid) per pose}).
    """
    grid = benchmark_split()["test"][(name, placement)][:poses]
    opened, closed = BatchController(1, None).initial, BatchController(1, None).closed
    span = np.where(closed == opened, 1.0, closed - opened)
    lines, outcomes = [f"### {name} at the {placement} ({len(grid)} test poses)", ""], {}
    for label, params in READINGS:
        made: list[TracedController] = []

        def factory(n: int, hand: HandModel, params: ControllerParams = params,
                    made: list[TracedController] = made) -> TracedController:
            made.append(TracedController(BatchController(n, som, params, hand=hand)))
            return made[-1]

        trials = run_trials(TrialSetup(object=OBJECTS[name].object, controller=factory, method=label), grid,
                            [np.random.default_rng([0, i]) for i in range(len(grid))])
        log = made[0].log
        times = np.array([entry[0] for entry in log])
        touched = np.array([(entry[1] > 0).any(axis=1) for entry in log])  # (cycles, worlds)
        first = np.array([times[np.argmax(touched[:, w])] if touched[:, w].any() else np.inf
                          for w in range(len(grid))])
        on_way = np.array([entry[3].any(axis=1) for entry in log])
        closure = np.array([[((entry[2][:, m] - opened[m]) / span[m]).mean(axis=1) for m in FINGER_JOINT_MASKS]
                            for entry in log])  # (cycles, fingers, worlds): how far each finger's target is closed
        after = times[:, None] >= first[None, :]
        opening = (np.maximum(0.0, -np.diff(closure, axis=0)).sum(axis=1) * after[1:]).sum(axis=0)
        held, valid = np.array([t.hold for t in trials]), np.array([t.valid for t in trials])
        timeout = np.array([t.time_to_grasp >= params.timeout - 1e-9 for t in trials])
        touched_at = first[np.isfinite(first)]
        outcomes[label] = (held, valid)
        lines.append(
            f"- {label}: holds {rate_text(int(held[valid].sum()), int(valid.sum()))}; first contact at "
            f"{np.median(touched_at) if len(touched_at) else float('nan'):.2f} s (median); timeout {timeout.mean():.0%}; "
            f"segments touching at the end {np.mean([t.touching.sum() for t in trials]):.1f}; cycles with a finger on "
            f"its way to a recall: {on_way[~after].mean() if (~after).any() else 0:.0%} before the first contact, "
            f"{on_way[after].mean() if after.any() else 0:.0%} after; targets opened after the first contact by "
            f"{opening.mean():.2f} closure units (summed over fingers); best-match queries "
            f"{np.median([t.matches for t in trials]):.0f} (median)")
    return lines + [""], outcomes


def main(argv: list[str] | None = None) -> None:
    """The command: `python scripts/trace_literal_controller.py --help`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experience", default="study-uncertainty", help="a study's folder with experience_*.npz")
    parser.add_argument("--object", default="pen", choices=list(OBJECTS))
    parser.add_argument("--placement", default="palm", choices=list(PLACEMENTS))
    parser.add_argument("--all", action="store_true", help="every cell of the test split, and pooled comparisons")
    parser.add_argument("--quick", action="store_true",
                        help=f"a smoke run: the first {QUICK_POSES} test poses of the one cell (not with --all)")
    parser.add_argument("--out", default="", help="the folder its report (recall_trace.md) is kept in (default "
                        "study-recall-trace[-quick])")
    args = parser.parse_args(argv)
    if args.quick and args.all:
        parser.error("--quick traces one cell: give it without --all")
    args.out = args.out or ("study-recall-trace-quick" if args.quick else "study-recall-trace")

    def trace(run: object) -> None:
        files = sorted(glob.glob(f"{args.experience}/experience_*.npz"))
        if not files:
            raise SystemExit(f"error: no experience_*.npz in {args.experience}: run a study there first")
        sets = [PostureSet.load(f) for f in files]
        som = train_experience_map(np.concatenate([s.postures for s in sets]))
        print(f"Experience: {sum(len(s) for s in sets)} verified postures of {len(files)} objects ({args.experience}), "
              "one SOM.\n")
        cells = [(o, p) for o in OBJECTS for p in PLACEMENTS] if args.all else [(args.object, args.placement)]
        runs = []
        for name, placement in cells:
            lines, outcomes = trace_cell(som, name, placement, QUICK_POSES if args.quick else None)
            print("\n".join(lines), flush=True)
            runs.append(outcomes)
        pooled = {label: tuple(np.concatenate([r[label][k] for r in runs]) for k in (0, 1)) for label, _ in READINGS}

        def versus(a: str, b: str):
            return mcnemar(pooled[a][0], pooled[b][0], valid=pooled[a][1] & pooled[b][1])

        print("### Pooled\n")
        print("\n".join(f"- {label}: {rate_text(int(held[valid].sum()), int(valid.sum()))}"
                        for label, (held, valid) in pooled.items()) + "\n")
        print("\n".join(comparison_table(holm_family([
            ("closing recall against the paper's controller", versus("closing recall", "paper's controller")),
            ("the blend against the paper's controller", versus("blend", "paper's controller")),
            ("the blend against the closing recall", versus("blend", "closing recall"))]))))

    run_study(args.out, 1, trace, "recall_trace.md")
