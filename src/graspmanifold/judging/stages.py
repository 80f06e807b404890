"""The rules of judging (`JudgingRules`) and the stages of the judging loop (`judge.episode_loop`): the grasp, the
hold test, the disturbance margin.

Every world goes through the stages in turn, each on its own clock of control periods; a stage holds some of
the worlds at a time. Every period the loop asks each stage, in order, to `step` the worlds it holds before the
physics (it sets their disturbance and hands on those it has finished with, which the next stage `begin`s in the
same period), runs one period of physics, and then asks each stage whether a world it holds is `done` (the
object left the bound: its judging ends there). A world that leaves the last stage is judged. The stages after
the grasp come from the rules (`JudgingRules.stages`): a stage of one's own is a subclass of `Stage` named there,
and runs without a change to the loop (dm_control's composer, one episode loop with the task as hooks, is the
model).

- `Grasp` (always first): the controller grasps until its grasp is ready (the regrasp's lift probe decides where
  attempts remain: `regrasp.LiftProbe`); then the support is released and the grasp recorded (its epsilon).
- `HoldTest`: the disturbance along each of the rules' directions in turn for `hold_seconds` (ours: gravity
  along it; DexGraspBench's: a push with gravity off, each direction from the state at the test's start); the
  object must stay within `hold_limit` (and `angle_limit`).
- `MarginRamp` (only where the rules ask for the margin): a grasp that held is pushed along each direction by a
  force that ramps from 0 to `margin_force`; the margin is the force at which the object first leaves the bound.
- `Lift` (the lift protocol's, in place of the two above, named with its settings as `LiftStage`): gravity on, the
  arm raises the palm straight up and holds it there; the object must keep up with the palm within `hold_limit` (it needs a hand on a flange).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import Bounds, check_directions, check_fields
from ..sim.scene import GRAVITY
from ..sim.worlds import Worlds


class JudgingRun(Protocol):
    """What a stage may use of the judging run it belongs to (`judge.Judging`, one per call of the loop).

    Attributes:
        worlds: the worlds judged (`sim.worlds.Worlds`).
        rules: the judging rules (`JudgingRules`).
        period: s per control period.
        n: worlds.
        directions: (k, 3) the rules' disturbance directions.
        start: (n, 3) m, where each object was when its grasp was released.
        displacement: (n,) m, the largest displacement of each object in the hold test so far.
        margin: (n,) N, each grasp's disturbance margin (NaN where the rules do not ask for it).
        hold_time: (n,) s of the hold test run.
    """

    worlds: Worlds
    rules: JudgingRules
    period: float
    n: int
    directions: np.ndarray
    start: np.ndarray
    displacement: np.ndarray
    margin: np.ndarray
    hold_time: np.ndarray

    def release(self, worlds: np.ndarray) -> np.ndarray:
        """Release these worlds' objects and record their grasps; returns those recorded (the others a fault)."""


class Stage:
    """One stage of the judging loop over the worlds it holds (see the module doc); a subclass overrides what it
    needs. A stage is made afresh for every run of the loop: it may keep per-world state (arrays of `run.n`).

    Args:
        run: the judging run it belongs to (`JudgingRun`: the worlds, the rules, the control period, and the
            measures every stage shares: `displacement`, `margin`, `hold_time`, `start`).
    """

    def __init__(self, run: JudgingRun):
        self.run = run

    def begin(self, worlds: np.ndarray) -> None:
        """The worlds that enter this stage now, before this period's physics.

        Args:
            worlds: their indices.
        """

    def step(self, worlds: np.ndarray) -> np.ndarray:
        """Before a period's physics: set up the period for the worlds this stage holds.

        Args:
            worlds: the indices of the worlds it holds (those that entered this period included).

        Returns:
            The worlds this stage has finished with (the next stage begins them in this period).
        """
        return worlds[:0]

    def done(self, worlds: np.ndarray, moved: np.ndarray) -> np.ndarray:
        """After a period's physics: the worlds whose judging ends here.

        Args:
            worlds: the indices of the worlds it holds.
            moved: (n,) m each object has moved from where it was grasped (inf: turned beyond `angle_limit`).

        Returns:
            The worlds judged now (their object left the bound).
        """
        return worlds[:0]


