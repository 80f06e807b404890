"""Regrasp, beyond the paper: notice a failing grasp by touch alone, open the hand and try another grasp.

A trial with a `Regrasp` of more than one attempt does, once the controller reports its grasp done and
attempts remain, a lift probe: the object's support is released and gravity pulls it along
`PROBE_DIRECTION` (its weight, as when the hand lifts it) for `probe_seconds`, while the hand keeps its
targets. The probe watches what a tactile skin reports, nothing else (`Regrasp.failing`): at its end a
grasp is failing when fewer than two parts of the hand (the five fingers and the palm) touch the object, so
nothing opposes anything, or their normal forces add up to less than `min_force`; it ends early once no
segment touches at all (the object is gone). A failing grasp's probe ends: gravity goes off, the support is
re-engaged where the object lies now (it is not put back; it catches the object at rest there,
`Scene.anchor_object_support`), softer than the support of the first closing (`support_stiffness`,
`support_damping`: the hand moving to a new preshape then pushes the object aside instead of into it), and the
controller starts its next attempt from there (`BatchController.restart`), with the next preshape chosen from
what the failed attempt sensed:

- `grasp_types` given (one per reference posture of the experience, `reference_grasp_types`): the
  experience's best match for the failed attempt's Partial Contact Posture (its last sensed joints and
  touching segments, Eq. 1-2) among the references of another grasp type than the one the hand ended in
  (the type of the reference nearest to its last posture): regrasp with experience;
- `preshapes` given: a fixed sequence, row k the preshape of attempt k + 2 (NaN row: none, the plain heuristic);
- `chooser` given: a learned choice from what the failed attempt sensed (`trials.strategy_selector.StrategySelector`);
- neither: the first attempt's way again (the heuristic retried, or its constant preshape again).

A grasp that passes the probe, or the last attempt, goes to the judge's full hold test, once.
"""

from __future__ import annotations

import hashlib
import pickle
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import Bounds, check_fields
from ..manifold.experience import Experience
from ..manifold.nearest import argmin_tied, nearest_rows
from ..manifold.postureset import PostureSet
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS, HandModel
from ..sim.scene import GRAVITY
from ..sim.worlds import Worlds
from ..sim.posture import SEGMENT_FINGER, pcp_masks

#: the probe's gravity, unit vector in the world: the object's weight as when the hand lifts it
PROBE_DIRECTION = np.array([0.0, 0.0, -1.0])
#: the part of the hand (a finger, or the palm) each segment belongs to, for the probe's rule
_FINGER_OF_SEGMENT = np.unique(SEGMENT_FINGER, return_inverse=True)[1]


#: the bounds of a `Regrasp`: a million attempts, each probed and failing, ran a two-pose evaluation for minutes
MAX_ATTEMPTS = 10
MAX_PROBE_SECONDS = 5.0
MAX_MIN_FORCE = 1000.0  # N
MAX_SUPPORT = 1e5  # N/m, N s/m: the re-engaged support's stiffness and damping
REGRASP_BOUNDS = {"attempts": Bounds(1, MAX_ATTEMPTS, whole=True),
                  "probe_seconds": Bounds(0.0, MAX_PROBE_SECONDS, above_low=True, unit="s"),
                  "min_force": Bounds(0.0, MAX_MIN_FORCE, above_low=True, unit="N"),
                  "support_stiffness": Bounds(0.0, MAX_SUPPORT, unit="N/m"),
                  "support_damping": Bounds(0.0, MAX_SUPPORT, unit="N s/m")}


