"""What a best match does: the grasp controller's recall rules (the controller module's doc describes them), each
one value of `ControllerParams.recall`, and what a rule may read and change of the controller (`ControllerView`).

A rule of one's own is a `RecallRule` subclass (a frozen dataclass, its settings as fields) that reads and changes
only the controller's public view: its `GraspState` (`state`), which joints and fingers a match may set, the hand's
kinematics, closed posture, ranges and speeds. `tests/test_house.py` runs one that steers only the thumb.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar, Protocol

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import Bounds, check_choice, check_number
from ..manifold.experience import Experience, carried_values
from ..sim.grip import pressed_towards
from ..sim.hand import FINGERS, N_FINGER_JOINTS, SegmentKinematics
from ..sim.posture import SEGMENT_FINGER
from .state import FINGER_JOINT_MASKS, JOINT_FINGER, GraspState, per_finger

#: rad/s: a finger on its way to a recalled posture whose joints move slower than this has stopped short of it
REST_SPEED = 0.1


class ControllerView(Protocol):
    """What a recall rule reads and changes of the controller (`BatchController` is one): nothing private.

    Attributes:
        state: every world's arrays (`GraspState`): what a rule changes.
        steered_joint_mask, steered_finger_mask: (22,) and (5,) bool, the joints and fingers a best match may set.
        kinematics: the hand's `SegmentKinematics` where the rule or the palm steering moves the palm, else None.
        initial, closed, limits: the open and closed postures (22,) and the ranges (22, 2), rad.
        speed: (5,) each finger's joint speed, rad/s.
        control_period: s between two cycles.
        squeeze: rad, the press of the holding fingers when nothing regulates it (`ControllerParams.squeeze`).
        palm_offset: (N, 3) m, how far each palm has moved.
        experience: the experience base recalled from (None: the plain heuristic).
        time: s since the grasp started.
    """

    state: GraspState
    steered_joint_mask: np.ndarray
    steered_finger_mask: np.ndarray
    kinematics: SegmentKinematics | None
    initial: np.ndarray
    closed: np.ndarray
    limits: np.ndarray
    speed: np.ndarray
    palm_offset: np.ndarray
    experience: Experience | None
    time: float

    @property
    def control_period(self) -> float:
        """s between two cycles."""
        ...

    @property
    def squeeze(self) -> float:
        """rad, the press of the holding fingers when nothing regulates it."""
        ...


class RuleSettings(Protocol):
    """What a rule's `check` may read of the controller's parameters (`ControllerParams` is them)."""

    @property
    def steered_joints(self) -> str:
        """'all' or 'spread': which joints of a steered finger a match sets."""
        ...


class RecallRule:
    """What a best match does (see the module doc): the hooks `BatchController` calls with itself, so that a rule of
    one's own runs without a change to the controller (`ControllerParams(recall=MyRule())`; a frozen dataclass, its
    fields part of the trials' key). The hooks work on the controller's arrays of the worlds given; the closing
    heuristic, the holding and the finishing stay the controller's.

    What a rule reads and changes is the controller's public view, nothing private: `c.state` (the `GraspState`,
    per-world arrays such as `target`, `base`, `held`, `visited`, which a rule changes), `c.steered_joint_mask`
    (22,) and `c.steered_finger_mask` (5,) (which joints and fingers a match may set: `steered_fingers`,
    `steered_joints`), `c.kinematics` (the hand's `SegmentKinematics` where a rule or the palm steering moves the
    palm, else None), `c.initial`, `c.closed`, `c.limits`, `c.speed`, `c.control_period`, `c.palm_offset`, `c.experience`,
    `c.time`: `ControllerView`.

    Attributes:
        name: the rule's name (`ControllerParams.recall` for ours).
        moves_palm: whether a recall may move the palm (the trials then carry each palm to `palm_offset`).
        reach_speed: m/s a recall moves the palm at.
    """

    name = "rule"
    reach_speed = 0.0
    __dataclass_fields__: ClassVar[dict[str, Any]]  # a rule is a dataclass (`fields` and `replace` read it)

    @property
    def moves_palm(self) -> bool:
        """Whether a recall may move the palm (a rule of one's own may say so by a class attribute)."""
        return False

    def preshape(self, c: ControllerView, worlds: np.ndarray, postures: np.ndarray) -> None:
        """Phase B with a constant preshape, nothing touching yet.

        Args:
            c: the controller (its `state` is what a rule changes).
            worlds: (m,) the worlds' indices.
            postures: (m, 22) rad, their preshapes.
        """
        raise NotImplementedError

    def recall(self, c: ControllerView, worlds: np.ndarray, winners: np.ndarray, match: np.ndarray,
               joints: np.ndarray, touching_segments: np.ndarray, fingers_touching: np.ndarray) -> None:
        """Trusted best matches, once a control cycle.

        Args:
            c: the controller.
            worlds: (m,) the worlds with a trusted match.
            winners: (m,) their winning reference rows.
            match: (m, 22) rad, their recalled postures.
            joints: (N, 22) rad, every world's sensed joints.
            touching_segments: (N, segments) bool, every world's touching segments.
            fingers_touching: (N, 5) bool, every world's touching fingers.
        """
        raise NotImplementedError

    def follow(self, c: ControllerView, act: np.ndarray, newly_held: np.ndarray, joints: np.ndarray) -> None:
        """After the holding of phase D, every cycle (nothing by default).

        Args:
            c: the controller.
            act: (N,) bool, the worlds acting this cycle.
            newly_held: (N, 5) bool, the (world, finger) pairs that touched now for the first time.
            joints: (N, 22) rad, the sensed joints.
        """

    def pressed(self, c: ControllerView, amount: float | np.ndarray) -> np.ndarray:
        """Where the holding fingers press (phase D's squeeze): by default each flexion joint `amount` on from where
        its finger touched, towards the closed hand (`squeezed`).

        Args:
            c: the controller.
            amount: rad, how far: one, or (N, 1) one per world.

        Returns:
            (N, 22) rad, every world's pressing targets (the controller takes those of the holding fingers).
        """
        return pressed_towards(c.state.held_posture, amount, c.closed, c.limits)

    def settled(self, c: ControllerView, closed: np.ndarray) -> np.ndarray:
        """Which (world, finger) pairs count as fully closed for the grasp's end.

        Args:
            c: the controller.
            closed: (N, 5) bool, the pairs whose closure reached 1.

        Returns:
            (N, 5) bool; `closed` by default.
        """
        return closed

    def check(self, params: RuleSettings) -> None:
        """Refuse controller parameters this rule cannot work with (none by default).

        Args:
            params: the parameters that hold it.

        Raises:
            InvalidInput: a combination it cannot work with.
        """

    def to_table(self) -> dict:
        """The rule as a table (a configuration file's, run.json's, the trials' key): its name under 'rule', then its
        fields."""
        return {"rule": self.name, **{f.name: getattr(self, f.name) for f in fields(self)}}

    def with_table(self, table: str | dict) -> RecallRule:
        """This rule as a configuration file's table changes it: a name alone is that rule of ours with its defaults;
        {rule, field = value, ...} the rule named (this one where the name is its own) with those fields.

        Args:
            table: the table, or a name in `RECALL_RULES`.

        Returns:
            The rule.

        Raises:
            InvalidInput: an unknown rule or field.
        """
        table = {"rule": table} if isinstance(table, str) else dict(table)
        name = table.pop("rule", self.name)
        base = self if name == self.name else RECALL_RULES[check_choice(name, tuple(RECALL_RULES), "recall rule")]()
        known = [f.name for f in fields(base)]
        unknown = sorted(set(table) - set(known))
        if unknown:
            raise InvalidInput(f"unknown setting(s) {unknown} of the recall rule {name!r}; it has {known}")
        return replace(base, **table)


@dataclass(frozen=True)
class TargetRecall(RecallRule):
    """The paper's reading (`recall="target"`): the recall is the steered free fingers' target; a finger closes on
    from it once there (see the module doc).

    Attributes:
        tolerance: rad: a finger is there once every joint is this close to its recall (or at rest short of it).
        closes_only: a recall moves a joint only towards the closed hand (`CLOSING_RECALL`).
    """

    tolerance: float = 0.05
    closes_only: bool = False
    name = "target"

    def __post_init__(self) -> None:
        check_number(self.tolerance, "TargetRecall.tolerance", Bounds(0.0, 10.0, above_low=True, unit="rad"))
        if not isinstance(self.closes_only, bool):
            raise InvalidInput(f"TargetRecall.closes_only must be True or False, got {self.closes_only!r}")

    def preshape(self, c: ControllerView, worlds: np.ndarray, postures: np.ndarray) -> None:
        """The preshape is the steered free fingers' first recall (its key 0).

        Args:
            c: the controller.
            worlds: (m,) the worlds' indices.
            postures: (m, 22) rad, their preshapes.
        """
        self._recall_for(c, worlds, np.zeros(len(worlds), dtype=np.int64), postures)

    def recall(self, c: ControllerView, worlds: np.ndarray, winners: np.ndarray, match: np.ndarray,
               joints: np.ndarray, touching_segments: np.ndarray, fingers_touching: np.ndarray) -> None:
        """Each match becomes the target of the steered free fingers not on their way to it or done with it.

        Args:
            c: the controller.
            worlds: (m,) the worlds with a trusted match.
            winners: (m,) their winning reference rows (each recall's key: the row + 1).
            match: (m, 22) rad, their recalled postures.
            joints: (N, 22) rad, every world's sensed joints (not read).
            touching_segments: (N, segments) bool (not read).
            fingers_touching: (N, 5) bool (not read).
        """
        self._recall_for(c, worlds, np.asarray(winners, dtype=np.int64) + 1, match)

    def follow(self, c: ControllerView, act: np.ndarray, newly_held: np.ndarray, joints: np.ndarray) -> None:
        # a finger that touched on its way is done with its recall; one that arrived closes on from it
        self._done_with(c, newly_held)  # touched on its way: that recall is done with
        self._arrive(c, act, joints)

    def settled(self, c: ControllerView, closed: np.ndarray) -> np.ndarray:
        """A finger whose recall was the closed hand is fully closed once there; one on its way is not.

        Args:
            c: the controller.
            closed: (N, 5) bool, the pairs whose closure reached 1.

        Returns:
            (N, 5) bool.
        """
        return ~c.state.approaching & (closed | per_finger(c.state.target == c.closed, FINGER_JOINT_MASKS))

    def _recall_for(self, c: ControllerView, worlds: np.ndarray, keys: np.ndarray, postures: np.ndarray) -> None:
        """Each world's recalled posture (its key: the reference row + 1, 0 for the preshape) becomes the recall of
        its steered free fingers that are not on their way to it already, nor done with it."""
        visits = c.state.visit(worlds[:, None], np.arange(len(FINGERS)), keys[:, None])
        new = (c.steered_finger_mask & ~c.state.held[worlds] & ~c.state.was_visited(visits)
               & ~(c.state.approaching[worlds] & (c.state.heading[worlds] == keys[:, None])))
        recalled = np.clip(np.where(c.steered_joint_mask, postures, c.state.target[worlds]), *c.limits.T)  # any hand's
        if self.closes_only:  # no joint sent back towards the open hand
            now = c.state.target[worlds]
            recalled = np.where((recalled - now) * np.sign(c.closed - c.initial) < 0, now, recalled)
        c.state.recalled_posture[worlds] = np.where(new[:, JOINT_FINGER], recalled, c.state.recalled_posture[worlds])
        c.state.approaching[worlds] |= new
        c.state.heading[worlds] = np.where(new, keys[:, None], c.state.heading[worlds])

    @staticmethod
    def _done_with(c: ControllerView, fingers: np.ndarray) -> None:
        """These (world, finger) pairs are done with the recall they were on their way to."""
        fingers = fingers & c.state.approaching
        worlds, which = np.nonzero(fingers)
        c.state.mark_visited(c.state.visit(worlds, which, c.state.heading[fingers]))
        c.state.approaching &= ~fingers

    def _arrive(self, c: ControllerView, act: np.ndarray, joints: np.ndarray) -> None:
        """A free finger whose target has reached its recall, its joints within `tolerance` of it or at rest
        short of it, closes on from it, its closure from 0."""
        with np.errstate(invalid="ignore"):  # nothing was sensed before the first cycle: not at rest
            still = per_finger(np.abs(joints - c.state.previous) <= REST_SPEED * c.control_period,
                                FINGER_JOINT_MASKS)
        near = per_finger(np.abs(joints - c.state.recalled_posture) <= self.tolerance, FINGER_JOINT_MASKS)
        arrived = (act[:, None] & c.state.approaching & ~c.state.held & (near | still)
                   & per_finger(c.state.target == c.state.recalled_posture, FINGER_JOINT_MASKS))
        c.state.base = np.where(arrived[:, JOINT_FINGER], c.state.recalled_posture, c.state.base)
        c.state.closure[arrived] = 0.0
        c.state.lost &= ~arrived
        self._done_with(c, arrived)


@dataclass(frozen=True)
class ApproachRecall(TargetRecall):
    """The execution of a recalled grasp as a verified grasp is executed (`recall="approach"`, `APPROACH`): the
    paper's reading of a recall as the steered free fingers' target, with the way to it kept (`GraspState.way`:
    from the posture the attempt started in, the open hand or a plan's pregrasp, to the recall). A finger that
    reached its recall
    without a contact closes on *along that way*, up to `overshoot` times its length further (the paper's reading
    closes it on towards the closed fist, which sweeps a fingertip past a small object); a finger that touches
    presses on along its way by `ControllerParams.squeeze` (rad, the finger's joints together) instead of flexing
    towards the fist; where the experience carries each grasp's verified squeeze (its `squeezes`), it presses by the
    recalled grasp's own squeeze instead (`pressed`). A grasp's pregrasp lies back from it along the contacts' normals, so from there the way is
    the normals' way, and the press is what a verified grasp's squeeze does (`sim/normal_offsets`) without knowing the
    normals. A finger with no way (never recalled) closes and presses as the paper's reading does.

    Attributes:
        tolerance, closes_only: as `TargetRecall`'s.
        overshoot: how far past its recall a finger that arrived untouched may close, in lengths of its way.
        together: the fingers that set out for a recall at once arrive at once (the slowest at the heuristic's
            speed, the others slowed to its time: `GraspState.pace`), as a replayed grasp's fingers do; otherwise
            each at the heuristic's speed.
    """

    overshoot: float = 1.0
    together: bool = True
    name = "approach"

    def __post_init__(self) -> None:
        super().__post_init__()
        check_number(self.overshoot, "ApproachRecall.overshoot", Bounds(0.0, 10.0))
        if not isinstance(self.together, bool):
            raise InvalidInput(f"ApproachRecall.together must be True or False, got {self.together!r}")

    def _recall_for(self, c: ControllerView, worlds: np.ndarray, keys: np.ndarray, postures: np.ndarray) -> None:
        """As `TargetRecall`'s, and each finger that sets out for a recall keeps its way there: from the attempt's
        starting posture, not from where the finger is (a recall that came late, near the finger, would leave it a
        way too short to close on along: on the experience study's selection split such fingers counted as closed
        without touching)."""
        setting_out = ~c.state.approaching[worlds] | (c.state.heading[worlds] != keys[:, None])
        start = c.state.target[worlds]
        super()._recall_for(c, worlds, keys, postures)
        new = setting_out & c.state.approaching[worlds] & (c.state.heading[worlds] == keys[:, None])
        recalled = c.state.recalled_posture[worlds]
        c.state.way[worlds] = np.where(new[:, JOINT_FINGER], recalled - c.initial, c.state.way[worlds])
        if self.together:  # the slowest finger's time at its own speed, the others slowed to it
            length = np.sqrt(((recalled - start) ** 2) @ FINGER_JOINT_MASKS.T)  # (m, 5) to travel
            moves = new & (c.speed > 0)  # a finger the heuristic would not move (start at closed) sets no time
            time = np.max(np.where(moves, length / np.where(c.speed > 0, c.speed, 1.0), 0.0), axis=1, keepdims=True)
            pace = np.where(time > 0, length / np.where(time > 0, time, 1.0), c.speed)
            c.state.pace[worlds] = np.where(new, pace, c.state.pace[worlds])

    def _arrive(self, c: ControllerView, act: np.ndarray, joints: np.ndarray) -> None:
        """As `TargetRecall`'s, and a finger that arrives closes on along its way (its `GraspState.aim`)."""
        before = c.state.approaching.copy()
        super()._arrive(c, act, joints)
        arrived = (before & ~c.state.approaching & ~c.state.held)[:, JOINT_FINGER]
        aim = np.clip(c.state.recalled_posture + self.overshoot * c.state.way, c.limits[:, 0], c.limits[:, 1])
        c.state.aim = np.where(arrived, aim, c.state.aim)

    def pressed(self, c: ControllerView, amount: float | np.ndarray) -> np.ndarray:
        """A holding finger whose recalled grasp carries its verified squeeze (the experience's `squeezes`, issue 84)
        presses by that squeeze from where it touched, scaled by `amount` / `c.squeeze` (in full unless a grip
        regulation or a settling ramp eases it); one with a way and no squeeze presses on along its way, `amount`
        rad (its joints' norm); one without either, as the paper's reading does.

        Args:
            c: the controller.
            amount: rad: one, or (N, 1) one per world.

        Returns:
            (N, 22) rad.
        """
        length = np.sqrt((c.state.way ** 2) @ FINGER_JOINT_MASKS.T)[:, JOINT_FINGER]  # (N, 22): each finger's
        along = c.state.held_posture + amount * c.state.way / np.where(length > 0, length, 1.0)
        along = np.clip(along, c.limits[:, 0], c.limits[:, 1])
        pressed = np.where(length > 0, along, super().pressed(c, amount))
        squeezes = carried_values(c.experience).get("squeezes")
        if squeezes is None:
            return pressed
        keys = c.state.heading[:, JOINT_FINGER]  # (N, 22): the recall each joint's finger went to (row + 1; 0 none)
        offsets = squeezes[np.maximum(keys - 1, 0), np.arange(N_FINGER_JOINTS)]
        share = np.divide(amount, c.squeeze) if c.squeeze > 0 else 0.0
        recalled = np.clip(c.state.held_posture + share * offsets, c.limits[:, 0], c.limits[:, 1])
        return np.where(keys > 0, recalled, pressed)


@dataclass(frozen=True)
class BlendRecall(RecallRule):
    """Our earlier blend (`recall="base"`, `BLEND`): the recall is the closing heuristic's base (see the module doc).

    Attributes:
        restart_closure: the first trusted match after a contact restarts the free fingers' closure at 0.
        reach: m: that match may also move the palm by up to this much (0: the palm stays).
        reach_speed: m/s the palm moves at then.
    """

    restart_closure: bool = False
    reach: float = 0.0
    reach_speed: float = 0.1
    name = "base"

    def __post_init__(self) -> None:
        if not isinstance(self.restart_closure, bool):
            raise InvalidInput(f"BlendRecall.restart_closure must be True or False, got {self.restart_closure!r}")
        check_number(self.reach, "BlendRecall.reach", Bounds(0.0, 0.2, unit="m"))
        check_number(self.reach_speed, "BlendRecall.reach_speed", Bounds(0.0, 10.0, above_low=True, unit="m/s"))

    def check(self, params: RuleSettings) -> None:
        """Its extensions need every joint of a steered finger recalled.

        Args:
            params: the parameters that hold it.

        Raises:
            InvalidInput: `restart_closure` or `reach` with `steered_joints='spread'`.
        """
        if (self.restart_closure or self.reach) and params.steered_joints != "all":
            raise InvalidInput(f"BlendRecall({'restart_closure' if self.restart_closure else 'reach'}) needs "
                               "steered_joints='all': with only the spread joints recalled, a restarted closure would "
                               "open the fingers' flexion again")

    @property
    def moves_palm(self) -> bool:
        """Whether a recall moves the palm: with a reach."""
        return self.reach > 0

    def preshape(self, c: ControllerView, worlds: np.ndarray, postures: np.ndarray) -> None:
        """The preshape is the closing heuristic's base.

        Args:
            c: the controller.
            worlds: (m,) the worlds' indices.
            postures: (m, 22) rad, their preshapes.
        """
        c.state.base[worlds] = postures

    def recall(self, c: ControllerView, worlds: np.ndarray, winners: np.ndarray, match: np.ndarray,
               joints: np.ndarray, touching_segments: np.ndarray, fingers_touching: np.ndarray) -> None:
        """Each match is the base of the steered joints; the first after a contact may restart the closure and
        move the palm (`restart_closure`, `reach`).

        Args:
            c: the controller.
            worlds: (m,) the worlds with a trusted match.
            winners: (m,) their winning reference rows (not read).
            match: (m, 22) rad, their recalled postures.
            joints: (N, 22) rad, every world's sensed joints.
            touching_segments: (N, segments) bool, every world's touching segments.
            fingers_touching: (N, 5) bool, every world's touching fingers.
        """
        c.state.base[worlds] = np.where(c.steered_joint_mask, match, c.state.base[worlds])
        if not (self.restart_closure or self.reach > 0):
            return
        any_touch = np.asarray(touching_segments.any(axis=1))  # a contact's first trusted match restarts the closure
        restart = worlds[any_touch[worlds] & ~c.state.closure_restarted[worlds]]
        c.state.closure_restarted[restart] = True
        touching = fingers_touching[restart]
        if self.reach > 0:
            for world, row in zip(restart, match[np.isin(worlds, restart)]):
                self._start_reach(c, world, joints[world], row, touching_segments[world])
            reset = np.broadcast_to(c.steered_finger_mask, touching.shape)
        else:
            reset = ~touching & ~c.state.held[restart] & c.steered_finger_mask
        c.state.closure[restart] = np.where(reset, 0.0, c.state.closure[restart])

    def _start_reach(self, c: ControllerView, world: int, joints: np.ndarray, match: np.ndarray,
                     touching: np.ndarray) -> None:
        """The palm's way to the recalled grasp (`palm_shift`); every finger lets go to follow the recall."""
        rows = np.flatnonzero(touching & (SEGMENT_FINGER != ""))
        if not len(rows):
            return
        if c.kinematics is None:
            raise InvalidInput("a recall that reaches moves the palm: its controller must know the hand's kinematics")
        c.state.palm_goal[world] = palm_shift(c.kinematics, joints, match, rows, self.reach)
        c.state.reaching[world] = bool(np.any(c.state.palm_goal[world] != c.palm_offset[world]))
        c.state.held[world] = False
        c.state.lost[world] = False


def palm_shift(kinematics: SegmentKinematics, joints: np.ndarray, recalled: np.ndarray, touching: np.ndarray,
               reach: float) -> np.ndarray:
    """How far (3,), m, palm frame, the palm should move so that the object lies where a recalled grasp
    (22,), rad, holds it: the mean difference between where the touching segments (indices into SEGMENTS)
    are now, at the sensed joints (22,), rad, and where the recall puts them, at most `reach` m long."""
    now, then = kinematics.positions(joints), kinematics.positions(recalled)
    shift = np.mean(now[touching] - then[touching], axis=0)
    length = float(np.linalg.norm(shift))
    return shift if length <= reach else shift * (reach / length)


#: our recall rules by name (`ControllerParams(recall="base")`, a configuration file's `recall = "base"`)
RECALL_RULES: dict[str, type[RecallRule]] = {"target": TargetRecall, "base": BlendRecall, "approach": ApproachRecall}
