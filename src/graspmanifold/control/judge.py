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

`judge_worlds` is the one judging loop, over N worlds at once, whatever steps them (`CpuWorlds`, or
`WarpWorlds` on a GPU): the trials run it while their controller grasps, the open-loop replay
(`dexgraspbench.replay_grasp`, the generator's verifier among its callers) once the hand has squeezed. No simulated second is spent that cannot
change an outcome: a world's hold test ends in the period its object leaves the bound, its margin ramp
likewise, and the margin runs only where it is asked for.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..base.errors import QualityError
from ..sim.hand import SEGMENTS, SHADOW_HAND, HandModel
from ..sim.objects import GraspObject
from ..sim.scene import GRAVITY, Scene
from ..sim.tactile import TactileReading
from ..sim.worlds import CpuWorlds, Worlds
from .controller import row_norms
from .quality import epsilon_l1

HOLD_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
#: the same directions as a tuple of tuples, for the frozen rules that hold them
SIX_DIRECTIONS: tuple[tuple[float, float, float], ...] = tuple(map(tuple, HOLD_DIRECTIONS.tolist()))


@dataclass(frozen=True)
class JudgingRules:
    """How every grasp is judged (see the module doc), in one place: `judge_worlds` reads it for the
    trials and for the generator's verifier (a shorter `hold_seconds`, no margin).

    Attributes:
        hold_seconds: s of gravity per direction in the hold test.
        hold_limit: m the object may move from where it was grasped and still be held.
        margin_force: N, the largest extra disturbance tried (about five times a 0.1 kg object's weight).
        margin_seconds: s per direction of the margin's ramp.
        epsilon_threshold: force closure means epsilon above this: the grasp resists every disturbance
            wrench of at least 1 % of its total normal force; smaller values are numerically marginal closure.
        support_stiffness: N/m (and N m/rad) of the object's support while the hand closes.
        support_damping: N s/m (and N m s/rad) of that support: about critical for 0.1 kg.
        margin: measure the disturbance margin of a grasp that holds (False: the margin is NaN, not measured;
            `TrialSetup.margin` asks for it).
        push: N; 0 (ours): the disturbance along each direction is gravity; above 0 (DexGraspBench's): an external
            force of this size on the object, gravity off.
        angle_limit: rad the object may turn from where it was grasped and still be held (inf: any).
        from_grasp: every direction starts again from the state at the grasp's end (DexGraspBench replays its
            grasp for each); False (ours): the directions follow one another.
        physics: the name of the scene's physics profile (`protocols.PhysicsProfile`), '' for ours.
        directions: the disturbance's unit directions, in turn (ours: +x, -x, +y, -y, +z, -z; `HOLD_DIRECTIONS`).
    """

    hold_seconds: float = 0.5
    hold_limit: float = 0.02
    margin_force: float = 5.0
    margin_seconds: float = 0.3
    epsilon_threshold: float = 0.01
    support_stiffness: float = 2000.0
    support_damping: float = 30.0
    margin: bool = False
    push: float = 0.0
    angle_limit: float = math.inf
    from_grasp: bool = False
    physics: str = ""
    directions: tuple[tuple[float, float, float], ...] = SIX_DIRECTIONS

    @staticmethod
    def cycles(seconds: float, period: float) -> int:
        """Control cycles of `period` s in `seconds` (at least one)."""
        return max(1, round(seconds / period))


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


def supported_scene(obj: GraspObject, table: bool = False, hand: str | HandModel = SHADOW_HAND.name) -> Scene:
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


def reading_epsilon(reading: TactileReading, centre: np.ndarray, friction: float) -> float:
    """Epsilon of a reading's contacts about the object's centre of mass `centre` (3,), m (0 without a contact)."""
    if not len(reading.forces):
        return 0.0
    return float(epsilon_l1(reading.points, reading.normals, centre, mu=friction))


def judge_scene(scene: Scene, rules: JudgingRules = JUDGING, period: float = 0.02) -> Judgement:
    """Judge the grasp a scene (from `supported_scene`) holds now, its actuators keeping their targets:
    `judge_worlds` on one world that only steps; one look at the object every `period` s."""
    worlds = CpuWorlds([scene])
    nstep = max(1, round(period / scene.model.opt.timestep))
    return judge_worlds(worlds, period, lambda live: worlds.step(live, nstep), friction=scene.object.friction,
                        rules=rules)[0]


#: s of gravity per direction in the verifier's hold test (`dexgraspbench.GraspVerifier`): a trial's, so that a
#: verified grasp is one that holds when replayed under our hold test (a shorter hold kept a quarter of the
#: marble's grasps that the full hold drops)
VERIFY_HOLD_SECONDS = JUDGING.hold_seconds


_GRASP, _HOLD, _MARGIN, _FINISHED = range(4)


def judge_worlds(worlds: Worlds, period: float, advance: Callable[[np.ndarray], dict[int, str]], *,
                 friction: float, rules: JudgingRules = JUDGING,
                 ready: Callable[[], np.ndarray] | None = None) -> list[Judgement]:
    """The judging loop: every world, once its grasp is ready (`ready()`, (n,) bool, asked before every period;
    None: all from the start), released and judged (see the module doc), all worlds advancing together one
    control period of `period` s at a time until each is judged. `advance(live)` runs one period of the worlds
    given (an index array; a judged world is never given, its state may not be finite): whatever drives the
    hands, then the physics; it returns {world: why its physics failed}. `friction` is the objects', for epsilon.
    Returns one `Judgement` per world, in order.
    """
    n = worlds.n
    hold_cycles = rules.cycles(rules.hold_seconds, period)
    margin_cycles = rules.cycles(rules.margin_seconds, period)
    stage = np.full(n, _GRASP)
    directions = np.asarray(rules.directions, dtype=float).reshape(-1, 3)
    direction = np.zeros(n, dtype=int)  # which of the directions the judging is at
    count = np.zeros(n, dtype=int)  # control cycles done in that direction (the margin ramp's k)
    start = np.zeros((n, 3))
    start_quat = np.zeros((n, 4))
    saved: dict[int, object] = {}  # the state at each grasp's end, where every direction starts (`from_grasp`)
    turning = math.isfinite(rules.angle_limit)
    worst = np.zeros(n)
    hold_time = np.full(n, len(directions) * rules.hold_seconds)
    held_force = np.zeros(n) if rules.margin else np.full(n, np.nan)
    judged: list[Judgement | None] = [None] * n
    grasped: dict[int, tuple] = {}

    def finish(world: int) -> None:
        stage[world] = _FINISHED
        reading, posture, epsilon = grasped.pop(world)
        judged[world] = Judgement(epsilon, bool(worst[world] <= rules.hold_limit), float(worst[world]),
                                  float(held_force[world]), posture, np.array([reading.touches(s) for s in SEGMENTS]),
                                  worlds.max_penetration(world), hold_time=float(hold_time[world]))

    def disturb(chosen: np.ndarray) -> None:
        """The disturbance of each chosen world's direction: gravity along it, or a push with gravity off."""
        along = directions[direction[chosen]]
        if rules.push > 0:
            worlds.set_gravity(chosen, np.zeros((len(chosen), 3)))
            worlds.push(chosen, rules.push * along)
        else:
            worlds.set_gravity(chosen, GRAVITY * along)

    def fail(world: int, why: str) -> None:
        stage[world] = _FINISHED
        grasped.pop(world, None)
        judged[world] = Judgement(0.0, False, np.inf, 0.0 if rules.margin else np.nan, worlds.posture(world),
                                  np.zeros(len(SEGMENTS), dtype=bool), worlds.max_penetration(world), why,
                                  worlds.time(world))

    while (stage != _FINISHED).any():
        # judging begins for the worlds whose grasp ended in the last period
        begin = np.flatnonzero((stage == _GRASP) & (True if ready is None else ready()))
        if len(begin):
            worlds.release(begin)
            positions = worlds.object_positions()
            for world in begin:
                reading, centre = worlds.reading(world)
                try:
                    epsilon = reading_epsilon(reading, centre, friction)
                except QualityError as error:
                    fail(world, str(error))
                    continue
                grasped[world] = (reading, worlds.posture(world), epsilon)
                start[world] = positions[world]
                if turning:
                    start_quat[world] = worlds.object_quats()[world]
                if rules.from_grasp:
                    saved[world] = worlds.save(world)
            begin = begin[stage[begin] == _GRASP]
            stage[begin], direction[begin], count[begin] = _HOLD, 0, 0
            disturb(begin)
        # the hold test: hold_cycles periods per gravity direction
        turn = np.flatnonzero((stage == _HOLD) & (count == hold_cycles))
        direction[turn] += 1
        count[turn] = 0
        done_holding = turn[direction[turn] == len(directions)]
        held = done_holding[worst[done_holding] <= rules.hold_limit] if rules.margin else done_holding[:0]
        for world in np.setdiff1d(done_holding, held):  # a grasp that held, when no margin is asked for
            finish(world)
        stage[held], direction[held], count[held], held_force[held] = _MARGIN, 0, 0, rules.margin_force
        turn = turn[stage[turn] == _HOLD]
        for world in turn if rules.from_grasp else ():
            worlds.restore(world, saved[world])
        disturb(turn)
        # the margin: a push ramping up over margin_cycles periods per direction
        ramp = np.flatnonzero(stage == _MARGIN)
        count[ramp] += 1
        turn = ramp[count[ramp] > margin_cycles]
        direction[turn] += 1
        count[turn] = 1
        for world in turn[direction[turn] == len(directions)]:
            worlds.push(np.array([world]), np.zeros((1, 3)))
            finish(world)
        ramp = ramp[stage[ramp] == _MARGIN]
        worlds.set_gravity(ramp, GRAVITY * directions[direction[ramp]])
        pushes = (rules.margin_force * count[ramp] / margin_cycles)[:, None] * directions[direction[ramp]]
        worlds.push(ramp, pushes)

        live = np.flatnonzero(stage != _FINISHED)
        if not len(live):
            break
        for world, why in advance(live).items():
            fail(world, why)
        if not np.isin(stage, (_HOLD, _MARGIN)).any():  # the objects are looked at only while judged
            continue
        with np.errstate(invalid="ignore"):
            moved = row_norms(worlds.object_positions() - start)
            if turning:  # an angle beyond the limit counts as a displacement beyond it
                dots = np.clip(np.abs(np.sum(worlds.object_quats() * start_quat, axis=1)), 0.0, 1.0)
                moved = np.where(2.0 * np.arccos(dots) > rules.angle_limit, np.inf, moved)
        holding = np.flatnonzero(stage == _HOLD)
        worst[holding] = np.maximum(worst[holding], moved[holding])
        count[holding] += 1
        for world in holding[worst[holding] > rules.hold_limit]:  # dropped: no later direction can change that
            hold_time[world] = rules.hold_seconds * direction[world] + period * count[world]
            finish(world)
        ramp = np.flatnonzero(stage == _MARGIN)
        for world in ramp[moved[ramp] > rules.hold_limit]:
            held_force[world] = rules.margin_force * (count[world] - 1) / margin_cycles
            worlds.push(np.array([world]), np.zeros((1, 3)))
            finish(world)
    return judged
