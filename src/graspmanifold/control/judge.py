"""Judging a grasp in the simulation: force closure, the hold test and the disturbance margin.

A grasp is judged once the hand has closed on a free object that a support has kept in place (a
spring with gravity off, or a table with gravity on); the support is released first. Three measures, primary first:

- hold: gravity is switched on along +x, -x, +y, -y, +z and -z in turn (`hold_seconds` each)
  while the hand keeps its grasp; the object must stay within `JudgingRules.hold_limit` of where it was grasped;
- margin: a grasp that holds is then pushed, in the same six directions in turn, by an extra
  force on the object that ramps from 0 to `margin_force` over `margin_seconds` (on top of
  gravity along that direction); the margin is the extra force (N) at which the object first
  leaves the 2 cm bound, `margin_force` when it never does (a censored value), 0 when it did not hold;
- force closure: the Ferrari-Canny epsilon of the L1 grasp wrench space of the contacts at the
  moment of release, with the object's friction (the one the simulation uses), above
  `epsilon_threshold`, the paper's measure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..sim.hand import HandModel
from ..sim.objects import GraspObject
from ..sim.scene import GRAVITY, Scene
from ..sim.tactile import TactileReading
from .quality import epsilon_l1

HOLD_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)


@dataclass(frozen=True)
class JudgingRules:
    """How every grasp is judged (see the module doc), in one place: `judge_grasp`, the batched judge of
    `batch_trials` and the generator's verifier (a shorter `hold_seconds`, no margin) all read it.

    Attributes:
        hold_seconds: s of gravity per direction in the hold test.
        hold_limit: m the object may move from where it was grasped and still be held.
        margin_force: N, the largest extra disturbance tried (about five times a 0.1 kg object's weight).
        margin_seconds: s per direction of the margin's ramp.
        epsilon_threshold: force closure means epsilon above this: the grasp resists every disturbance
            wrench of at least 1 % of its total normal force; smaller values are numerically marginal closure.
        support_stiffness: N/m (and N m/rad) of the object's support while the hand closes.
        support_damping: N s/m (and N m s/rad) of that support: about critical for 0.1 kg.
    """

    hold_seconds: float = 0.5
    hold_limit: float = 0.02
    margin_force: float = 5.0
    margin_seconds: float = 0.3
    epsilon_threshold: float = 0.01
    support_stiffness: float = 2000.0
    support_damping: float = 30.0

    @staticmethod
    def cycles(seconds: float, period: float) -> int:
        """Control cycles of `period` s in `seconds` (at least one)."""
        return max(1, round(seconds / period))


JUDGING = JudgingRules()
"""The rules every trial is judged by."""


@dataclass(frozen=True)
class Judgement:
    """How good one grasp is (see the module doc)."""

    epsilon: float
    hold: bool
    displacement: float  # m, largest during the hold test
    margin: float  # N

    @property
    def force_closure(self) -> bool:
        return self.epsilon > JUDGING.epsilon_threshold


def supported_scene(obj: GraspObject, table: bool = False, hand: str | HandModel = "ours") -> Scene:
    """A scene whose free object rests on the support a grasp closes on, before judging releases it: the
    spring-damper of `JUDGING` with gravity off, or a table with gravity on. Trials and the generator's
    verifier start from it (`hold_on_support` sets the spring again after a reset).

    Args:
        obj: the object.
        table: a table with gravity on instead of the spring.
        hand: the hand model, or its name.

    Returns:
        The scene.
    """
    scene = Scene(obj, free_object=True, gravity=table, table=table, hand=hand)
    hold_on_support(scene)
    return scene


def hold_on_support(scene: Scene) -> None:
    """Put a scene's free object back on the spring support (nothing to do on a table).

    Args:
        scene: a scene made by `supported_scene`.
    """
    if scene.table_geom is None:
        scene.set_object_support(JUDGING.support_stiffness, JUDGING.support_damping)


def grasp_epsilon(scene: Scene) -> float:
    """Epsilon of the current hand-object contacts, with the object's friction."""
    return reading_epsilon(scene.tactile(), scene.data.xipos[scene.object_body].copy(), scene.object.friction)


def reading_epsilon(reading: TactileReading, centre: np.ndarray, friction: float) -> float:
    """Epsilon of a reading's contacts about the object's centre of mass `centre`."""
    if not len(reading.forces):
        return 0.0
    return float(epsilon_l1(reading.points, reading.normals, centre, mu=friction))


def judge_grasp(scene: Scene, cycle: Callable[[], None], period: float, *, rules: JudgingRules = JUDGING,
                margin: bool = True) -> Judgement:
    """Release the support and judge the grasp; `cycle()` advances one control period of `period` s."""
    scene.set_object_support(0.0, 0.0)
    if scene.table_geom is not None:
        scene.set_table(False)  # lifted off the table
    epsilon = grasp_epsilon(scene)
    start = scene.object_pose()[0]
    moved = lambda: float(np.linalg.norm(scene.object_pose()[0] - start))  # noqa: E731
    worst = 0.0
    for direction in HOLD_DIRECTIONS:
        scene.set_gravity(GRAVITY * direction)
        for _ in range(rules.cycles(rules.hold_seconds, period)):
            cycle()
            worst = max(worst, moved())
    hold = worst <= rules.hold_limit
    held_force = 0.0
    if hold and margin:
        held_force = rules.margin_force
        steps = rules.cycles(rules.margin_seconds, period)
        push = scene.data.xfrc_applied[scene.object_body]
        for direction in HOLD_DIRECTIONS:
            scene.set_gravity(GRAVITY * direction)
            for k in range(1, steps + 1):
                push[:3] = rules.margin_force * k / steps * direction
                cycle()
                if moved() > rules.hold_limit:
                    held_force = rules.margin_force * (k - 1) / steps
                    break
            if held_force < rules.margin_force:
                break
        push[:] = 0.0
    scene.set_gravity(False)
    return Judgement(epsilon, hold, worst, held_force)