@dataclass(frozen=True, eq=False)
class Regrasp:
    """How many attempts a trial's controller has, how it probes a grasp and how it chooses the next one
    (see the module doc).

    Attributes:
        attempts: grasp attempts at most (1: no probe, the paper's single grasp).
        probe_seconds: s of the lift probe.
        min_force: N, the least total normal force of a grasp that passes the probe.
        preshapes: (attempts - 1, 22) rad, a fixed sequence of the later attempts' preshapes (NaN rows: none).
        grasp_types: (k,) one grasp type per reference posture of the experience: recall the next grasp from
            the experience, another type than the failed one.
        chooser: `chooser(features)` -> (m, 22) rad, the next preshapes (NaN rows: none) from what the failed
            attempts sensed, (m, 22 + len(SEGMENTS)): their joints and segment forces (`Trial.failure`); e.g. a
            fitted `trials.strategy_selector.StrategySelector`. A picklable object, for worker processes.
        support_stiffness: N/m (and N m/rad) of the support re-engaged after a failed probe; a tenth of the first
            closing's (`judge.JUDGING`): with that one, 11 of 191 second attempts on the benchmark's selection
            split failed their physics (a contact deeper than 5 mm), with this one none (issue 51).
        support_damping: N s/m (and N m s/rad) of that support: critical for 11 g (the benchmark's lightest
            objects), a third of it for 0.1 kg.
    """

    attempts: int = 1
    probe_seconds: float = 0.2
    min_force: float = 1.0
    preshapes: np.ndarray | None = None
    grasp_types: np.ndarray | None = None
    chooser: Callable[[np.ndarray], np.ndarray] | None = None
    support_stiffness: float = 200.0
    support_damping: float = 3.0

    def __post_init__(self) -> None:
        check_fields(self, REGRASP_BOUNDS)
        if self.preshapes is not None:
            rows = np.asarray(self.preshapes, dtype=float)
            if rows.shape != (self.attempts - 1, N_FINGER_JOINTS):
                raise InvalidInput(f"Regrasp.preshapes must be ({self.attempts - 1}, {N_FINGER_JOINTS}): one preshape "
                                   f"per attempt after the first, got shape {rows.shape}")
            if not np.all(np.isfinite(rows) | np.isnan(rows).all(axis=1, keepdims=True)):
                raise InvalidInput("Regrasp.preshapes rows must be finite angles, or all NaN (no preshape)")
            if np.nanmax(np.abs(rows), initial=0.0) > np.pi:  # 100 rad was taken (the servos clip it)
                raise InvalidInput(f"Regrasp.preshapes must be joint angles within ±π rad, got one of "
                                   f"{np.nanmax(np.abs(rows)):.3g} rad")
            object.__setattr__(self, "preshapes", rows)
        if sum(x is not None for x in (self.preshapes, self.grasp_types, self.chooser)) > 1:
            raise InvalidInput("Regrasp takes one way to choose the next attempt: preshapes (a fixed sequence), "
                               "grasp_types (recall from the experience) or a chooser")
        if self.chooser is not None and not callable(self.chooser):
            raise InvalidInput(f"Regrasp.chooser must be callable: chooser(features) -> preshapes, got {self.chooser!r}")
        if self.grasp_types is not None:
            object.__setattr__(self, "grasp_types", np.asarray(self.grasp_types, dtype=str).ravel())

    def check_trials(self, experience: Experience | None, hand: HandModel, table: bool, backend: str) -> None:
        """Refuse trials this regrasp cannot run in, before any trial starts.

        Args:
            experience: the trials' experience base (None: the plain controller).
            hand: the hand model the trials run (its joint ranges bound `preshapes`).
            table: whether the object stands on a table.
            backend: the trials' physics backend.

        Raises:
            InvalidInput: grasp types without an experience or of another length than its references, a preshape
                outside the hand's ranges, or more than one attempt on a table or off the cpu backend.
        """
        if self.grasp_types is not None and self.attempts > 1:
            if experience is None:
                raise InvalidInput("Regrasp.grasp_types recalls the next grasp from the experience: give an experience")
            if len(self.grasp_types) != len(experience.references):
                raise InvalidInput(f"Regrasp.grasp_types has {len(self.grasp_types)} types for an experience of "
                                   f"{len(experience.references)} reference postures")
        if self.preshapes is not None:
            limits, rows = hand.limits(), self.preshapes
            outside = np.isfinite(rows) & ((rows < limits[:, 0] - 1e-9) | (rows > limits[:, 1] + 1e-9))
            if outside.any():
                row, joint = np.argwhere(outside)[0]
                raise InvalidInput(f"Regrasp.preshapes row {row}: {hand.finger_joints[joint]} = {rows[row, joint]:.3g} "
                                   f"rad lies outside its range {limits[joint].round(3).tolist()} on the "
                                   f"{hand.name!r} hand")
        if self.attempts > 1 and (table or backend != "cpu"):
            raise InvalidInput("a regrasp (Regrasp.attempts > 1) runs on the spring support (table=False) and the cpu "
                               "backend: its probe re-engages the support where the object lies")

    def description(self) -> dict:
        """What a checkpoint key needs of it: plain values."""
        return {"attempts": int(self.attempts), "probe_seconds": float(self.probe_seconds),
                "min_force": float(self.min_force), "support": [float(self.support_stiffness),
                                                                 float(self.support_damping)],
                "preshapes": None if self.preshapes is None else np.nan_to_num(self.preshapes, nan=99.0).round(9).tolist(),
                "grasp_types": None if self.grasp_types is None else self.grasp_types.tolist(),
                "chooser": None if self.chooser is None else hashlib.sha256(pickle.dumps(self.chooser)).hexdigest()}

    def failing(self, forces: np.ndarray) -> np.ndarray:
        """The probe's rule at its end, from touch alone: fewer than two parts of the hand (fingers, palm) touch,
        or the normal forces add up to less than `min_force`.

        Args:
            forces: segment forces (m, len(SEGMENTS)), N, in `SEGMENTS` order.

        Returns:
            (m,) bool: the grasps that are failing.
        """
        forces = np.asarray(forces, dtype=float)
        parts = np.zeros((len(forces), _FINGER_OF_SEGMENT.max() + 1), dtype=bool)
        np.logical_or.at(parts, (np.arange(len(forces))[:, None], _FINGER_OF_SEGMENT[None, :]), forces > 0)
        return (parts.sum(axis=1) < 2) | (forces.sum(axis=1) < self.min_force)

    def next_preshapes(self, experience: Experience | None, attempt: int, joints: np.ndarray, forces: np.ndarray,
                       current: np.ndarray) -> np.ndarray:
        """The preshapes of the next attempt of m worlds whose attempt `attempt` (1, 2, ...) failed.

        Args:
            experience: the controller's experience (needed with `grasp_types`).
            attempt: the number of the attempt that failed.
            joints: (m, 22) rad, the joints sensed when it failed.
            forces: (m, len(SEGMENTS)) N, the segment forces sensed then.
            current: (m, 22) rad, the failed attempt's preshapes (NaN rows: none).

        Returns:
            (m, 22) rad, NaN rows where the attempt has no preshape.
        """
        if self.preshapes is not None:
            return np.tile(self.preshapes[attempt - 1], (len(joints), 1))
        if self.chooser is not None:
            chosen = np.asarray(self.chooser(np.column_stack([joints, forces])), dtype=float)
            if chosen.shape != joints.shape:
                raise InvalidInput(f"Regrasp.chooser must return ({len(joints)}, {N_FINGER_JOINTS}) preshapes, got "
                                   f"shape {chosen.shape}")
            return chosen
        if self.grasp_types is None:
            return current.copy()
        if experience is None:
            raise InvalidInput("Regrasp.grasp_types chooses among an experience's references: give an experience")
        references = np.asarray(experience.references, dtype=float)
        if len(self.grasp_types) != len(references):
            raise InvalidInput(f"Regrasp.grasp_types has {len(self.grasp_types)} types for an experience of "
                               f"{len(references)} reference postures")
        nearest = argmin_tied(((references[None] - joints[:, None]) ** 2).sum(axis=2), axis=1)
        failed_type = self.grasp_types[nearest]
        masks = np.array(pcp_masks(np.asarray(forces) > 0), dtype=bool)
        masks[~masks.any(axis=1)] = True  # nothing specified (only the palm touched): the whole posture
        chosen = np.empty_like(joints)
        for row, (posture, mask, excluded) in enumerate(zip(joints, masks, failed_type)):
            allowed = np.flatnonzero(self.grasp_types != excluded)
            if not len(allowed):  # one grasp type only: the best match of any
                allowed = np.arange(len(references))
            distances = (((references[allowed] - posture) ** 2) * mask).sum(axis=1)
            chosen[row] = references[allowed[argmin_tied(distances)]]
        return chosen


