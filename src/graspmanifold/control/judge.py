"""Judging a grasp in the simulation: force closure, the hold test and the disturbance margin.

A grasp is judged once the hand has closed on a free object that a support has kept in place (a
spring with gravity off, or a table with gravity on); the support is released first. Three measures, primary first:

- hold: gravity is switched on along +x, -x, +y, -y, +z and -z in turn (`hold_seconds` each)
  while the hand keeps its grasp; the object must stay within `HOLD_LIMIT` of where it was grasped;
- margin: a grasp that holds is then pushed, in the same six directions in turn, by an extra
  force on the object that ramps from 0 to `MARGIN_FORCE` over `MARGIN_SECONDS` (on top of
  gravity along that direction); the margin is the extra force (N) at which the object first
  leaves the 2 cm bound, `MARGIN_FORCE` when it never does (a censored value), 0 when it did not hold;
- force closure: the Ferrari-Canny epsilon of the L1 grasp wrench space of the contacts at the
  moment of release, with the object's friction (the one the simulation uses), above
  `EPSILON_THRESHOLD`, the paper's measure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..sim.scene import GRAVITY, Scene
from ..sim.tactile import TactileReading
from .quality import epsilon_l1

HOLD_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
HOLD_SECONDS = 0.5  # s per gravity direction
HOLD_LIMIT = 0.02  # m
MARGIN_FORCE = 5.0  # N: the largest extra disturbance tried (about five times a 0.1 kg object's weight)
MARGIN_SECONDS = 0.3  # s per direction for the ramp
#: Force closure means epsilon above this: the grasp resists every disturbance wrench of at least 1 %
#: of its total normal force; smaller values are numerically marginal closure.
EPSILON_THRESHOLD = 0.01
SUPPORT_STIFFNESS = 2000.0  # N/m (and N m/rad): the object's support while the hand closes
SUPPORT_DAMPING = 30.0  # N s/m (and N m s/rad): about critical for 0.1 kg


@dataclass(frozen=True)
class Judgement:
    """How good one grasp is (see the module doc)."""

    epsilon: float
    hold: bool
    displacement: float  # m, largest during the hold test
    margin: float  # N

    @property
    def force_closure(self) -> bool:
        return self.epsilon > EPSILON_THRESHOLD


def grasp_epsilon(scene: Scene) -> float:
    """Epsilon of the current hand-object contacts, with the object's friction."""
    return reading_epsilon(scene.tactile(), scene.data.xipos[scene.object_body].copy(), scene.object.friction)


def reading_epsilon(reading: TactileReading, centre: np.ndarray, friction: float) -> float:
    """Epsilon of a reading's contacts about the object's centre of mass `centre`."""
    if not len(reading.forces):
        return 0.0
    return float(epsilon_l1(reading.points, reading.normals, centre, mu=friction))


def judge_grasp(scene: Scene, cycle: Callable[[], None], period: float, *, hold_seconds: float = HOLD_SECONDS,
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
        for _ in range(max(1, round(hold_seconds / period))):
            cycle()
            worst = max(worst, moved())
    hold = worst <= HOLD_LIMIT
    held_force = 0.0
    if hold and margin:
        held_force = MARGIN_FORCE
        steps = max(1, round(MARGIN_SECONDS / period))
        push = scene.data.xfrc_applied[scene.object_body]
        for direction in HOLD_DIRECTIONS:
            scene.set_gravity(GRAVITY * direction)
            for k in range(1, steps + 1):
                push[:3] = MARGIN_FORCE * k / steps * direction
                cycle()
                if moved() > HOLD_LIMIT:
                    held_force = MARGIN_FORCE * (k - 1) / steps
                    break
            if held_force < MARGIN_FORCE:
                break
        push[:] = 0.0
    scene.set_gravity(False)
    return Judgement(epsilon, hold, worst, held_force)