class Grasp(Stage):
    """The controller's grasp, until it is ready; then the support is released and the grasp recorded. Where the
    rules fade the release (`JudgingRules.release_seconds`), the support's spring weakens to nothing over that
    time first, the hand acting on, so that a load the spring carried is handed to the grasp gradually.

    Args:
        run: the judging run.
        ready: () -> (n,) bool, the worlds whose grasp is ready, asked once a period while a world grasps (None:
            every grasp is ready from the start).
    """

    def __init__(self, run: JudgingRun, ready: Callable[[], np.ndarray] | None = None):
        super().__init__(run)
        self.ready = ready
        self.cycles = run.rules.cycles(run.rules.release_seconds, run.period) if run.rules.release_seconds else 0
        self.fading = np.full(run.n, -1)  # control periods of the fading release done; -1: still grasping

    def step(self, worlds: np.ndarray) -> np.ndarray:
        grasping = worlds[self.fading[worlds] < 0]
        ready = grasping if self.ready is None else grasping[np.asarray(self.ready(), dtype=bool)[grasping]]
        if not self.cycles:
            return self.run.release(ready)
        self.fading[ready] = 0
        fading = worlds[self.fading[worlds] >= 0]
        self.fading[fading] += 1
        done = fading[self.fading[fading] > self.cycles]
        going = fading[self.fading[fading] <= self.cycles]
        left = 1.0 - self.fading[going] / (self.cycles + 1)
        self.run.worlds.soften(going, self.run.rules.support_stiffness * left, self.run.rules.support_damping * left)
        return self.run.release(done)


class HoldTest(Stage):
    """The hold test (see the module doc): `hold_seconds` of the disturbance per direction; a world whose object
    leaves the bound is judged at once (no later direction can change that), its `hold_time` where it stopped."""

    def __init__(self, run: JudgingRun):
        super().__init__(run)
        self.cycles = run.rules.cycles(run.rules.hold_seconds, run.period)
        self.direction = np.zeros(run.n, dtype=int)  # which of the directions each world is at
        self.count = np.zeros(run.n, dtype=int)  # control periods done in it
        self.saved: dict[int, np.ndarray] = {}  # the state each direction starts from (`JudgingRules.from_grasp`)

    def begin(self, worlds: np.ndarray) -> None:
        if self.run.rules.from_grasp:
            for world in worlds:
                self.saved[world] = self.run.worlds.save(world)
        self.direction[worlds], self.count[worlds] = 0, 0
        self.disturb(worlds)

    def step(self, worlds: np.ndarray) -> np.ndarray:
        turn = worlds[self.count[worlds] == self.cycles]
        self.direction[turn] += 1
        self.count[turn] = 0
        finished = self.direction[turn] == len(self.run.directions)
        turn, held = turn[~finished], turn[finished]
        for world in turn if self.run.rules.from_grasp else ():
            self.run.worlds.restore(world, self.saved[world])
        self.disturb(turn)
        return held

    def disturb(self, worlds: np.ndarray) -> None:
        """The disturbance of each world's direction: gravity along it, or a push with gravity off.

        Args:
            worlds: their indices.
        """
        run = self.run
        along = run.directions[self.direction[worlds]]
        if run.rules.push > 0:
            run.worlds.set_gravity(worlds, np.zeros((len(worlds), 3)))
            run.worlds.push(worlds, run.rules.push * along)
        else:
            run.worlds.set_gravity(worlds, GRAVITY * along)

    def done(self, worlds: np.ndarray, moved: np.ndarray) -> np.ndarray:
        run = self.run
        run.displacement[worlds] = np.maximum(run.displacement[worlds], moved[worlds])
        self.count[worlds] += 1
        dropped = worlds[run.displacement[worlds] > run.rules.hold_limit]
        run.hold_time[dropped] = run.rules.hold_seconds * self.direction[dropped] + run.period * self.count[dropped]
        return dropped