def grasp_types_of(postures: PostureSet) -> np.ndarray:
    """The grasp type of every posture of a generated set, from its metadata's `grasp_types` (starting design ->
    type, as `generate_postures` writes it).

    Args:
        postures: the posture set.

    Returns:
        (n,) str, one type per posture.
    """
    types_by_design = postures.metadata.get("grasp_types")
    names = [name.split(":", 1)[-1] for name in postures.start_names]  # "object:design" or "design"
    if not isinstance(types_by_design, dict) or not all(name in types_by_design for name in names):
        raise InvalidInput("postures must name each starting design's grasp type (metadata 'grasp_types', written "
                           "by generate_postures)")
    return np.array([types_by_design[names[i]] for i in postures.start_ids], dtype=str)


def reference_grasp_types(experience: Experience, postures: np.ndarray, types: np.ndarray) -> np.ndarray:
    """The grasp type of each reference posture of an experience: that of the nearest of the postures it was
    made from (a database's own postures; a SOM node's nearest training posture).

    Args:
        experience: a SOM, a PostureDatabase or any `Experience`.
        postures: (m, 22) rad, the postures it was made from.
        types: (m,) their grasp types (`grasp_types_of`).

    Returns:
        (k,) str, one type per row of `experience.references`.
    """
    data, types = np.asarray(postures, dtype=float), np.asarray(types, dtype=str)
    if data.ndim != 2 or data.shape[1] != N_FINGER_JOINTS or types.shape != (len(data),) or not len(data):
        raise InvalidInput(f"postures must be (m, {N_FINGER_JOINTS}) with one type each (m >= 1), got shapes "
                           f"{data.shape} and {types.shape}")
    return types[nearest_rows(experience.references, data)]


