"""The four-phase tactile grasp controller (paper Section 2, Fig. 2).

The controller runs an action-perception loop at a fixed rate. Each cycle it receives the 22 joint
angles and the normal force on each tactile segment (what a tactile skin reports), and returns the
22 joint targets. It never sees the object: not its shape, not its pose, not the contact points.

    A  preshape: actuate the initial open posture;
    B  close until the first contact, influenced by experience: every cycle the whole current
       posture is matched against the experience base, and the match becomes the fingers' base;
    C  once anything touches: every cycle form the Partial Contact Posture (the joints the contacts
       make reliable, Eq. 1), find the best-matching experienced posture with the masked search
       (Eq. 2 / Eq. 4) and make it the base of the free fingers;
    D  embedded in B and C: the generic closing heuristic. Every free finger has a closure c that
       grows at `closing_rate` per second from the moment B starts and is never reset or held
       back; its goal is its base posture closed by c towards the closed hand,
       goal = base + c (closed - base). Without experience the base is the open hand, so the goal is
       the plain heuristic's open + c (closed - open). The finger's target follows the goal at
       most `follow_speed` times the heuristic's joint speed, so a new match moves it smoothly
       and it meets the object on its way instead of jumping past it. A touching finger holds
       where it touched and squeezes gently (`squeeze` on its flexion joints); if it loses the
       contact it closes on from where it held. The grasp ends when the set of touching fingers
       has been stable for `stable_time` and every finger touches or is fully closed, or at the
       timeout.

Closing from the matched posture towards the closed hand (not along the global open-to-closed
synergy from it) keeps the closing in the direction the experienced grasp already faces: a matched
thumb that is rotated under the palm closes to the closed thumb, not further under the palm.

Every part of the experience mechanism can be switched off for ablations (`ControllerParams`):
phase B's preshape (`experience_preshape`), phase C's steering (`experience_steering`; off, the
free fingers keep the last phase-B match), which fingers experience steers (`steered_fingers`),
which of their joints (`steered_joints`: all, or only the spread joints, leaving flexion to the
closing heuristic so that experience chooses where a finger closes and touch decides how far), and
match confidence (`max_match_distance`: a best match farther from the sensed joints than this RMS
distance over the matched joints is ignored and the base stays as it was). The default of 0.2 rad
(about 11 degrees per matched joint) trusts a recall only when the experience holds a grasp that
agrees with what the hand senses: in phase B the open hand is farther than that from every
experienced grasp, so experience takes over only once the closing hand comes near one. It was
chosen from 0.1, 0.2 and no limit on the paper grid (`docs/experience_study_paper_grids.md` reports the
ablation with no limit).

Beyond the paper, `restart_closure` gives the recalled grasp real weight: the first trusted match
after the first contact (the contacts select the grasp type) restarts the closure of every free
steered finger at 0, so the finger first moves onto the recalled posture and only then closes on
from it; without it a finger's closure has already grown while the hand closed, and the recall
only shifts a goal that lies most of the way to the closed hand.

A further extension, also off by default, lets a recall move the palm (`reach`, in m): at that first
trusted match after a contact, the touching segments' places now (from the hand's own kinematics,
`hand.SegmentKinematics`) are compared with where the recalled grasp would put them; the palm moves
by their mean difference, at most `reach` and at `reach_speed`, so that the object comes to lie where
the recalled grasp held it, while every finger (the touching ones too) goes to the recalled posture
from a restarted closure. Once the palm has arrived, touching fingers hold and squeeze as before. The
palm moves by the arm (the trial moves the hand's mount), not by the wrist joints: the experience's
grasps all have the wrist straight. The offset of the palm from its start, in the palm frame, is
`GraspController.palm_offset`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base.errors import InvalidInput
from ..manifold.experience import Experience, check_experience
from ..sim.hand import FINGER_JOINTS, FINGERS, PHYSICS_TIMESTEP, SEGMENTS, SegmentKinematics, finger_limits, finger_of
from ..sim.posture import closed_posture, open_posture, pcp_mask, validate_posture

#: the finger each of the 22 finger joints belongs to (FINGER_JOINTS order)
FINGER_OF_JOINT = np.array([finger_of(j) for j in FINGER_JOINTS])
_JOINTS_OF = {f: FINGER_OF_JOINT == f for f in FINGERS}
#: joints that flex a finger around an object (the squeeze acts on these)
FLEXION = np.array([j[-1] in "123" and j not in ("THJ3",) for j in FINGER_JOINTS])


#: which joints of a steered finger take the matched posture: all, or only the spread joints (finger
#: abduction, little-finger cupping, thumb rotation, abduction and roll); flexion is then left to the
#: closing heuristic, which stops at the contact
STEERED_JOINTS = {"all": np.ones(len(FINGER_JOINTS), dtype=bool), "spread": ~FLEXION}


@dataclass(frozen=True)
class ControllerParams:
    """Timing, gains and switches of the controller (s, rad, rad/s)."""

    control_period: float = 0.02  # 50 Hz
    preshape_time: float = 0.3  # phase A
    closing_rate: float = 0.8  # closure per second of a free finger (1 = fully closed)
    follow_speed: float = 2.0  # a free finger's target moves at most this many times the heuristic's speed
    squeeze: float = 0.15  # rad beyond the touching posture, on the flexion joints
    release_time: float = 0.1  # a holding finger that lost its contact this long closes on
    stable_time: float = 0.3  # the touching set must stay unchanged this long to finish
    timeout: float = 3.0  # s after the start
    experience_preshape: bool = True  # phase B: match the whole posture every cycle
    experience_steering: bool = True  # phase C: match the Partial Contact Posture every cycle
    steered_fingers: tuple[str, ...] = FINGERS  # fingers whose base the experience sets
    steered_joints: str = "all"  # 'all', or 'spread': only the joints that do not flex the finger
    max_match_distance: float = 0.2  # rad, RMS over the matched joints; farther matches are ignored (inf: none)
    restart_closure: bool = False  # the first trusted match after a contact restarts the free fingers' closure
    reach: float = 0.0  # m: that match may also move the palm by up to this much (0: the palm stays)
    reach_speed: float = 0.1  # m/s, how fast the palm moves then

    def __post_init__(self) -> None:
        for name in ("control_period", "closing_rate", "follow_speed", "timeout", "reach_speed"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInput(f"ControllerParams.{name} must be a positive finite number, got {value!r}")
        steps = self.control_period / PHYSICS_TIMESTEP
        if isinstance(self.control_period, bool) or round(steps) < 1 or abs(steps - round(steps)) > 1e-6:
            raise InvalidInput(f"ControllerParams.control_period must be a whole number of {PHYSICS_TIMESTEP} s physics "
                             f"steps (0.002, 0.004, ..., 0.02), got {self.control_period!r}: another period would "
                             "make the controller's clock run apart from the physics")
        for name in ("preshape_time", "squeeze", "release_time", "stable_time", "reach"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise InvalidInput(f"ControllerParams.{name} must be a finite number >= 0, got {value!r}")
        if not (isinstance(self.max_match_distance, (int, float)) and self.max_match_distance > 0):
            raise InvalidInput(f"ControllerParams.max_match_distance must be > 0 (inf: trust every match), "
                             f"got {self.max_match_distance!r}")
        if self.steered_joints not in STEERED_JOINTS:
            raise InvalidInput(f"ControllerParams.steered_joints must be one of {tuple(STEERED_JOINTS)}, "
                             f"got {self.steered_joints!r}")
        if not isinstance(self.restart_closure, bool):
            raise InvalidInput(f"ControllerParams.restart_closure must be True or False, got {self.restart_closure!r}")
        for name in ("restart_closure", "reach"):
            if getattr(self, name) and self.steered_joints != "all":
                raise InvalidInput(f"ControllerParams.{name} needs steered_joints='all': with only the spread joints "
                                 "recalled, a restarted closure would open the fingers' flexion again")
        unknown = [f for f in self.steered_fingers if f not in FINGERS]
        if unknown:
            raise InvalidInput(f"ControllerParams.steered_fingers has unknown fingers {unknown}; expected some of {FINGERS}")


def squeezed(posture: np.ndarray, amount: float) -> np.ndarray:
    """The posture with its flexion joints pushed further towards the closed hand: the target that
    makes fingers touching an object press on it. Both controllers and the generator's verifier squeeze
    with it.

    Args:
        posture: finger postures (..., 22), rad (one, or one per row).
        amount: how far to push each flexion joint (`FLEXION`), rad.

    Returns:
        The squeezed postures (..., 22), rad, clipped to the joint ranges.
    """
    closed = closed_posture()
    target = posture + amount * np.sign(closed - posture) * FLEXION
    limits = finger_limits()
    return np.clip(target, limits[:, 0], limits[:, 1])


def palm_shift(kinematics: SegmentKinematics, joints: np.ndarray, recalled: np.ndarray, touching: np.ndarray,
               reach: float) -> np.ndarray:
    """How far the palm should move so that the object comes to lie where a recalled grasp holds it.

    Args:
        kinematics: the hand's segment kinematics.
        joints: the sensed joint angles (22,), radians.
        recalled: the recalled grasp posture (22,), radians.
        touching: indices into SEGMENTS of the finger segments that touch the object.
        reach: the longest shift allowed (m).

    Returns:
        The shift (3,) in m, palm frame: the mean difference between where the touching segments are now
        and where the recalled posture puts them, shortened to at most `reach`.
    """
    now, then = kinematics.positions(joints), kinematics.positions(recalled)
    shift = np.mean(now[touching] - then[touching], axis=0)
    length = float(np.linalg.norm(shift))
    return shift if length <= reach else shift * (reach / length)


@dataclass(frozen=True)
class ClosingPlan:
    """What a controller derives once from its parameters and open posture: the contract that
    `GraspController` and its array twin `BatchController` share.

    Attributes:
        closed: the closed hand (22,), rad: where the closing heuristic drives each finger.
        limits: the finger joints' ranges (22, 2), rad.
        speed: each finger's joint speed (5,), rad/s, FINGERS order: the open-to-closed synergy at `closing_rate`.
        steered: which of the 22 joints take a recalled posture (`steered_fingers`, `steered_joints`).
        kinematics: the segment kinematics for the palm's reach (None when `reach` is 0).
    """

    closed: np.ndarray
    limits: np.ndarray
    speed: np.ndarray
    steered: np.ndarray
    kinematics: SegmentKinematics | None


def closing_plan(params: ControllerParams, initial: np.ndarray) -> ClosingPlan:
    """The `ClosingPlan` of a controller.

    Args:
        params: the controller's parameters.
        initial: the open posture it starts from (22,), rad.

    Returns:
        The plan.
    """
    closed = closed_posture()
    speed = np.array([params.closing_rate * float(np.linalg.norm((closed - initial)[_JOINTS_OF[f]])) for f in FINGERS])
    steered = np.isin(FINGER_OF_JOINT, params.steered_fingers) & STEERED_JOINTS[params.steered_joints]
    return ClosingPlan(closed, finger_limits(), speed, steered, SegmentKinematics() if params.reach > 0 else None)


class GraspController:
    """Tactile grasp controller; call `step` once per control period."""

    def __init__(self, experience: Experience | None = None, params: ControllerParams | None = None,
                 initial_posture: np.ndarray | None = None, preshape: np.ndarray | None = None):
        """A controller ready for its first grasp.

        Args:
            experience: None (the plain tactile controller), a PostureDatabase, a SOM or a PostureSet.
            params: timing, gains and switches (`ControllerParams`).
            initial_posture: the open hand it starts from (22,), rad (default `open_posture()`).
            preshape: a fixed base posture for phase B, rad (a constant preshape) instead of matching the
                experience there; phase C still steers with the experience, if any.
        """
        self.experience = check_experience(experience)
        self.params = params or ControllerParams()
        self.initial = validate_posture(open_posture() if initial_posture is None else initial_posture,
                                        name="initial_posture", check_limits=True)
        self.preshape = None if preshape is None else validate_posture(preshape, name="preshape", check_limits=True)
        self.plan = closing_plan(self.params, self.initial)
        self.reset()

    def reset(self) -> None:
        """Start a new grasp."""
        self.time = 0.0
        self.phase = "A"
        self.done = False
        self.time_to_grasp: float | None = None
        self.matches = 0  # best-match queries used
        self.winners: list[int] = []  # the best match (a row of experience.references) of every query used, in order
        self._closure = dict.fromkeys(FINGERS, 0.0)
        self._held: dict[str, np.ndarray] = {}
        self._lost: dict[str, np.ndarray] = {}  # fingers that lost their contact: the posture they held
        self._last_touch = dict.fromkeys(FINGERS, -np.inf)
        self._base = self.initial.copy()
        self._target = self.initial.copy()
        self._touching: frozenset[str] = frozenset()
        self._stable_since = 0.0
        self._recalled = False  # a trusted match after a contact has restarted the closure (restart_closure)
        self.palm_offset = np.zeros(3)  # m, palm frame: how far the palm has moved from its start (reach)
        self._palm_goal = np.zeros(3)
        self._reaching = False  # the palm is on its way to the recalled grasp's place

    def __repr__(self) -> str:
        experience = "none" if self.experience is None else type(self.experience).__name__
        return (f"GraspController(experience {experience}, phase {self.phase}, {self.matches} matches"
                f"{', done' if self.done else ''})")

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
        p, dt = self.params, self.params.control_period
        self.time += dt
        if self.done:
            return self._target.copy()
        touching_segments = [s for s, f in zip(SEGMENTS, forces) if f > 0.0]
        touching = frozenset(f for f in map(finger_of, touching_segments) if f is not None)
        if self.time <= p.preshape_time and not touching_segments:
            self._target = self.initial.copy()
            return self._target.copy()

        self.phase = "C" if touching_segments else "B"
        self._match(joints, touching_segments)
        for finger in touching if not self._reaching else ():  # while the palm moves, every finger follows the recall
            self._last_touch[finger] = self.time
            self._held.setdefault(finger, joints.copy())
            self._lost.pop(finger, None)
        for finger in [f for f in self._held if self.time - self._last_touch[f] > p.release_time]:
            self._lost[finger] = self._held.pop(finger)  # lost its contact: close on from where it held
            self._closure[finger] = 0.0

        target = np.empty(len(FINGER_JOINTS))
        for index, finger in enumerate(FINGERS):
            of = _JOINTS_OF[finger]
            if finger in self._held:  # D: hold where it touched and squeeze
                target[of] = squeezed(self._held[finger], p.squeeze)[of]
                continue
            # D: close from the base towards the closed hand, following the goal at a bounded speed
            self._closure[finger] = min(1.0, self._closure[finger] + p.closing_rate * dt)
            base = self._lost[finger][of] if finger in self._lost else self._base[of]
            goal = base + self._closure[finger] * (self.plan.closed[of] - base)
            move = goal - self._target[of]
            limit = p.follow_speed * self.plan.speed[index] * dt
            distance = float(np.linalg.norm(move))
            target[of] = self._target[of] + (move if distance <= limit else move * (limit / distance))
        self._target = np.clip(target, self.plan.limits[:, 0], self.plan.limits[:, 1])
        if self._reaching:  # the palm moves towards the recalled grasp's place at reach_speed
            move = self._palm_goal - self.palm_offset
            limit = p.reach_speed * dt
            distance = float(np.linalg.norm(move))
            self.palm_offset = self.palm_offset + (move if distance <= limit else move * (limit / distance))
            self._reaching = bool(np.any(self.palm_offset != self._palm_goal))

        if touching != self._touching:
            self._touching, self._stable_since = touching, self.time
        settled = all(f in touching or self._closure[f] >= 1.0 for f in FINGERS)
        if (touching and settled and not self._reaching and self.time - self._stable_since >= p.stable_time) \
                or self.time >= p.timeout:
            self.done = True
            self.phase = "done"
            self.time_to_grasp = self.time
        return self._target.copy()

    def _match(self, joints: np.ndarray, touching_segments: list[str]) -> None:
        """Phase B / C: the best-matching experienced posture becomes the base of the steered fingers."""
        p = self.params
        if not touching_segments and self.preshape is not None:
            self._base = self.preshape.copy()
            return
        wanted = p.experience_steering if touching_segments else p.experience_preshape
        if self.experience is None or not wanted:
            return
        mask = pcp_mask(touching_segments) if touching_segments else np.ones(len(FINGER_JOINTS), dtype=bool)
        if not mask.any():  # a palm contact alone specifies no joint
            return
        winner = self.experience.best_match(joints, mask)
        match = self.experience.references[winner]
        if math.isfinite(p.max_match_distance):
            rms = float(np.sqrt(np.mean((match - joints)[mask] ** 2)))
            if rms > p.max_match_distance:
                return
        self.matches += 1
        self.winners.append(int(winner))
        self._base = np.where(self.plan.steered, match, self._base)
        if (p.restart_closure or p.reach > 0) and touching_segments and not self._recalled:
            self._recalled = True
            touching = {finger_of(s) for s in touching_segments}
            if p.reach > 0:
                self._start_reach(joints, match, touching_segments)
            for finger in p.steered_fingers:
                if p.reach > 0 or (finger not in touching and finger not in self._held):
                    self._closure[finger] = 0.0

    def _start_reach(self, joints: np.ndarray, match: np.ndarray, touching_segments: list[str]) -> None:
        """The palm's way to the recalled grasp (`palm_shift`); every finger lets go to follow the recall."""
        rows = [SEGMENTS.index(s) for s in touching_segments if finger_of(s) is not None]
        if not rows:
            return
        self._palm_goal = palm_shift(self.plan.kinematics, joints, match, np.array(rows), self.params.reach)
        self._reaching = bool(np.any(self._palm_goal != self.palm_offset))
        self._held.clear()
        self._lost.clear()
