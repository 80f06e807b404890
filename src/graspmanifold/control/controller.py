"""The four-phase tactile grasp controller (paper Section 2, Fig. 2), one array program over N worlds.

Each control cycle the controller receives, for every world, the 22 joint angles and the normal force
on each tactile segment (what a tactile skin reports), and returns the 22 joint targets. It never
sees the object. `BatchController` is the one implementation (the trials run it); `GraspController`
is the same controller for one world, driven one posture at a time.

    A  preshape: actuate the open posture;
    B  close until the first contact, "in an already experience-influenced process": nothing touches
       yet, so every cycle the whole sensed posture is matched against the experience;
    C  once anything touches: every cycle the Partial Contact Posture (Eq. 1) is matched with the
       masked search (Eq. 2 / Eq. 4);
    D  embedded in B and C, the generic closing heuristic: a free finger's closure c grows at
       `closing_rate` per second, its goal is goal = base + c (closed - base), and its target follows
       the goal at most `follow_speed` times the heuristic's joint speed; without experience the base
       is the open hand and c grows from the start of B (the plain heuristic). A touching finger holds
       where it touched and squeezes (`squeeze`, flexion joints; with `squeeze_time`, only once the grasp has
       settled, every touching finger at once, ramped over that time); one that loses its contact for
       `release_time` closes on from where it held. With a `grip_force` (N) the press is regulated to it from the
       segment forces sensed, while the grasp goes on and once it is done: an integral law on the press, bounded
       to [0, `grip_press`] rad (`BOUNDED_APPROACH`). The grasp ends when the touching fingers have
       not changed for `stable_time` and every finger touches or is fully closed, or at `timeout`.

What a best match does is a `RecallRule`, a value of `ControllerParams.recall` (ours by name, `RECALL_RULES`, or
one of one's own); ours:

- `"target"` (`TargetRecall`), the paper's reading ("the resulting posture then acts as the target posture for the
  current control cycle", Section 2): each steered free finger moves to its part of the recalled
  posture at the heuristic's joint speed, and only once it is there (its joints within
  `tolerance`, or at rest short of it without a contact) does phase D close it on, from the
  recall, its closure from 0. Where the paper leaves a detail open we chose the plainest reading: phase
  B matches the whole posture; a finger goes to each recalled posture once (one it reached, or touched
  the object on its way to, does not call it back, so two alternating matches cannot hold it between
  them); a finger that loses its contact closes on from where it held; every match is trusted. A
  `reproduce` report lists these under "Our choices".
- `"base"` (`BlendRecall`), our earlier blend (`BLEND`): the recall is the heuristic's base, goal = match + c (closed -
  match), with c grown since phase B began, so at the first contact the recall only shifts a goal far
  towards the closed hand. Two extensions work with it: `restart_closure` (the first trusted match
  after a contact restarts the free fingers' closure at 0) and `reach` (that match also moves the palm,
  by the arm, by the mean difference between where the touching segments are and where the recalled
  grasp puts them, `hand.SegmentKinematics`, at most `reach` at `reach_speed`, every finger following the
  recall meanwhile; `palm_offset` is where the palm is, palm frame).
- `"approach"` (`ApproachRecall`, `APPROACH`, issue 65): the paper's reading executed as a verified grasp is:
  the fingers that set out for a recall together arrive together (`GraspState.pace`); one that arrives untouched
  closes on along its way (from the attempt's starting posture to the recall, `GraspState.way`, up to `overshoot`
  ways beyond: `GraspState.aim`), not towards the closed fist; a touching finger presses `squeeze` on along that
  way (`RecallRule.pressed`) instead of along its flexion. Without a recall it is the paper's controller.

Where an arm carries the hand (a flange: `TrialSetup.palm`), `ControllerParams.palm` (`PalmSteering`, issue 66) gives
the palm phases of its own beside the fingers', whatever the recall rule: a guarded approach along the palm's normal
until the first contact, re-centring in the palm's plane on the touch while the grasp settles (on the palm's grasp
centre, or on where the recalled grasp had the object), still for the squeeze.

Beyond the paper, a controller with a `regrasp.Regrasp` of more than one attempt is probed once its grasp
is done (the trials lift it: gravity on, touch watched); a failing grasp is opened and grasped again from
where the object lies (`restart`: phase A opens the hand whatever touches, then B, C and D as before), with
the next preshape chosen from what the failed attempt sensed.

Ablations switch parts off (`experience_preshape`, `experience_steering`, `steered_fingers`,
`steered_joints`, `max_match_distance`: see `ControllerParams`). The controller drives the hand it is
given (`HandModel`): its open and closed postures, its ranges, its kinematics. Any object with the
members of `Controller` can stand in for it in the trials (`conformance.check_controller_contract`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import Protocol, runtime_checkable

import numpy as np

from ..base.errors import InvalidInput
from ..base.moved import moved_attribute
from ..base.validation import Bounds, check_choice, check_fields
from ..manifold.experience import Experience, check_experience
from ..sim.grip import CONTROL_PERIOD, FLEXION, SQUEEZE
from ..sim.hand import (
    FINGERS,
    N_FINGER_JOINTS,
    PHYSICS_TIMESTEP,
    SEGMENTS,
    SHADOW_HAND,
    HandModel,
    SegmentKinematics,
)
from ..sim.posture import SEGMENT_FINGER, pcp_masks, validate_posture
from ..sim.scene import GRASP_CENTRE_IN_PALM
from .recall import RECALL_RULES, ApproachRecall, RecallRule, TargetRecall
from .regrasp import Regrasp
from .state import FINGER_JOINT_MASKS, FINGER_SEGMENT_MASKS, JOINT_FINGER, GraspState, bounded_step, per_finger

#: which joints of a steered finger take the matched posture: all, or only the spread joints (finger
#: abduction, little-finger cupping, thumb rotation, abduction and roll); flexion is then left to the
#: closing heuristic, which stops at the contact
STEERED_JOINTS = {"all": np.ones(N_FINGER_JOINTS, dtype=bool), "spread": ~FLEXION}
#: the grasp phase of each world, as `GraspController.phase` names it
PHASES: tuple[str, ...] = ("A", "B", "C", "done")


#: the ranges of `ControllerParams`' numbers: the largest values still describe a controller (a closing rate of
#: 1e300 was taken)
CONTROLLER_BOUNDS = {"control_period": Bounds(0.0, 1.0, above_low=True, unit="s"),
                     "preshape_time": Bounds(0.0, 60.0, unit="s"),
                     "closing_rate": Bounds(0.0, 50.0, above_low=True, unit="closures/s (50: the hand closes in 20 ms)"),
                     "follow_speed": Bounds(0.0, 100.0, above_low=True),
                     "squeeze": Bounds(0.0, 1.0, unit="rad"),
                     "release_time": Bounds(0.0, 60.0, unit="s"),
                     "stable_time": Bounds(0.0, 60.0, unit="s"),
                     "timeout": Bounds(0.0, 60.0, above_low=True, unit="s"),
                     "squeeze_time": Bounds(0.0, 60.0, unit="s"),
                     "max_match_distance": Bounds(0.0, 1e3, above_low=True, infinite=True, unit="rad"),
                     "grip_force": Bounds(0.0, 1e4, above_low=True, infinite=True, unit="N"),
                     "grip_gain": Bounds(0.0, 50.0, above_low=True, unit="rad/s"),
                     "grip_press": Bounds(0.0, 1.0, unit="rad")}


@dataclass(frozen=True)
class PalmSteering:
    """The palm follows touch (issue 66): where an arm carries the hand (`TrialSetup.palm`: a flange), the controller
    moves the palm in phases of its own beside the fingers', whatever its recall rule:

    - the guarded approach (phase B, nothing touching yet): the palm advances along its normal towards the object
      (the palm's -y) at `approach_speed`, at most `approach`, and stops at the first contact;
    - re-centring (phase C, until the grasp settles): the palm moves in its plane (x, z) so that the object comes
      where the palm wants it: touch alone takes the force-weighted centre of the touching finger segments (where
      the hand's own kinematics puts them for the sensed joints: `hand.SegmentKinematics`) for the object and
      wants it at the palm's grasp centre (`scene.GRASP_CENTRE_IN_PALM`); with `recalled_place` the object sits off
      those segments as it sat off the same segments of the last recalled grasp (the experience's `places`,
      issue 66) and is wanted where that grasp had it (touch alone where the experience does not know places);
      measured at the contact and again whenever the touching set changes (`BatchController.object_estimate`), at
      `speed`, at most `reach` from where the trial put it;
    - locked for the squeeze: once every finger touches or is fully closed, the palm stays where it is.

    The default moves nothing (the palm stays where the trial put it, the paper's).

    Attributes:
        approach: m, the guarded approach's longest travel (0: none).
        approach_speed: m/s.
        reach: m, the longest re-centring in the palm's plane (0: none).
        speed: m/s of the re-centring.
        recalled_place: re-centre on where the recalled grasp had the object (experience) instead of on the palm's
            grasp centre (touch alone).
    """

    approach: float = 0.0
    approach_speed: float = 0.05
    reach: float = 0.0
    speed: float = 0.05
    recalled_place: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.recalled_place, bool):
            raise InvalidInput(f"PalmSteering.recalled_place must be True or False, got {self.recalled_place!r}")
        check_fields(self, {"approach": Bounds(0.0, 0.1, unit="m"), "reach": Bounds(0.0, 0.1, unit="m"),
                            "approach_speed": Bounds(0.0, 1.0, above_low=True, unit="m/s"),
                            "speed": Bounds(0.0, 1.0, above_low=True, unit="m/s")})

    @property
    def active(self) -> bool:
        """Whether it moves the palm at all."""
        return self.approach > 0 or self.reach > 0


#: the palm of the fingers-only controller: it stays where the trial put it
STILL_PALM = PalmSteering()
#: the palm follows touch (the palm study's values): a guarded approach of at most 2 cm along the palm normal, then
#: re-centring within 3 cm in the palm's plane at 5 cm/s; chosen on probes of generator seed 0 (the selection split,
#: 3 plans per object at 2-5 cm, 497 trials: approach 0, 1 or 2 cm; reach 1.5, 3 or 5 cm; 5 or 10 cm/s)
PALM_TOUCH = PalmSteering(approach=0.02, reach=0.03)
#: the same phases steered by where the recalled grasp had the object (the experience's places)
PALM_EXPERIENCE = replace(PALM_TOUCH, recalled_place=True)
#: the palm steerings by name (the CLI's `--palm-steering`)
PALM_STEERINGS: dict[str, PalmSteering] = {"still": STILL_PALM, "touch": PALM_TOUCH, "experience": PALM_EXPERIENCE}


#: the flat settings of a controller table before the recall rule was a value, and their names in the rule's
_FLAT_RECALL_SETTINGS = {"recall_tolerance": "tolerance", "recall_closes_only": "closes_only",
                         "restart_closure": "restart_closure", "reach": "reach", "reach_speed": "reach_speed"}


@dataclass(frozen=True)
class ControllerParams:
    """Timing, gains and switches of the controller (s, rad, rad/s); the defaults are the paper's reading
    (`TargetRecall`, every match trusted), `BLEND` our earlier variant. `recall` is what a best match does: a
    `RecallRule` value (`TargetRecall(...)`, `BlendRecall(...)` or one's own), or the name of one of ours
    (`RECALL_RULES`: 'target', 'base') with its defaults."""

    control_period: float = CONTROL_PERIOD  # 50 Hz
    preshape_time: float = 0.3  # phase A
    closing_rate: float = 0.8  # closure per second of a free finger (1 = fully closed)
    follow_speed: float = 2.0  # a closing finger's target moves at most this many times the heuristic's speed
    squeeze: float = SQUEEZE  # rad beyond the touching posture, on the flexion joints
    release_time: float = 0.1  # a holding finger that lost its contact this long closes on
    stable_time: float = 0.3  # the touching set must stay unchanged this long to finish
    timeout: float = 3.0  # s after the start
    squeeze_time: float = 0.0  # s; 0: a finger squeezes once it touches; > 0: all squeeze together once settled
    experience_preshape: bool = True  # phase B: match the whole posture every cycle
    experience_steering: bool = True  # phase C: match the Partial Contact Posture every cycle
    steered_fingers: tuple[str, ...] = FINGERS  # fingers whose recall the experience sets
    steered_joints: str = "all"  # 'all', or 'spread': only the joints that do not flex the finger (flexion: D's)
    max_match_distance: float = math.inf  # rad, RMS over the matched joints; farther matches are ignored (inf: none)
    grip_force: float = math.inf  # N, total normal force the holding fingers' press is regulated to (inf: off)
    grip_gain: float = 1.0  # rad/s the press changes at per unit of relative grip-force error
    grip_press: float = 0.6  # rad, the most the grip regulation presses (and 0 the least)
    recall: RecallRule = field(default_factory=lambda: TargetRecall())  # what a best match does (module doc)
    palm: PalmSteering = STILL_PALM  # the palm's own phases where an arm carries the hand (issue 66)

    def __post_init__(self) -> None:
        if isinstance(self.recall, str):
            object.__setattr__(self, "recall", RECALL_RULES[check_choice(self.recall, tuple(RECALL_RULES),
                                                                         "ControllerParams.recall")]())
        if not isinstance(self.recall, RecallRule):
            raise InvalidInput(f"ControllerParams.recall must be a RecallRule or one of {tuple(RECALL_RULES)}, got "
                               f"{self.recall!r}")
        check_fields(self, CONTROLLER_BOUNDS, flags=("experience_preshape", "experience_steering"))
        steps = self.control_period / PHYSICS_TIMESTEP
        if isinstance(self.control_period, bool) or round(steps) < 1 or abs(steps - round(steps)) > 1e-6:
            raise InvalidInput(f"ControllerParams.control_period must be a whole number of {PHYSICS_TIMESTEP} s physics "
                               f"steps (0.002, 0.004, ..., 0.02), got {self.control_period!r}: another period would "
                               "make the controller's clock run apart from the physics")
        check_choice(self.steered_joints, STEERED_JOINTS, "ControllerParams.steered_joints")
        if not isinstance(self.palm, PalmSteering):
            raise InvalidInput(f"ControllerParams.palm must be a PalmSteering, got {self.palm!r}")
        if self.palm.active and self.recall.moves_palm:
            raise InvalidInput("ControllerParams.palm steers the palm from touch and the recall rule moves it too "
                               f"({self.recall.name}'s reach): one of them moves it, not both")
        self.recall.check(self)
        unknown = [f for f in self.steered_fingers if f not in FINGERS]
        if unknown:
            raise InvalidInput(f"ControllerParams.steered_fingers has unknown fingers {unknown}; expected some of {FINGERS}")

    def to_table(self) -> dict:
        """The parameters as a table (TOML, run.json, the trials' key): every field, the recall rule as a table of
        its own with its name under 'rule', the palm's steering as one where it moves the palm (a still palm is left
        out, so that the keys of trials made before it stay)."""
        table = {f.name: getattr(self, f.name) for f in fields(self)}
        table["recall"] = self.recall.to_table()
        if self.palm.active:
            table["palm"] = {f.name: getattr(self.palm, f.name) for f in fields(self.palm)}
        else:
            del table["palm"]
        return table

    @staticmethod
    def upgrade_table(table: dict) -> dict:
        """A controller table of a run.json or TOML file written before the recall rule was a value (its settings
        flat: `recall = "base"`, `reach = 0.03`, ...), in today's form; today's is returned as it is.

        Args:
            table: the table.

        Returns:
            The table with `recall` a rule's table.
        """
        flat = {old: new for old, new in _FLAT_RECALL_SETTINGS.items() if old in table}
        if not flat and not isinstance(table.get("recall"), str):
            return table
        table = dict(table)
        rule = {"rule": table.pop("recall", "target")}
        for old, new in flat.items():
            value = table.pop(old)
            if new in {f.name for f in fields(RECALL_RULES.get(rule["rule"], TargetRecall))}:
                rule[new] = value
        table["recall"] = rule
        return table


BLEND = ControllerParams(recall=RECALL_RULES["base"](), max_match_distance=0.2)
"""Our earlier reading of phase C, a named variant: the recall is the closing heuristic's base; matches trusted
within 0.2 rad RMS (of 0.1, 0.2 and none on the paper grid: docs/studies/experience_study_paper_grids.md)."""

CLOSING_RECALL = ControllerParams(recall=TargetRecall(closes_only=True))
"""The paper's reading ("the resulting posture then acts as the target posture for the current control cycle") with
one detail it leaves open read the other way: a recall moves each joint of a free finger only towards the closed
hand, never back towards the open one (each joint's recall kept no more open than its target). The literal reading
(the default) lets a recall open a finger; traced, that is how it loses the pen near the palm
(`scripts/trace_literal_controller.py`)."""

SETTLED_BLEND = replace(BLEND, squeeze_time=0.2, squeeze=0.3, max_match_distance=math.inf)
"""The blend with the execution of the planned-grasp benchmark (`trials.planned`): a touching finger holds where it
touched, without pressing, until the grasp has settled; then every touching finger squeezes together, ramped over
0.2 s, twice as far (0.3 rad); every match is trusted (a plan's own posture lies 0.5-1 rad RMS from its pregrasp, so
the blend's 0.2 rad trust never recalled it there). Chosen on a probe (16 verified grasps each of the box, cylinder
and pen, generator seed 0, a perfect recall from the plan's pregrasp, judged by `protocols.HOLD_TEST_FADED`): the blend's
immediate squeeze let the first fingers push the object 6-11 mm against the support before the others arrived (the
open loop: 2-3 mm); scored on the other seeds' plans (docs/studies/planned_grasps.md)."""

APPROACH = ControllerParams(recall=ApproachRecall(), squeeze=0.3)
"""The paper's reading with the execution of a verified grasp (`ApproachRecall`): a finger goes to its recall, closes
on along the way it came (the fingers that set out at once arriving at once), and presses on along it by 0.3 rad
once it touches; every match trusted. Traced on generator seed 1's first 10 plans of the marble, pen and disc (a
perfect recall from the plan's pregrasp, judged by `protocols.HOLD_TEST_FADED`): the blend's fingers passed the recalled
posture already part way to the fist and swept past a small object; the paper's reading reached it but closed on
towards the fist, and its flexion squeeze of a fingertip pushed a marble out (pressing along the plan's own squeeze
instead: 22 of 30 held, the open loop 23). Chosen on seed 0 (12 plans of each of the seven benchmark objects): 61 of
84 held, the open loop 71, the settled blend (`SETTLED_BLEND`) 46; without arriving together 56; pressing 0.4 rad
57; a release time of 0.3 s 60; half the overshoot 60. The way is measured from the attempt's starting posture:
measured from where a finger was when a recall came, the whole map's recalls from the open hand left fingers ways
too short to close on along (the experience study's selection split, box and marble, every third pose, a map of 7
postures per object: 4 of 32 held against the paper's reading's 9; from the start, 18). Scored on seeds 2-4
(docs/studies/planned_grasps.md) and on the experience study's test split."""

BOUNDED_APPROACH = replace(APPROACH, grip_force=15.0, grip_press=APPROACH.squeeze)
"""The approach execution with its total grip force bounded (issue 65, "a bounded total grip force regulated from the
segment forces"): the press of the holding fingers eases off while the segment forces sum to more than 15 N, and
comes back up to the approach's 0.3 rad below it, while the grasp goes on and once it is done (`ControllerParams.
grip_force`). Chosen on generator seed 0 (12 plans of each of the seven benchmark objects, a perfect recall at 0 cm,
`protocols.HOLD_TEST_FADED`; the approach without a bound held 61 of 84): a bound of 15 N held 63, 8 N 56, 30 N 61; a
press allowed up to 0.45 rad 58 (15 N) and 57 (25 N), up to 0.6 rad 58 (15 N) and 57 (30 N); regulated only once
the grasp was done, up to 0.6 rad, 56 (10 N), 60 (20 N), 59 (40 N), and with the press kept at most the squeeze
61 (no change). More press held every box plan and lost pens, discs and marbles: the summed normal force does not
tell an object that needs a firmer grip from one a firmer grip pushes out. Scored on seeds 2-4
(docs/studies/planned_grasps.md)."""

CONTROLLERS: dict[str, ControllerParams] = {"paper": ControllerParams(), "blend": BLEND,
                                            "closing-recall": CLOSING_RECALL, "blend-settled": SETTLED_BLEND,
                                            "approach": APPROACH, "approach-bounded": BOUNDED_APPROACH}
"""The controllers by name (`graspmanifold reproduce --controller NAME`): the paper's reading, the blend, the
paper's reading with recalls that only close, the blend with the settled squeeze, the paper's reading executed
as a verified grasp is (`APPROACH`), and that with its total grip force bounded (`BOUNDED_APPROACH`)."""


@runtime_checkable
class Controller(Protocol):
    """What a trial drives, N worlds at once: `BatchController`, or a user's own (for `evaluate(controller=...)`,
    the benchmark and the study; the API reference shows one in 20 lines). Beyond the control step the trials read
    only what a controller declares in an attribute `readouts` (names of `READOUTS`; none without it), checked
    once when it is made (`declared_readouts`).

    Attributes:
        n: worlds.
        control_period: s between two `step` calls (a whole number of physics steps).
        initial: the posture (22,), rad, the hand starts a grasp in.
        done: (N,) bool: which worlds' grasps are finished (the trial then judges them).
    """

    n: int
    initial: np.ndarray
    done: np.ndarray

    @property
    def control_period(self) -> float:
        """s between two `step` calls (an attribute or a read-only property)."""

    def reset(self) -> None:
        """Start a new grasp in every world."""

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One cycle: sensed joints (N, 22), rad, and segment forces (N, len(SEGMENTS)), N -> targets (N, 22), rad."""


ControllerFactory = Callable[[int, HandModel], Controller]  # `factory(n, hand)`: what `evaluate(controller=...)` takes

#: what the trial loop may read from a controller beyond its control step, by name: the member and what it is. A
#: controller declares those it has in an attribute `readouts`; the trials record a default for the others
READOUTS: dict[str, str] = {
    "matches": "(N,) int: the experience queries each world's controller has made (default 0)",
    "winners": "N lists of int: per world, the row of the experience each query recalled, in order (default none)",
    "attempt": "(N,) int: each world's grasp attempt, 1 the first (default 1; needed for more than one attempt)",
    "palm_offset": "(N, 3) m, with `moves_palm` (bool): where the arm carries each palm while `moves_palm` is true",
    "object_estimate": "(N, 3) m: where touch first placed the object, NaN where it has not (default NaN)",
}


def declared_readouts(controller: Controller) -> frozenset[str]:
    """The read-outs a controller declares (`READOUTS`), checked: each a member of the documented shape.

    Args:
        controller: a controller just made (its n worlds).

    Returns:
        The names it declares (none for a controller without `readouts`).

    Raises:
        InvalidInput: an unknown name, or a declared member that is missing or of another shape.
    """
    declared = getattr(controller, "readouts", ())  # the one read of an optional member: the declaration
    if isinstance(declared, str) or not all(isinstance(name, str) for name in declared):
        raise InvalidInput(f"{type(controller).__name__}.readouts must be a tuple of names of READOUTS, got {declared!r}")
    unknown = sorted(set(declared) - set(READOUTS))
    if unknown:
        raise InvalidInput(f"{type(controller).__name__}.readouts names {unknown}, which the trials do not read; "
                           f"they read {sorted(READOUTS)}")
    n = controller.n
    shapes = {"matches": (n,), "attempt": (n,), "palm_offset": (n, 3), "object_estimate": (n, 3)}
    for name in declared:
        if not hasattr(controller, name):
            raise InvalidInput(f"{type(controller).__name__} declares the read-out {name!r} but has no such member")
        value = getattr(controller, name)
        if name == "winners" and len(value) != n or name in shapes and np.shape(value) != shapes[name]:
            raise InvalidInput(f"{type(controller).__name__}.{name} must be {READOUTS[name].split(':')[0]} for its "
                               f"{n} worlds, got shape {np.shape(value) if name in shapes else len(value)}")
    if "palm_offset" in declared and not isinstance(getattr(controller, "moves_palm", None), bool):
        raise InvalidInput(f"{type(controller).__name__} declares palm_offset: it needs a bool `moves_palm` beside it")
    return frozenset(declared)


def _rms(differences: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """RMS of every row over its masked columns, as `np.mean` of that row's masked entries alone sums them."""
    rms = np.empty(len(differences))
    patterns, which = np.unique(masks, axis=0, return_inverse=True)
    for k, pattern in enumerate(patterns):
        rows = which.ravel() == k
        rms[rows] = np.sqrt(np.mean(differences[rows][:, pattern] ** 2, axis=1))
    return rms


class BatchController:
    """The tactile grasp controller for N worlds (see the module doc); call `step` once per control
    period with every world's readings. The worlds share the clock; a world that is done keeps its target.

    Attributes:
        closed, limits, speed: the hand's closed posture (22,) and ranges (22, 2), rad, and each finger's
            joint speed (5,), rad/s: the open-to-closed synergy at `closing_rate`.
        steered_joint_mask, steered_finger_mask: (22,) and (5,) bool, the joints and fingers a best match may set
            (`ControllerParams.steered_fingers` and `steered_joints`); the recall rules read them.
        kinematics: the hand's `SegmentKinematics` where the recall rule or the palm steering moves the palm, else
            None.
        state: the `GraspState`, every world's arrays (what a recall rule changes).
        time: s since the grasp started; phase: (N,) index into `PHASES`; done: (N,) bool; time_to_grasp:
            (N,) s (NaN while not done); matches: (N,) best-match queries used; winners: per world, the best
            match of every query used (rows of `experience.references`), in order; palm_offset: (N, 3), m,
            palm frame: how far each palm has moved (`reach`); object_estimate: (N, 3), m, where touch last placed
            the object when the palm re-centred (`PalmSteering`), in the palm frame the grasp started with (NaN:
            nowhere yet).
    """

    #: what the trials read of it beyond the control step (`READOUTS`)
    readouts = ("matches", "winners", "attempt", "palm_offset", "object_estimate")

    def __init__(self, n: int, experience: Experience | None = None, params: ControllerParams | None = None,
                 initial_posture: np.ndarray | None = None, preshape: np.ndarray | None = None,
                 hand: HandModel = SHADOW_HAND, regrasp: Regrasp | None = None):
        """A controller ready for the first grasp in every world.

        Args:
            n: worlds.
            experience: None (the plain tactile controller), a PostureDatabase, a SOM, a PostureSet or any `Experience`.
            params: timing, gains and switches (`ControllerParams`).
            initial_posture: the open hand it starts from (22,), rad (default the hand's keyframe `open`).
            preshape: a fixed phase-B posture, rad, instead of matching the experience there (phase C still
                recalls); with recall='target' the hand goes to it and closes on from it, with 'base' it is the base.
            hand: the hand model it drives (its closed posture, joint ranges and kinematics).
            regrasp: its attempts and how it chooses the next one after a failed lift probe (`regrasp.Regrasp`;
                None: one attempt, the paper's).
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidInput(f"n (worlds) must be a positive integer, got {n!r}")
        if not isinstance(hand, HandModel):
            raise InvalidInput(f"hand must be a HandModel (hand_models.hand_model(name) makes one), got {hand!r}")
        self.n = int(n)
        self.experience = check_experience(experience)
        self.params = params or ControllerParams()
        self.hand = hand
        self.initial = validate_posture(hand.keyframe_posture("open") if initial_posture is None else initial_posture,
                                        name="initial_posture", check_limits=True, hand=hand)
        self.preshape = None if preshape is None else validate_posture(preshape, name="preshape", check_limits=True,
                                                                       hand=hand)
        self.regrasp = regrasp or Regrasp()
        if self.regrasp.grasp_types is not None and self.experience is None:
            raise InvalidInput("Regrasp.grasp_types recalls the next grasp from the experience: give an experience")
        self.closed, self.limits = hand.keyframe_posture("closed"), hand.limits()
        self.speed = self.params.closing_rate * np.array([np.linalg.norm((self.closed - self.initial)[of])
                                                          for of in FINGER_JOINT_MASKS])
        self.steered_finger_mask = np.isin(np.array(FINGERS), self.params.steered_fingers)
        self.steered_joint_mask = self.steered_finger_mask[JOINT_FINGER] & STEERED_JOINTS[self.params.steered_joints]
        self.kinematics = SegmentKinematics(hand) if self.params.recall.moves_palm or self.params.palm.active else None
        #: the recall keys one world's fingers can have (a row of the references, or the preshape)
        self._rows = 1 + (0 if self.experience is None else len(self.experience.references))
        self.reset()

    @property
    def control_period(self) -> float:
        """s between two `step` calls (`params.control_period`)."""
        return self.params.control_period

    @property
    def squeeze(self) -> float:
        """rad, how far the holding fingers press when nothing regulates the press (`params.squeeze`): a recalled
        squeeze is pressed in full at this amount (`recall.ApproachRecall.pressed`)."""
        return self.params.squeeze

    @property
    def moves_palm(self) -> bool:
        """Whether the trials must carry each palm to `palm_offset` (its recall rule moves palms: `reach` > 0; or its
        palm follows touch: `ControllerParams.palm`)."""
        return self.params.recall.moves_palm or self.params.palm.active

    def reset(self) -> None:
        """Start a new grasp in every world."""
        n = self.n
        self.time = 0.0
        self.phase = np.zeros(n, dtype=np.int8)
        self.done = np.zeros(n, dtype=bool)
        self.time_to_grasp = np.full(n, np.nan)
        self.matches = np.zeros(n, dtype=int)
        self.winners: list[list[int]] = [[] for _ in range(n)]
        self.palm_offset = np.zeros((n, 3))
        self.object_estimate = np.full((n, 3), np.nan)
        self.attempt = np.ones(n, dtype=int)  # each world's attempt, 1 the first
        self.state = GraspState.new(n, self.initial, self.closed, self.speed, self.preshape, self._rows)
        self.state.grip[:] = self.params.squeeze

    def restart(self, worlds: np.ndarray, joints: np.ndarray, segment_forces: np.ndarray) -> None:
        """The next attempt in these worlds, whose grasp failed its lift probe (`regrasp`): the hand opens
        (phase A) and closes again, from where the object lies, with the preshape `Regrasp.next_preshapes`
        chooses from what the failed attempt sensed last. Their best matches so far stay in `matches` / `winners`.

        Args:
            worlds: the worlds' indices (m,).
            joints: (m, 22) rad, their joints sensed last.
            segment_forces: (m, len(SEGMENTS)) N, their segment forces sensed last.
        """
        worlds = np.asarray(worlds, dtype=int)
        if np.any(self.attempt[worlds] >= self.regrasp.attempts):
            raise InvalidInput(f"restart: every world has {self.regrasp.attempts} attempts at most (Regrasp.attempts)")
        joints, forces = np.asarray(joints, dtype=float), np.asarray(segment_forces, dtype=float)
        for attempt in np.unique(self.attempt[worlds]):
            rows = self.attempt[worlds] == attempt
            self.state.preshapes[worlds[rows]] = self.regrasp.next_preshapes(self.experience, int(attempt), joints[rows],
                                                                        forces[rows], self.state.preshapes[worlds[rows]])
        self.attempt[worlds] += 1
        self.phase[worlds], self.done[worlds], self.time_to_grasp[worlds] = 0, False, np.nan
        self.state.restart(worlds, self.initial, self.closed, self.speed, self.palm_offset, self.time)
        self.state.grip[worlds] = self.params.squeeze

    def __repr__(self) -> str:
        experience = "none" if self.experience is None else type(self.experience).__name__
        return (f"BatchController({self.n} worlds, experience {experience}, recall {self.params.recall.name}, "
                f"{int(self.done.sum())} done)")

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control cycle of every world, in its phases: A (the open hand waits), B/C (matching), D (fingers
        hold where they touched, the others close), the palm's moves, and the end of the grasp.

        Args:
            joints: the sensed joint angles (N, 22), rad.
            segment_forces: the normal force on each segment (N, len(SEGMENTS)), N, in `SEGMENTS` order.

        Returns:
            The joint targets (N, 22), rad.
        """
        joints, forces = self._checked_readings(joints, segment_forces)
        self.time += self.params.control_period
        touching_segments = np.asarray(forces > 0.0)
        touching = per_finger(touching_segments, FINGER_SEGMENT_MASKS, np.any)
        elapsed = self.time - self.state.started
        any_touch = np.asarray(touching_segments.any(axis=1))
        waiting = self._wait(any_touch, elapsed)
        act = ~self.done & ~waiting
        self._regulate_grip(forces, ~waiting)
        if act.any():
            self.phase[act] = np.where(any_touch[act], PHASES.index("C"), PHASES.index("B"))
            self._match(act, joints, touching_segments, touching)
            newly_held = self._hold(act, joints, touching)
            self.params.recall.follow(self, act, newly_held, joints)
            self._close(act)
            self._move_palms(*(self._steer_palm(act, joints, forces, touching) if self.params.palm.active
                                else self._reach(act)))
            self._finish(act, touching, elapsed)
        self.state.previous = joints.copy()
        return self.state.target.copy()

    def _checked_readings(self, joints: np.ndarray, segment_forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        joints = np.asarray(joints, dtype=float)
        forces = np.asarray(segment_forces, dtype=float)
        if joints.shape != (self.n, N_FINGER_JOINTS) or not np.all(np.isfinite(joints)):
            raise InvalidInput(f"joints must be ({self.n}, {N_FINGER_JOINTS}) finite angles, got shape {joints.shape}")
        if forces.shape != (self.n, len(SEGMENTS)) or not np.all(np.isfinite(forces)):
            raise InvalidInput(f"segment_forces must be ({self.n}, {len(SEGMENTS)}) finite forces in SEGMENTS order, "
                               f"got shape {forces.shape}")
        return joints, forces

    def _wait(self, any_touch: np.ndarray, elapsed: np.ndarray) -> np.ndarray:
        """Phase A: the worlds whose hand waits open (the preshape time, untouched; a regrasp opens) -> (N,) bool."""
        p = self.params
        waiting = ~self.done & (elapsed <= p.preshape_time) & (~any_touch | (self.attempt > 1))
        self.state.target[waiting] = self.initial
        return waiting

    def _hold(self, act: np.ndarray, joints: np.ndarray, touching: np.ndarray) -> np.ndarray:
        """Phase D: a touching finger holds where it first touched; one that lost its contact this long closes on
        from there -> (N, 5) the (world, finger) pairs that touched now for the first time."""
        touched = act[:, None] & touching & ~self.state.reaching[:, None]  # while the palm moves, fingers follow the recall
        self.state.last_touch[touched] = self.time
        newly_held = touched & ~self.state.held
        self.state.held = self.state.held | newly_held
        self.state.held_posture = np.where(newly_held[:, JOINT_FINGER], joints, self.state.held_posture)
        self.state.lost &= ~touched
        released = act[:, None] & self.state.held & (self.time - self.state.last_touch > self.params.release_time)
        self.state.lost_posture = np.where(released[:, JOINT_FINGER], self.state.held_posture, self.state.lost_posture)
        self.state.lost |= released
        self.state.held &= ~released
        self.state.closure[released] = 0.0
        return newly_held

    def _close(self, act: np.ndarray) -> None:
        """The acting worlds' targets: a holding finger presses, a free one closes (or goes to its recall)."""
        p, dt = self.params, self.params.control_period
        target = self.state.target.copy()
        pressed = self.params.recall.pressed(self, self.state.grip[:, None] if not p.squeeze_time else
                                             self.state.grip[:, None] * self.state.squeezing[:, None])
        for finger, of in enumerate(FINGER_JOINT_MASKS):
            held = act & self.state.held[:, finger]
            target[np.ix_(held, of)] = pressed[np.ix_(held, of)]
            free = act & ~self.state.held[:, finger]
            if not free.any():
                continue
            going = self.state.approaching[free, finger]  # 'target': on the way to its recall; the others close
            closure = self.state.closure[free, finger]
            closure = np.where(going, closure, np.minimum(1.0, closure + p.closing_rate * dt))
            self.state.closure[free, finger] = closure
            base = np.where(self.state.lost[free, finger][:, None], self.state.lost_posture[np.ix_(free, of)],
                            self.state.base[np.ix_(free, of)])
            goal = np.where(going[:, None], self.state.recalled_posture[np.ix_(free, of)],
                            base + closure[:, None] * (self.state.aim[np.ix_(free, of)] - base))
            pace = np.where(going, self.state.pace[free, finger], p.follow_speed * self.speed[finger])
            target[np.ix_(free, of)] = bounded_step(self.state.target[np.ix_(free, of)], goal, pace * dt)
        self.state.target[act] = np.clip(target[act], self.limits[:, 0], self.limits[:, 1])

    def _move_palms(self, goal: np.ndarray, step: np.ndarray) -> None:
        """The one palm mechanism: every palm moves towards its goal by at most its step this cycle, whatever set
        them (the palm's phases, `_steer_palm`, or a recall that reaches, `_reach`); a palm that reached for a recall
        is no longer reaching once it has arrived.

        Args:
            goal: (N, 3) m, palm frame, where each palm is going.
            step: (N,) m, how far it may move this cycle (0: it stays).
        """
        moving = np.flatnonzero(step > 0)
        if len(moving):
            self.palm_offset[moving] = bounded_step(self.palm_offset[moving], goal[moving], step[moving])
        reached = moving[self.state.reaching[moving]]
        self.state.reaching[reached] = np.any(self.palm_offset[reached] != self.state.palm_goal[reached], axis=1)

    def _reach(self, act: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where a recall that reaches sends the palms on their way to the recalled grasps' places, at the recall
        rule's reach speed -> (goal (N, 3) m, step (N,) m) for `_move_palms`."""
        step = np.where(act & self.state.reaching, self.params.recall.reach_speed * self.params.control_period, 0.0)
        return self.state.palm_goal, step

    def _finish(self, act: np.ndarray, touching: np.ndarray, elapsed: np.ndarray) -> None:
        """The grasp's end: the touching set stable this long, every finger touching or closed, the squeeze
        ramped and the palm arrived; or the timeout."""
        p, dt = self.params, self.params.control_period
        changed = act & np.any(touching != self.state.touching, axis=1)
        self.state.touching[changed] = touching[changed]
        self.state.stable_since[changed] = self.time
        closed = self.params.recall.settled(self, self.state.closure >= 1.0)
        settled = np.all(touching | closed, axis=1)
        squeezed_fully = np.ones(self.n, dtype=bool)
        if p.squeeze_time:  # the touching fingers squeeze together once the grasp has settled
            ramping = act & touching.any(axis=1) & settled
            self.state.squeezing[ramping] = np.minimum(1.0, self.state.squeezing[ramping] + dt / p.squeeze_time)
            squeezed_fully = self.state.squeezing >= 1.0
        finished = act & ((touching.any(axis=1) & settled & ~self.state.reaching & squeezed_fully
                           & (self.time - self.state.stable_since >= p.stable_time))
                          | (elapsed >= p.timeout))
        self.done |= finished
        self.phase[finished] = PHASES.index("done")
        self.time_to_grasp[finished] = self.time

    def _steer_palm(self, act: np.ndarray, joints: np.ndarray, forces: np.ndarray,
                    touching: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The palm's phases (`PalmSteering`): the guarded approach before the first contact, re-centring on the
        touching segments while the grasp settles, still once every finger touches or is closed.

        Args:
            act: (N,) bool, the worlds acting this cycle.
            joints: (N, 22) rad, the sensed joints.
            forces: (N, segments) N, the segment forces.
            touching: (N, 5) bool, the touching fingers.

        Returns:
            (goal (N, 3) m, step (N,) m) for `_move_palms`.
        """
        palm, dt = self.params.palm, self.params.control_period
        any_touch = forces.max(axis=1) > 0.0
        settled = np.all(touching | self.params.recall.settled(self, self.state.closure >= 1.0), axis=1)
        approaching = np.flatnonzero(act & ~any_touch & ~self.state.touched_once)
        self.state.touched_once |= act & any_touch
        goal = self.palm_offset.copy()
        goal[approaching, 1] = -palm.approach
        step = np.zeros(self.n)
        step[approaching] = palm.approach_speed * dt
        centring = np.flatnonzero(act & any_touch & ~settled) if palm.reach > 0 else np.zeros(0, dtype=int)
        places = getattr(self.experience, "places", None) if palm.recalled_place else None
        kinematics, experience = self.kinematics, self.experience
        assert kinematics is not None  # made where the palm steers
        aim = self.state.palm_aim
        for world in centring:  # where the palm goes: measured at the contact, again whenever the touching set changes
            weights = forces[world] * (SEGMENT_FINGER != "")  # the fingers' segments: where the object is held
            renew = np.isnan(aim[world, 0]) or np.any(touching[world] != self.state.touching[world])
            if weights.sum() <= 0.0 or not renew:
                continue
            centre = weights @ kinematics.positions(joints[world]) / weights.sum()
            if places is None or experience is None or not self.winners[world]:  # touch alone: it is where touched
                estimate, wanted = centre, GRASP_CENTRE_IN_PALM
            else:  # the object sits off these segments as it sat off them in the recalled grasp
                row = self.winners[world][-1]
                recalled = weights @ kinematics.positions(experience.references[row]) / weights.sum()
                estimate, wanted = centre + places[row] - recalled, places[row]
            self.object_estimate[world] = self.palm_offset[world] + estimate
            aim[world] = np.clip(self.palm_offset[world, [0, 2]] + estimate[[0, 2]] - wanted[[0, 2]], -palm.reach,
                                 palm.reach)
        centring = centring[~np.isnan(aim[centring, 0])]
        goal[np.ix_(centring, [0, 2])] = aim[centring]
        step[centring] = palm.speed * dt
        return goal, step

    def _regulate_grip(self, forces: np.ndarray, acting: np.ndarray) -> None:
        """The press of the holding fingers regulated to the total grip force `ControllerParams.grip_force`: an
        integral law on each world's press (`GraspState.grip`, rad) from the sum of its segment forces, bounded to
        [0, `grip_press`]; while a world grasps, phase D presses its holding fingers by it, and once its grasp is
        done they press by it here. Nothing where `grip_force` is inf (the press stays the squeeze).

        Args:
            forces: (N, len(SEGMENTS)) N, the segment forces sensed.
            acting: (N,) bool, the worlds past phase A (the done ones included).
        """
        p = self.params
        holding = acting & self.state.held.any(axis=1)
        if math.isinf(p.grip_force) or not holding.any():
            return
        error = 1.0 - forces[holding].sum(axis=1) / p.grip_force  # 1 with no force, < 0 above the grip force
        self.state.grip[holding] = np.clip(self.state.grip[holding] + p.grip_gain * p.control_period * error,
                                           0.0, p.grip_press)
        done = holding & self.done
        if done.any():
            pressed = p.recall.pressed(self, self.state.grip[:, None])
            self.state.target = np.where(done[:, None] & self.state.held[:, JOINT_FINGER], pressed, self.state.target)

    def _match(self, act: np.ndarray, joints: np.ndarray, touching_segments: np.ndarray,
               fingers_touching: np.ndarray) -> None:
        """Phase B / C of every acting world: the best-matching experienced posture becomes the steered
        free fingers' recall ('target') or the closing heuristic's base ('base')."""
        p, any_touch = self.params, np.asarray(touching_segments.any(axis=1))
        preshaped = ~np.isnan(self.state.preshapes[:, 0])
        shaping = act & ~any_touch & preshaped
        self.params.recall.preshape(self, np.flatnonzero(shaping), self.state.preshapes[shaping])
        candidates = act & ~(preshaped & ~any_touch)
        if self.experience is None:
            return
        if not p.experience_steering:
            candidates &= ~any_touch
        if not p.experience_preshape:
            candidates &= any_touch
        masks = np.where(any_touch[:, None], pcp_masks(touching_segments), True)
        candidates &= masks.any(axis=1)  # a palm contact alone specifies no joint
        worlds = np.flatnonzero(candidates)
        if not len(worlds):
            return
        winners = self.experience.best_match_batch(joints[worlds], masks[worlds])
        # the recalled posture is the experience's completion of the query (`Experience.complete`): a reference
        # row for ours, whatever a user's own experience makes of it (a blend, say)
        match = np.asarray(self.experience.complete_batch(joints[worlds], masks[worlds]), dtype=float)
        if math.isfinite(p.max_match_distance):
            trusted = _rms(match - joints[worlds], masks[worlds]) <= p.max_match_distance
            worlds, match, winners = worlds[trusted], match[trusted], winners[trusted]
        self.matches[worlds] += 1
        for world, winner in zip(worlds, winners):
            self.winners[world].append(int(winner))
        self.params.recall.recall(self, worlds, np.asarray(winners), match, joints, touching_segments, fingers_touching)


class GraspController:
    """The tactile grasp controller for one world, sensing and acting one posture at a time: `batch`, a
    `BatchController` with N = 1, whose members it has (experience, params, hand, initial, ...), those of
    the world as one value: phase ('A', 'B', 'C', 'done'), done, matches, winners, palm_offset (3,), m,
    holding (the fingers that hold where they touched), time_to_grasp (s, None while not done)."""

    def __init__(self, experience: Experience | None = None, params: ControllerParams | None = None,
                 initial_posture: np.ndarray | None = None, preshape: np.ndarray | None = None,
                 hand: HandModel = SHADOW_HAND):
        """A controller ready for its first grasp (the arguments of `BatchController`).

        Args:
            experience: None (the plain tactile controller), a PostureDatabase, a SOM, a PostureSet or any
                `Experience`.
            params: timing, gains and switches (`ControllerParams`; the paper's reading by default, `BLEND`).
            initial_posture: the open hand it starts from (22,), rad (default the hand's keyframe `open`).
            preshape: a fixed phase-B posture, rad (a constant preshape) instead of matching the experience there.
            hand: the hand model it drives.
        """
        self.batch = BatchController(1, experience, params, initial_posture, preshape, hand)

    def __getattr__(self, name: str) -> object:  # what does not depend on the world: experience, params, hand, ...
        if name == "batch":
            raise AttributeError(name)
        return getattr(self.batch, name)

    phase = property(lambda self: PHASES[self.batch.phase[0]])
    done = property(lambda self: bool(self.batch.done[0]))
    matches = property(lambda self: int(self.batch.matches[0]))
    winners = property(lambda self: self.batch.winners[0])
    palm_offset = property(lambda self: self.batch.palm_offset[0])
    reaching = property(lambda self: bool(self.batch.state.reaching[0]))
    holding = property(lambda self: frozenset(f for f, h in zip(FINGERS, self.batch.state.held[0]) if h))
    time_to_grasp = property(lambda self: None if np.isnan(self.batch.time_to_grasp[0])
                             else float(self.batch.time_to_grasp[0]))

    def __repr__(self) -> str:
        experience = "none" if self.experience is None else type(self.experience).__name__
        return (f"GraspController(experience {experience}, recall {self.batch.params.recall.name}, phase {self.phase}, "
                f"{self.matches} matches{', done' if self.done else ''})")

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control cycle.

        Args:
            joints: the sensed joint angles (22,), rad.
            segment_forces: the normal force on each segment (len(SEGMENTS),), N, in `SEGMENTS` order.

        Returns:
            The joint targets (22,), rad.
        """
        joints = validate_posture(joints, name="joints")
        forces = np.asarray(segment_forces, dtype=float)
        if forces.shape != (len(SEGMENTS),) or not np.all(np.isfinite(forces)):
            raise InvalidInput(f"segment_forces must be {len(SEGMENTS)} finite forces in SEGMENTS order")
        return self.batch.step(joints[None], forces[None])[0]


def __getattr__(name: str) -> object:
    """The recall rules and the grasp state moved out in 0.2 (`control.recall`, `control.state`), with a warning."""
    return moved_attribute(__name__, name)