class SupportRules(Protocol):
    """What the probe reads of the trials' judging rules (`judging.stages.JudgingRules` has them)."""

    @property
    def release_seconds(self) -> float:
        """s the support's release fades over (0: let go at once)."""

    @property
    def support_stiffness(self) -> float:
        """N/m of the spring that holds the object while the hand closes."""

    @property
    def support_damping(self) -> float:
        """N s/m of that spring's damper."""


class RestartingController(Protocol):
    """What the probe reads and drives of a controller that grasps again (`BatchController` is one)."""

    done: np.ndarray  # (n,) bool
    attempt: np.ndarray  # (n,) int, each world's attempt, 1 the first

    def restart(self, worlds: np.ndarray, joints: np.ndarray, segment_forces: np.ndarray) -> None:
        """Grasp again in `worlds` from the sensed joints (m, 22) rad and segment forces (m, segments) N."""


class LiftProbe:
    """The regrasp's stage between a grasp the controller calls done and the judge, over N worlds (see the module
    doc): with attempts left, the grasp is lifted (the support off, the object's weight along `PROBE_DIRECTION`)
    for `probe_seconds`; one whose touch fails (or is gone, which ends the probe early) is grasped again
    (`restart`) from where the object lies, on the support, gravity off; one that passes, or the last attempt,
    goes to the judge.

    Where the trials' judging fades the support's release (`JudgingRules.release_seconds`: the planned-grasp
    benchmark's), the probe fades it the same way before it lifts: a support let go at once threw squeezed objects
    into the fingers; and a grasp that passes goes to the judge as the judge expects it, gravity off and the object
    on its support caught where it lies (the judge's fade re-engaged the spring at its old anchor and yanked the
    object into the fingers: on the box's first plan, 2 cm off, two of three grasps that held with one attempt
    faulted so, a contact 7-14 mm deep).

    Args:
        regrasp: the attempts and the probe's rules.
        worlds: the trials' worlds (`sim.worlds.Worlds`).
        controller: their controller (its `done`, `attempt` and `restart`).
        rules: the trials' judging rules (`stages.JudgingRules`: `release_seconds`, `support_stiffness`,
            `support_damping`), None: the support let go at once.

    Attributes:
        failure: (n, 22 + segments): the joints (rad) and segment forces (N) sensed when each world's first attempt
            failed its probe (NaN rows: none failed).
    """

    def __init__(self, regrasp: Regrasp, worlds: Worlds, controller: RestartingController,
                 rules: SupportRules | None = None):
        n = worlds.n
        self.regrasp, self.worlds, self.controller, self.rules = regrasp, worlds, controller, rules
        self._fading = np.full(n, np.nan)  # s: when each world's support began fading (NaN: none fades)
        self._probing = np.full(n, np.nan)  # s: when each world's probe began (NaN: none runs)
        self._probed = np.zeros(n, dtype=bool)  # passed the probe: the judge's turn
        self.failure = np.full((n, N_FINGER_JOINTS + len(SEGMENTS)), np.nan)

    def ready(self, clock: float) -> tuple[np.ndarray, np.ndarray]:
        """One look at the worlds, every control period.

        Args:
            clock: s since the trials began.

        Returns:
            ((n,) bool: the worlds whose grasp goes to the judge now, the indices of those grasping again from now).
        """
        controller, worlds, regrasp = self.controller, self.worlds, self.regrasp
        done = np.asarray(controller.done, dtype=np.bool_)
        again = np.zeros(0, dtype=int)
        if regrasp.attempts == 1:
            return done, again
        probing, probed = self._probing, self._probed
        last = np.asarray(controller.attempt) >= regrasp.attempts
        begin = np.flatnonzero(done & ~last & ~probed & np.isnan(probing) & np.isnan(self._fading))
        fade = 0.0 if self.rules is None else self.rules.release_seconds
        self._fading[begin] = clock
        fading = np.flatnonzero(~np.isnan(self._fading))
        left = 1.0 - (clock - self._fading[fading]) / fade if fade else np.zeros(len(fading))
        if np.any(left > 1e-9) and self.rules is not None:  # the support weakens to nothing first, the hand acting on
            soft = fading[left > 1e-9]
            worlds.soften(soft, self.rules.support_stiffness * left[left > 1e-9],
                          self.rules.support_damping * left[left > 1e-9])
        begin = fading[left <= 1e-9]
        self._fading[begin] = np.nan
        if len(begin):  # support off, the object's weight on: only touch is watched from here
            worlds.release(begin)
            worlds.set_gravity(begin, np.tile(GRAVITY * PROBE_DIRECTION, (len(begin), 1)))
            probing[begin] = clock
        watched = np.flatnonzero(~np.isnan(probing))
        if len(watched):
            forces = worlds.segment_forces(watched)
            over = clock - probing[watched] >= regrasp.probe_seconds - 1e-9
            failing = np.where(over, regrasp.failing(forces), ~(forces > 0).any(axis=1))  # gone: ends early
            passed = watched[~failing & over]
            again = watched[failing]
            probed[passed], probing[passed] = True, np.nan
            if len(passed) and self.rules is not None:  # the judge's start as it expects it: gravity off, the object
                worlds.set_gravity(passed, np.zeros((len(passed), 3)))  # on its support, caught where it lies (its
                worlds.support(passed, self.rules.support_stiffness, self.rules.support_damping)  # fade's anchor)
            if len(again):  # gravity off, the support on where the object lies, the next attempt from there
                worlds.set_gravity(again, np.zeros((len(again), 3)))
                worlds.support(again, regrasp.support_stiffness, regrasp.support_damping)
                joints = worlds.joints(again)
                first = again[np.isnan(self.failure[again, 0])]
                self.failure[first] = np.column_stack([joints, forces[failing]])[np.isin(again, first)]
                controller.restart(again, joints, forces[failing])
                probing[again] = np.nan
                done = np.asarray(controller.done, dtype=np.bool_)
        return done & (probed | (np.asarray(controller.attempt) >= regrasp.attempts)), again