class MarginRamp(Stage):
    """The disturbance margin (see the module doc), where the rules ask for it (otherwise every world passes
    straight on): per direction a push that ramps from 0 to `margin_force` over `margin_seconds`, on top of
    gravity along it; a grasp never dropped keeps `margin_force` (censored)."""

    def __init__(self, run: JudgingRun):
        super().__init__(run)
        self.cycles = run.rules.cycles(run.rules.margin_seconds, run.period)
        self.direction = np.zeros(run.n, dtype=int)
        self.count = np.zeros(run.n, dtype=int)  # the ramp's k: the push is k / cycles of margin_force

    def begin(self, worlds: np.ndarray) -> None:
        if self.run.rules.margin:
            self.direction[worlds], self.count[worlds] = 0, 0
            self.run.margin[worlds] = self.run.rules.margin_force

    def step(self, worlds: np.ndarray) -> np.ndarray:
        run = self.run
        if not run.rules.margin:
            return worlds
        self.count[worlds] += 1
        turn = worlds[self.count[worlds] > self.cycles]
        self.direction[turn] += 1
        self.count[turn] = 1
        finished = turn[self.direction[turn] == len(run.directions)]
        for world in finished:
            run.worlds.push(np.array([world]), np.zeros((1, 3)))
        ramp = worlds[~np.isin(worlds, finished)]
        along = run.directions[self.direction[ramp]]
        run.worlds.set_gravity(ramp, GRAVITY * along)
        run.worlds.push(ramp, (run.rules.margin_force * self.count[ramp] / self.cycles)[:, None] * along)
        return finished

    def done(self, worlds: np.ndarray, moved: np.ndarray) -> np.ndarray:
        run = self.run
        dropped = worlds[moved[worlds] > run.rules.hold_limit]
        for world in dropped:
            run.margin[world] = run.rules.margin_force * (self.count[world] - 1) / self.cycles
            run.worlds.push(np.array([world]), np.zeros((1, 3)))
        return dropped


class Lift(Stage):
    """The lift of the field's closed-loop protocol (issue 66): gravity on (world -z), the arm raises the palm
    `height` m straight up at `speed` m/s (bounded by its flange's speed) and keeps it there for `hold_seconds`. A
    protocol names it with its settings, `LiftStage(height, speed)`.
    The displacement is how far the object stayed below the palm's rise, at its largest; the grasp holds when that is
    within `hold_limit` (the field's: a 0.2 m lift, held when the object rose at least 0.1 m), and a world is judged
    in the period its object falls further behind. Needs worlds whose hands hang on a flange (`sim.flange`)."""

    #: the stage moves the palm: the trial's scenes need a flange (`JudgingRules.needs_flange`)
    needs_flange = True

    def __init__(self, run: JudgingRun, height: float = 0.2, speed: float = 0.1):
        super().__init__(run)
        self.height = height
        self.rising = run.rules.cycles(height / speed, run.period)
        self.cycles = self.rising + run.rules.cycles(run.rules.hold_seconds, run.period)
        self.count = np.zeros(run.n, dtype=int)  # control periods done
        self.up = np.zeros((run.n, 3))  # the world's up in the flange's slide coordinates
        self.home = np.zeros((run.n, 6))  # the flange where the lift began

    def begin(self, worlds: np.ndarray) -> None:
        run = self.run
        self.count[worlds] = 0
        run.hold_time[worlds] = self.cycles * run.period
        run.worlds.set_gravity(worlds, np.tile([0.0, 0.0, -GRAVITY], (len(worlds), 1)))
        self.up[worlds] = run.worlds.flange_axes(worlds)[:, :, 2]  # row i: slide i's direction; column 2: its rise
        self.home[worlds] = run.worlds.flanges(worlds)

    def step(self, worlds: np.ndarray) -> np.ndarray:
        run = self.run
        rise = self.height * np.minimum(self.count[worlds] + 1, self.rising) / self.rising
        targets = self.home[worlds].copy()
        targets[:, :3] += rise[:, None] * self.up[worlds]
        run.worlds.steer_flanges(worlds, targets, run.period)
        return worlds[self.count[worlds] >= self.cycles]

    def done(self, worlds: np.ndarray, moved: np.ndarray) -> np.ndarray:
        run = self.run
        self.count[worlds] += 1
        palm_rise = np.sum((run.worlds.flanges(worlds)[:, :3] - self.home[worlds, :3]) * self.up[worlds], axis=1)
        lag = palm_rise - (run.worlds.object_positions()[worlds, 2] - run.start[worlds, 2])
        run.displacement[worlds] = np.maximum(run.displacement[worlds], lag)
        dropped = worlds[run.displacement[worlds] > run.rules.hold_limit]
        run.hold_time[dropped] = run.period * self.count[dropped]
        return dropped



