"""Does experience pay? Paired comparisons of grasp methods, experience grown from the controller's
own grasps, and a plain verdict.

The paper's claim is that recalling experienced grasps from the Partial Contact Posture makes a
tactile grasp better than the closing heuristic alone. Measured honestly that means: the same
poses for every method (paired outcomes, McNemar's test), the hold test as the primary measure,
and the strongest simple control, not the weakest, as the bar.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..base.moved import moved_attribute
from ..base.paper_numbers import MAP_SIZE
from ..control.controller import ControllerParams
from ..manifold.som import SOM
from ..sim.hand import N_FINGER_JOINTS
from ..sim.objects import GraspObject
from .evaluation import EvaluationResult, evaluate
from .stats import compare as paired_comparison
from .stats import rate_text
from .setup import Noise

#: Where the controller gathers its own experience: grid poses perturbed by this much, so the poses
#: it learns from are never the poses it is tested on.
TRAINING_NOISE = Noise(position=0.01, yaw=0.2)
#: The bar of the target: experience must win where the strongest control holds fewer than this.
HARD_FOR_CONTROL = 0.8


def train_experience_map(postures: np.ndarray, seed: int = 0, shape: tuple[int, int] = MAP_SIZE) -> SOM:
    """A SOM grasp manifold of the paper's size and schedule on these postures."""
    return SOM(*shape, postures.shape[1], seed=seed).fit(postures)


def grow_experience(obj: GraspObject, postures: np.ndarray, grid: np.ndarray, rounds: int, *, seed: int = 0,
                    workers: int | None = None, on_round: Callable[[int, SOM | None, np.ndarray], None] | None = None,
                    progress: bool | None = None) -> tuple[np.ndarray, list[dict]]:
    """The paper's resumed learning as a loop: grasp, keep what held, retrain, grasp again.

    Each round trains a SOM on the experience so far (none yet: the plain heuristic grasps), lets
    the controller grasp at the grid poses perturbed by `TRAINING_NOISE` (a fresh draw per round),
    and adds the final postures of the grasps that held. `on_round(round, som, postures)` is called
    with each round's map before it grasps (to measure a learning curve). Returns the grown
    postures (the given ones first) and one record per round.
    """
    grown = np.asarray(postures, dtype=float).reshape(-1, N_FINGER_JOINTS)
    records = []
    for r in range(rounds):
        som = train_experience_map(grown, seed) if len(grown) else None
        if on_round is not None:
            on_round(r, som, grown)
        result = evaluate(obj, som, grid, seed=seed + 1000 * (r + 1), workers=workers, noise=TRAINING_NOISE,
                          progress=progress)
        held = result.successful_postures()
        records.append({"round": r, "experience_before": len(grown), "trials": len(result.trials),
                        "held": len(held), "hold_rate": result.summary["hold_rate"]})
        grown = np.concatenate([grown, held])
    return grown, records


#: the controls of a verdict by what they are ('none' is the plain heuristic's method name)
_CONTROL_NAMES = {"none": "the plain heuristic, none"}


@dataclass(frozen=True)
class TargetVerdict:
    """The target, judged: wins where the strongest control is below `HARD_FOR_CONTROL`, and losses."""

    met: bool
    wins: list[tuple[str, str]]  # (object, grid) where experience beats the strongest control
    losses: list[tuple[str, str]]  # where it loses significantly
    text: str


def judge_target(rows: list[dict], method: str = "som", alpha: float = 0.05) -> TargetVerdict:
    """Judge the target from comparison rows (`comparison_rows`) of `method` against the strongest control."""
    mine = [r for r in rows if r["method"] == method]
    wins = [(r["object"], r["grid"]) for r in mine
            if r["verdict"] == "better" and r["control_rate"] < HARD_FOR_CONTROL and r["p_value"] < alpha]
    losses = [(r["object"], r["grid"]) for r in mine if r["verdict"] == "worse"]
    won_objects = sorted({o for o, _ in wins})
    met = len(won_objects) >= 2 and not losses
    controls = sorted({r["control"] for r in mine})
    strongest = ("the strongest control (" + ", ".join(_CONTROL_NAMES.get(c, c) for c in controls) + ")" if controls
                 else "a control (none was run)")
    where = f"where that control holds below {HARD_FOR_CONTROL:.0%}"
    if met:
        text = (f"Target met: the {method} controller beats {strongest} on the hold test at p < {alpha} on "
                f"{', '.join(won_objects)}, {where}, and loses significantly nowhere.")
    else:
        beaten = (f"on {len(won_objects)} object{'s' if len(won_objects) != 1 else ''} "
                  f"({', '.join(f'{o}/{g}' for o, g in wins)})" if wins else "on no object")
        lost = (f"loses significantly on {', '.join(f'{o}/{g}' for o, g in losses)}" if losses
                else "loses significantly nowhere")
        text = (f"Target not met: the {method} controller beats {strongest} significantly {beaten} (p < {alpha}, "
                f"counted {where}), and {lost}; the target is two such objects and no significant loss.")
    return TargetVerdict(met, wins, losses, text)


def comparison_rows(results: dict[tuple[str, str, str], EvaluationResult], methods: tuple[str, ...],
                    controls: tuple[str, ...], measure: str = "hold") -> list[dict]:
    """For every (object, grid) and method: the method against the strongest of the controls there."""
    rows = []
    for obj, grid in sorted({(o, g) for o, g, _ in results}):
        present = [c for c in controls if (obj, grid, c) in results]
        if not present:
            continue
        rate = {c: results[(obj, grid, c)].rate(measure) for c in present}
        strongest = max(present, key=lambda c: (rate[c], -present.index(c)))
        for method in methods:
            if (obj, grid, method) not in results:
                continue
            mine = results[(obj, grid, method)]
            paired = paired_comparison(mine, results[(obj, grid, strongest)], measure)
            k, k_control = paired.only_a + paired.both, paired.only_b + paired.both
            rows.append({"object": obj, "grid": grid, "method": method, "control": strongest, "n": paired.n,
                         "rate": k / paired.n, "rate_text": rate_text(k, paired.n),
                         "control_rate": k_control / paired.n, "control_text": rate_text(k_control, paired.n),
                         "only_method": paired.only_a, "only_control": paired.only_b,
                         "p_value": paired.p_value, "verdict": paired.verdict()})
    return rows


def closing_rate_params(factor: float) -> ControllerParams:
    """The plain heuristic closing `factor` times as fast (the speed-matched control)."""
    return ControllerParams(closing_rate=ControllerParams.closing_rate * factor)


def __getattr__(name: str) -> object:
    """`compare`, which moved to the statistics room (`stats.compare`) in 0.3, with a warning."""
    return moved_attribute(__name__, name)
