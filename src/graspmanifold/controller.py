"""The four-phase tactile grasp controller (paper Section 2, Fig. 2).

The controller runs an action-perception loop at a fixed rate. Each cycle it receives the 22 joint
angles and the normal force on each tactile segment (what a tactile skin reports), and returns the
22 joint targets. It never sees the object: not its shape, not its pose, not the contact points.

    A  preshape: actuate the initial open posture;
    B  close until the first contact. With an experience base, the closing starts from the
       experienced grasp posture nearest to the current hand posture (all 22 joints compared),
       re-matched every cycle as the hand closes, so the hand preshapes towards known grasps;
    C  once anything touches: every cycle form the Partial Contact Posture (the joints the contacts
       make reliable, Eq. 1), find the best-matching experienced posture with the masked search
       (Eq. 2 / Eq. 4) and steer the free fingers towards it, re-matching as contacts appear; a free
       finger that has reached its matched posture without touching, or is stuck short of it (say,
       under another finger), closes on from there (D);
    D  embedded in B and C: a generic closing heuristic. A finger not yet touching keeps closing
       from its current base posture along the hand's closing synergy (closed hand minus open hand);
       a touching finger holds where it touched and squeezes gently, and if it loses the contact it
       closes on from where it held (the experience no longer steers it back); the grasp ends when
       the set of touching fingers has been stable for a while (and every finger touches or is fully
       closed) or at the timeout.

Without an experience base (`experience=None`) the base posture is the open hand, so phases A and D
alone remain: the purely tactile-driven baseline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .experience import Experience
from .hand import FINGER_JOINTS, FINGERS, SEGMENTS, finger_limits, finger_of
from .posture import closed_posture, open_posture, pcp_mask, validate_posture

_FINGER_OF_JOINT = np.array([finger_of(j) for j in FINGER_JOINTS])
_FINGER_OF_SEGMENT = [finger_of(s) for s in SEGMENTS]
#: joints that flex a finger around an object (the squeeze acts on these)
_FLEXION = np.array([j[-1] in "123" and j not in ("THJ3",) for j in FINGER_JOINTS])


@dataclass(frozen=True)
class ControllerParams:
    """Timing and gains of the controller (s, rad, rad/s)."""

    control_period: float = 0.02  # 50 Hz
    preshape_time: float = 0.3  # phase A
    closing_rate: float = 0.8  # closure per second of a free finger (1 = fully closed)
    squeeze: float = 0.15  # rad beyond the touching posture, on the flexion joints
    release_time: float = 0.1  # a holding finger that lost its contact this long closes on
    arrive_tolerance: float = 0.1  # rad: a free finger this close to its matched posture closes further
    stall_time: float = 0.1  # s: a free finger blocked this long short of its matched posture closes further too
    stall_speed: float = 0.1  # rad/s: below this joint speed a finger counts as not moving
    stable_time: float = 0.3  # the touching set must stay unchanged this long to finish
    timeout: float = 3.0  # s after the start


def check_experience(experience: object) -> Experience | None:
    if experience is None:
        return None
    if not isinstance(experience, Experience):
        raise ValueError(f"experience must be None, a PostureDatabase or a SOM, got {type(experience).__name__}")
    if experience.dim != len(FINGER_JOINTS):
        raise ValueError(f"experience must hold {len(FINGER_JOINTS)}-joint postures, it has dim {experience.dim}")
    return experience


class GraspController:
    """Tactile grasp controller; call `step` once per control period."""

    def __init__(self, experience: Experience | None = None, params: ControllerParams | None = None,
                 initial_posture: np.ndarray | None = None):
        self.experience = check_experience(experience)
        self.params = params or ControllerParams()
        self.initial = validate_posture(open_posture() if initial_posture is None else initial_posture,
                                        name="initial_posture", check_limits=True)
        self._closed = closed_posture()
        self._closing = self._closed - self.initial  # the closing synergy: open hand -> closed hand
        self._limits = finger_limits()
        self.reset()

    def reset(self) -> None:
        """Start a new grasp."""
        self.time = 0.0
        self.phase = "A"
        self.done = False
        self.time_to_grasp: float | None = None
        self.matches = 0  # best-match queries made
        self._closure = dict.fromkeys(FINGERS, 0.0)
        self._held: dict[str, np.ndarray] = {}
        self._lost: dict[str, np.ndarray] = {}  # fingers that lost their contact: the posture they held
        self._last_touch = dict.fromkeys(FINGERS, -np.inf)
        self._moving_at = dict.fromkeys(FINGERS, 0.0)
        self._previous: np.ndarray | None = None
        self._base = self.initial.copy()
        self._target = self.initial.copy()
        self._touching: frozenset[str] = frozenset()
        self._stable_since = 0.0

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control cycle: sensed joint angles (22,) and normal force per segment -> joint targets (22,)."""
        joints = validate_posture(joints, name="joints")
        forces = np.asarray(segment_forces, dtype=float)
        if forces.shape != (len(SEGMENTS),) or not np.all(np.isfinite(forces)):
            raise ValueError(f"segment_forces must be {len(SEGMENTS)} finite forces in SEGMENTS order")
        dt = self.params.control_period
        self.time += dt
        if self.done:
            return self._target.copy()
        if self._previous is not None:
            speed = np.abs(joints - self._previous) / dt
            for finger in FINGERS:
                if np.max(speed[_FINGER_OF_JOINT == finger]) > self.params.stall_speed:
                    self._moving_at[finger] = self.time
        self._previous = joints
        touching_segments = [s for s, f in zip(SEGMENTS, forces) if f > 0.0]
        touching = frozenset(f for f in map(finger_of, touching_segments) if f is not None)
        if self.time <= self.params.preshape_time and not touching_segments:
            self._target = self.initial.copy()
            return self._target.copy()

        entering_c = self.phase != "C" and bool(touching_segments)
        self.phase = "C" if touching_segments else "B"
        if self.experience is not None and entering_c:
            self._closure = dict.fromkeys(FINGERS, 0.0)  # steer to the matched posture first, then close on
        if self.experience is not None and (touching or self.matches == 0):
            # B: one match of the whole hand posture gives the preshape; C: re-match the PCP each cycle
            self._base = self.experience.complete(joints, pcp_mask(touching_segments) if touching else None)
            self.matches += 1
        for finger in touching:
            self._last_touch[finger] = self.time
            self._held.setdefault(finger, joints.copy())
            self._lost.pop(finger, None)
        for finger in [f for f in self._held if self.time - self._last_touch[f] > self.params.release_time]:
            self._lost[finger] = self._held.pop(finger)  # lost its contact: close on from where it held
            self._closure[finger] = 0.0
        target = np.empty(len(FINGER_JOINTS))
        for finger in FINGERS:
            joints_of = _FINGER_OF_JOINT == finger
            if finger in self._held:  # D: hold where it touched and squeeze
                held = self._held[finger][joints_of]
                push = np.sign(self._closed[joints_of] - held) * _FLEXION[joints_of]
                target[joints_of] = held + self.params.squeeze * push
            else:  # D: keep closing from the base posture
                base = self._lost[finger][joints_of] if finger in self._lost else self._base[joints_of]
                arrived = np.max(np.abs(joints[joints_of] - self._target[joints_of])) < self.params.arrive_tolerance
                stalled = self.time - self._moving_at[finger] >= self.params.stall_time
                if self.phase == "B" or self.experience is None or finger in self._lost or arrived or stalled:
                    self._closure[finger] = min(1.0, self._closure[finger] + self.params.closing_rate * dt)
                target[joints_of] = base + self._closure[finger] * self._closing[joints_of]
        self._target = np.clip(target, self._limits[:, 0], self._limits[:, 1])

        if touching != self._touching:
            self._touching, self._stable_since = touching, self.time
        settled = all(f in touching or self._closure[f] >= 1.0 for f in FINGERS)
        if (touching and settled and self.time - self._stable_since >= self.params.stable_time) \
                or self.time >= self.params.timeout:
            self.done = True
            self.phase = "done"
            self.time_to_grasp = self.time
        return self._target.copy()