@dataclass(frozen=True)
class LiftStage:
    """The lift with its settings, as `JudgingRules.stages` names it: the stage's own settings live on the stage,
    not on the rules (`JudgingRules.lift_height` and `lift_speed` before 0.3).

    Attributes:
        height: m the `Lift` raises the palm.
        speed: m/s it raises it at (the flange's `FlangeLimits.speed` bounds it).
    """

    height: float = 0.2
    speed: float = 0.1
    #: the stage moves the palm: the trial's scenes need a flange (`JudgingRules.needs_flange`)
    needs_flange: ClassVar[bool] = True

    def __post_init__(self) -> None:
        check_fields(self, {"height": Bounds(0.0, 2.0, above_low=True, unit="m"),
                            "speed": Bounds(0.0, 10.0, above_low=True, unit="m/s")})

    def __call__(self, run: JudgingRun) -> Lift:
        """The stage for a judging run.

        Args:
            run: the judging's worlds and rules.

        Returns:
            The `Lift`.
        """
        return Lift(run, self.height, self.speed)

HOLD_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
#: the same directions as a tuple of tuples, for the frozen rules that hold them
SIX_DIRECTIONS: tuple[tuple[float, float, float], ...] = tuple(map(tuple, HOLD_DIRECTIONS.tolist()))
#: the ranges of `JudgingRules`' numbers (a NaN stiffness or a negative hold ran to a normal-looking result)
JUDGING_BOUNDS = {"hold_seconds": Bounds(0.0, 60.0, above_low=True, unit="s"),
                  "hold_limit": Bounds(0.0, 1.0, above_low=True, unit="m"),
                  "margin_force": Bounds(0.0, 1000.0, unit="N"),
                  "margin_seconds": Bounds(0.0, 60.0, above_low=True, unit="s"),
                  "epsilon_threshold": Bounds(0.0, 1.0),
                  "support_stiffness": Bounds(0.0, 1e6, unit="N/m"),
                  "support_damping": Bounds(0.0, 1e5, unit="N s/m"),
                  "push": Bounds(0.0, 1000.0, unit="N"),
                  "angle_limit": Bounds(0.0, 2 * math.pi, above_low=True, infinite=True, unit="rad"),
                  "release_seconds": Bounds(0.0, 60.0, unit="s")}


@dataclass(frozen=True)
class JudgingRules:
    """How every grasp is judged (see `judge`'s module doc), in one place: `episode_loop` reads it for the
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
        release_seconds: s over which the support fades to nothing once a grasp is ready, the hand acting on, before
            it is released and recorded (0, ours: released at once; the planned-grasp benchmark fades it).
        directions: the disturbance's unit directions, in turn (ours: +x, -x, +y, -y, +z, -z; `HOLD_DIRECTIONS`).
        stages: the judging's stages after the grasp, in turn: each a `stages.Stage` class (or a callable that
            makes one of a `Judging`, with its own settings: `LiftStage(height, speed)`); one's own runs without a
            change to the loop.
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
    release_seconds: float = 0.0
    directions: tuple[tuple[float, float, float], ...] = SIX_DIRECTIONS
    stages: tuple[Callable[[JudgingRun], Stage], ...] = (HoldTest, MarginRamp)

    def __post_init__(self) -> None:
        check_fields(self, JUDGING_BOUNDS, flags=("margin", "from_grasp"))
        object.__setattr__(self, "directions", check_directions(self.directions, "JudgingRules.directions"))
        if not isinstance(self.physics, str):
            raise InvalidInput(f"JudgingRules.physics must be a profile's name (a string), got {self.physics!r}")
        if not isinstance(self.stages, tuple) or not self.stages or not all(callable(s) for s in self.stages):
            raise InvalidInput(f"JudgingRules.stages must be a non-empty tuple of Stage classes (or callables that make "
                               f"one of a run): a judging with no stage tests nothing, got {self.stages!r}")

    @property
    def needs_flange(self) -> bool:
        """Whether a stage moves the palm (`Lift`): the scenes judged need a hand on a flange."""
        return any(getattr(stage, "needs_flange", False) for stage in self.stages)

    @property
    def lift(self) -> LiftStage | None:
        """The lift among the stages, with its settings (None: the rules lift nothing)."""
        return next((stage for stage in self.stages if isinstance(stage, LiftStage)), None)

    @staticmethod
    def cycles(seconds: float, period: float) -> int:
        """Control cycles of `period` s in `seconds` (at least one)."""
        return max(1, round(seconds / period))
