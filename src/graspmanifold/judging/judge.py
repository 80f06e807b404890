"""Judging a grasp in the simulation: force closure, the hold test and the disturbance margin.

A grasp is judged once the hand has closed on a free object that a support has kept in place (a
spring with gravity off, or a table with gravity on); the support is released first. Three measures, primary first:

- hold: gravity is switched on along +x, -x, +y, -y, +z and -z in turn (`hold_seconds` each)
  while the hand keeps its grasp; the object must stay within `JudgingRules.hold_limit` of where it was grasped
  (the test ends for a world in the period its object leaves the bound);
- margin (only where `JudgingRules.margin` asks for it: a report that shows it; it adds up to six
  `margin_seconds` of physics to every grasp that holds): a grasp that holds is then pushed, in the same six
  directions in turn, by an extra force on the object that ramps from 0 to `margin_force` over
  `margin_seconds` (on top of gravity along that direction); the margin is the extra force (N) at which
  the object first leaves the bound (the ramp ends there), `margin_force` when it never does (a censored
  value), 0 when it did not hold, NaN when it was not asked for;
- force closure: the Ferrari-Canny epsilon of the L1 grasp wrench space of the contacts at the
  moment of release, with the object's friction (the one the simulation uses), above
  `epsilon_threshold`, the paper's measure.

`episode_loop` is the one judging loop, over N worlds at once, whatever steps them (`CpuWorlds`, or
`WarpWorlds` on a GPU): the trials run it while their controller grasps, the open-loop replay
(`replay.replay_grasp`, the generator's verifier among its callers) once the hand has squeezed. Its
stages are objects (`stages.py`: the grasp, the hold test, the margin; `JudgingRules.stages` names those after the
grasp, so a stage of one's own runs without a change to the loop). No simulated second is spent that cannot
change an outcome: a world's hold test ends in the period its object leaves the bound, its margin ramp
likewise, and the margin runs only where it is asked for.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..base.errors import QualityError
from ..base.moved import moved_attribute
from ..sim.flange import FlangeLimits
from ..sim.grip import row_norms
from ..sim.hand import SEGMENTS, SHADOW_HAND, HandModel
from ..sim.objects import GraspObject
from ..sim.scene import Scene
from ..sim.tactile import TactileReading
from ..sim.worlds import CpuWorlds, Worlds
from .quality import epsilon_l1
from .stages import Grasp, JudgingRules

JUDGING = JudgingRules()
"""The rules every trial is judged by."""


@dataclass(frozen=True)
class Judgement:
    """How good one grasp is (see the module doc), or why its physics failed: epsilon at release (per unit
    total normal force), hold, the largest displacement in the hold test (m; inf when the physics failed; for a
    grasp that did not hold, where the object was in the period it first left the bound: beyond the limit, and
    the test stops there, as no later direction can change the outcome), margin (N; NaN when the rules did not
    ask for it), the posture (22,) rad and touching segments (`SEGMENTS` order) at release, the deepest contact
    (m, up to where judging stopped), the fault (empty when none), the world's clock when it failed (s), and the
    seconds of the hold test run (all six directions' `hold_seconds` for a grasp that held, fewer for one that
    dropped its object; 0 on a fault)."""

    epsilon: float
    hold: bool
    displacement: float
    margin: float
    posture: np.ndarray | None = None
    touching: np.ndarray | None = None
    penetration: float = 0.0
    fault: str = ""
    time: float = float("nan")
    hold_time: float = 0.0


def supported_scene(obj: GraspObject, table: bool = False, hand: str | HandModel = SHADOW_HAND.name,
                    touch: str = "contacts", rules: JudgingRules = JUDGING,
                    flange: FlangeLimits | None = None) -> Scene:
    """A scene whose free object rests on the support a grasp closes on, before judging releases it: the
    spring-damper of the judging rules with gravity off, or a table with gravity on. Trials start from it
    (`hold_on_support` sets the spring again after a reset).

    Args:
        obj: the object.
        table: a table with gravity on instead of the spring.
        hand: the hand model, or its name.
        touch: where the sensed segment forces come from (`scene.TOUCH_SOURCES`).
        rules: the judging rules whose support it is (`JudgingRules.support_stiffness`, `support_damping`).
        flange: the hand on an arm's flange with these limits (`sim.flange`), or None.

    Returns:
        The scene.
    """
    scene = Scene(obj, free_object=True, gravity=table, table=table, hand=hand, touch=touch, flange=flange)
    hold_on_support(scene, rules)
    return scene


def hold_on_support(scene: Scene, rules: JudgingRules = JUDGING) -> None:
    """Put a scene's free object back on the spring support (nothing to do on a table).

    Args:
        scene: a scene made by `supported_scene`.
        rules: the judging rules whose support it is.
    """
    if scene.table_geom is None:
        scene.set_object_support(rules.support_stiffness, rules.support_damping)


def reading_epsilon(reading: TactileReading, centre: np.ndarray, friction: float) -> float:
    """Epsilon of a reading's contacts about the object's centre of mass `centre` (3,), m (0 without a contact)."""
    if not len(reading.forces):
        return 0.0
    return float(epsilon_l1(reading.points, reading.normals, centre, mu=friction))


def judge_scene(scene: Scene, rules: JudgingRules = JUDGING, period: float = 0.02) -> Judgement:
    """Judge the grasp a scene (from `supported_scene`) holds now, its actuators keeping their targets:
    `episode_loop` on one world that only steps; one look at the object every `period` s."""
    worlds = CpuWorlds([scene])
    nstep = max(1, round(period / scene.model.opt.timestep))
    return episode_loop(worlds, period, lambda live: worlds.step(live, nstep), friction=scene.object.friction,
                        rules=rules)[0]


#: s of gravity per direction in the verifier's hold test (`replay.GraspVerifier`): a trial's, so that a
#: verified grasp is one that holds when replayed under our hold test (a shorter hold kept a quarter of the
#: marble's grasps that the full hold drops)
VERIFY_HOLD_SECONDS = JUDGING.hold_seconds


class Judging:
    """One run of the judging loop over N worlds: what its stages (`stages.Stage`) share, and the judgements.

    Args:
        worlds: the worlds (`CpuWorlds`, `WarpWorlds`).
        period: s per control period.
        rules: the judging rules.
        friction: the objects' friction, for epsilon.

    Attributes:
        n: worlds.
        directions: (k, 3) the rules' disturbance directions.
        start: (n, 3) m, where each object was when its grasp was released.
        displacement: (n,) m, the largest displacement of each object in the hold test so far.
        margin: (n,) N, each grasp's disturbance margin (NaN where the rules do not ask for it).
        hold_time: (n,) s of the hold test run (all of it unless the object dropped).
        stage: (n,) the index of the stage each world is in (0: the grasp); -1 once it is judged.
        judged: one `Judgement` per world once it is judged (None before).
    """

    def __init__(self, worlds: Worlds, period: float, rules: JudgingRules, friction: float):
        n = self.n = worlds.n
        self.worlds, self.period, self.rules, self.friction = worlds, period, rules, friction
        self.directions = np.asarray(rules.directions, dtype=float).reshape(-1, 3)
        self.start = np.zeros((n, 3))
        self._start_quat = np.zeros((n, 4))
        self.displacement = np.zeros(n)
        self.margin = np.zeros(n) if rules.margin else np.full(n, np.nan)
        self.hold_time = np.full(n, len(self.directions) * rules.hold_seconds)
        self.stage = np.zeros(n, dtype=int)
        self.judged: list[Judgement | None] = [None] * n
        self._grasped: dict[int, tuple] = {}

    def release(self, worlds: np.ndarray) -> np.ndarray:
        """Release the objects of these worlds from their support and record their grasps (the touch, the posture,
        epsilon, where each object is); a world whose epsilon cannot be computed is judged a fault.

        Args:
            worlds: their indices.

        Returns:
            Those whose grasp was recorded.
        """
        if not len(worlds):
            return worlds
        self.worlds.release(worlds)
        positions = self.worlds.object_positions()
        quats = self.worlds.object_quats() if math.isfinite(self.rules.angle_limit) else None
        recorded = []
        for world in worlds:
            reading, centre = self.worlds.reading(world)
            try:
                epsilon = reading_epsilon(reading, centre, self.friction)
            except QualityError as error:
                self.fail(world, str(error))
                continue
            self._grasped[world] = (reading, self.worlds.posture(world), epsilon)
            self.start[world] = positions[world]
            if quats is not None:
                self._start_quat[world] = quats[world]
            recorded.append(world)
        return np.array(recorded, dtype=int)

    def moved(self) -> np.ndarray:
        """(n,) m each object has moved from where it was grasped; inf where it turned beyond the angle limit."""
        with np.errstate(invalid="ignore"):
            moved = row_norms(self.worlds.object_positions() - self.start)
            if math.isfinite(self.rules.angle_limit):
                dots = np.clip(np.abs(np.sum(self.worlds.object_quats() * self._start_quat, axis=1)), 0.0, 1.0)
                moved = np.where(2.0 * np.arccos(dots) > self.rules.angle_limit, np.inf, moved)
        return moved

    def finish(self, world: int) -> None:
        """Judge a world whose grasp was recorded, by the measures its stages left.

        Args:
            world: its index.
        """
        self.stage[world] = -1
        reading, posture, epsilon = self._grasped.pop(world)
        displacement = self.displacement[world]
        self.judged[world] = Judgement(epsilon, bool(displacement <= self.rules.hold_limit), float(displacement),
                                       float(self.margin[world]), posture,
                                       np.array([reading.touches(s) for s in SEGMENTS]),
                                       self.worlds.max_penetration(world), hold_time=float(self.hold_time[world]))

    def fail(self, world: int, why: str) -> None:
        """Judge a world whose physics failed: a fault, neither held nor closed.

        Args:
            world: its index.
            why: what failed (the judgement's `fault`).
        """
        self.stage[world] = -1
        self._grasped.pop(world, None)
        self.judged[world] = Judgement(0.0, False, np.inf, 0.0 if self.rules.margin else np.nan,
                                       self.worlds.posture(world), np.zeros(len(SEGMENTS), dtype=bool),
                                       self.worlds.max_penetration(world), why, self.worlds.time(world))


def episode_loop(worlds: Worlds, period: float, advance: Callable[[np.ndarray], dict[int, str]], *,
                 friction: float, rules: JudgingRules = JUDGING,
                 ready: Callable[[], np.ndarray] | None = None) -> list[Judgement]:
    """The episode loop (see the module doc of `stages`; `judge_worlds` before 0.3): every world goes through the grasp (until `ready()`,
    (n,) bool, asked once a period while a world grasps; None: all ready from the start) and then the rules'
    stages (`JudgingRules.stages`: the hold test, the margin), all worlds advancing together one control period of
    `period` s at a time until each is judged.

    Args:
        worlds: the worlds.
        period: s per control period.
        advance: `advance(live)` runs one period of the worlds given (an index array; a judged world is never
            given, its state may not be finite): whatever drives the hands, then the physics; it returns {world:
            why its physics failed}.
        friction: the objects', for epsilon.
        rules: the judging rules.
        ready: which grasps are ready, asked every period (None: all).

    Returns:
        One `Judgement` per world, in order.
    """
    run = Judging(worlds, period, rules, friction)
    stages = [Grasp(run, ready), *(stage(run) for stage in rules.stages)]
    while (run.stage >= 0).any():
        for index, stage in enumerate(stages):
            holding = np.flatnonzero(run.stage == index)
            if not len(holding):
                continue
            passed = stage.step(holding)
            passed = passed[run.stage[passed] == index]  # not judged by the step (a fault)
            if index + 1 < len(stages):
                run.stage[passed] = index + 1
                if len(passed):
                    stages[index + 1].begin(passed)
            else:
                for world in passed:
                    run.finish(world)
        live = np.flatnonzero(run.stage >= 0)
        if not len(live):
            break
        for world, why in advance(live).items():
            run.fail(world, why)
        if not (run.stage > 0).any():  # the objects are looked at only while judged
            continue
        moved = run.moved()
        for index, stage in enumerate(stages[1:], start=1):
            holding = np.flatnonzero(run.stage == index)
            for world in stage.done(holding, moved) if len(holding) else ():
                run.finish(world)
    return run.judged  # type: ignore[return-value]


def __getattr__(name: str) -> object:
    """`judge_worlds`, the episode loop's name before 0.3, with a warning (`base.moved.MOVED_NAMES`)."""
    return moved_attribute(__name__, name)
