"""The grasp controller as an array program over N trials at once.

`BatchController` makes exactly the decisions of `controller.GraspController` (the readable
reference, which documents the four phases) for N worlds in one call: the state of every world
lives in arrays, the best matches of all worlds that match in a cycle are one batched masked
search with a mask per world, and every arithmetic step is the reference's, in the same order,
so the targets agree bit for bit (tests/test_batch.py runs both on the same readings, cycle by
cycle). All worlds start together and share the clock; a world that is done keeps its target.
"""

from __future__ import annotations

import math

import numpy as np

from ..base.errors import InvalidInput
from ..manifold.experience import Experience
from ..sim.hand import FINGERS, N_FINGER_JOINTS, SEGMENTS
from ..sim.posture import SEGMENT_FINGER, pcp_masks
from .controller import FINGER_OF_JOINT, ControllerParams, GraspController, palm_shift, squeezed

_JOINT_FINGER = np.array([FINGERS.index(f) for f in FINGER_OF_JOINT])
#: (5, 22): which joints belong to which finger
_FINGER_JOINTS = _JOINT_FINGER[None, :] == np.arange(len(FINGERS))[:, None]

#: the grasp phase of each world, as `GraspController.phase` names it
PHASES = ("A", "B", "C", "done")


def row_norms(rows: np.ndarray) -> np.ndarray:
    """Euclidean norm of every row, rounded exactly as `np.linalg.norm` of that row alone (a dot product)."""
    return np.sqrt((rows[:, None, :] @ rows[:, :, None])[:, 0, 0])


def _rms(differences: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """RMS of every row over its masked columns, summed in the order `np.mean` of that row's masked
    entries alone would sum them (rows that share a mask are reduced together)."""
    rms = np.empty(len(differences))
    patterns, which = np.unique(masks, axis=0, return_inverse=True)
    for k, pattern in enumerate(patterns):
        rows = which.ravel() == k
        rms[rows] = np.sqrt(np.mean(differences[rows][:, pattern] ** 2, axis=1))
    return rms


class BatchController:
    """`GraspController` for N worlds; call `step` once per control period with every world's readings."""

    def __init__(self, n: int, experience: Experience | None = None, params: ControllerParams | None = None,
                 initial_posture: np.ndarray | None = None, preshape: np.ndarray | None = None):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidInput(f"n (worlds) must be a positive integer, got {n!r}")
        # the reference validates the arguments and computes the per-finger constants once
        reference = GraspController(experience, params, initial_posture, preshape)
        self.n = int(n)
        self.experience, self.params = reference.experience, reference.params
        self.initial, self.preshape = reference.initial, reference.preshape
        self.plan = reference.plan
        self._steered_finger = np.isin(np.array(FINGERS), self.params.steered_fingers)
        self.reset()

    def reset(self) -> None:
        """Start a new grasp in every world."""
        n, fingers = self.n, len(FINGERS)
        self.time = 0.0
        self.phase = np.zeros(n, dtype=np.int8)  # index into PHASES
        self.done = np.zeros(n, dtype=bool)
        self.time_to_grasp = np.full(n, np.nan)
        self.matches = np.zeros(n, dtype=int)
        self.winners: list[list[int]] = [[] for _ in range(n)]  # per world: `GraspController.winners`
        self._closure = np.zeros((n, fingers))
        self._held = np.zeros((n, fingers), dtype=bool)
        self._held_posture = np.zeros((n, N_FINGER_JOINTS))
        self._lost = np.zeros((n, fingers), dtype=bool)
        self._lost_posture = np.zeros((n, N_FINGER_JOINTS))
        self._last_touch = np.full((n, fingers), -np.inf)
        self._base = np.tile(self.initial, (n, 1))
        self._target = np.tile(self.initial, (n, 1))
        self._touching = np.zeros((n, fingers), dtype=bool)
        self._stable_since = np.zeros(n)
        self._recalled = np.zeros(n, dtype=bool)
        self.palm_offset = np.zeros((n, 3))  # m, palm frame: how far each world's palm has moved (reach)
        self._palm_goal = np.zeros((n, 3))
        self._reaching = np.zeros(n, dtype=bool)

    def __repr__(self) -> str:
        experience = "none" if self.experience is None else type(self.experience).__name__
        return f"BatchController({self.n} worlds, experience {experience}, {int(self.done.sum())} done)"

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control cycle of every world: sensed joints (N, 22) and segment forces (N, len(SEGMENTS))
        -> joint targets (N, 22)."""
        joints = np.asarray(joints, dtype=float)
        forces = np.asarray(segment_forces, dtype=float)
        if joints.shape != (self.n, N_FINGER_JOINTS) or not np.all(np.isfinite(joints)):
            raise InvalidInput(f"joints must be ({self.n}, {N_FINGER_JOINTS}) finite angles, got shape {joints.shape}")
        if forces.shape != (self.n, len(SEGMENTS)) or not np.all(np.isfinite(forces)):
            raise InvalidInput(f"segment_forces must be ({self.n}, {len(SEGMENTS)}) finite forces in SEGMENTS order, "
                             f"got shape {forces.shape}")
        p, dt = self.params, self.params.control_period
        self.time += dt
        touching_segments = forces > 0.0
        any_touch = touching_segments.any(axis=1)
        touching = np.zeros_like(self._touching)
        for finger in range(len(FINGERS)):
            touching[:, finger] = touching_segments[:, SEGMENT_FINGER == FINGERS[finger]].any(axis=1)
        waiting = ~self.done & (self.time <= p.preshape_time) & ~any_touch  # phase A
        self._target[waiting] = self.initial
        act = ~self.done & ~waiting
        if not act.any():
            return self._target.copy()

        self.phase[act] = np.where(any_touch[act], PHASES.index("C"), PHASES.index("B"))
        self._match(act, joints, touching_segments, any_touch)
        touched = act[:, None] & touching & ~self._reaching[:, None]  # while the palm moves, fingers follow the recall
        self._last_touch[touched] = self.time
        newly_held = touched & ~self._held
        self._held = self._held | newly_held
        for finger in range(len(FINGERS)):  # a finger remembers the joints it first touched with
            worlds = newly_held[:, finger]
            self._held_posture[worlds] = np.where(_FINGER_JOINTS[finger], joints[worlds], self._held_posture[worlds])
        self._lost &= ~touched
        released = act[:, None] & self._held & (self.time - self._last_touch > p.release_time)
        for finger in range(len(FINGERS)):  # lost its contact: close on from where it held
            worlds = released[:, finger]
            of = _FINGER_JOINTS[finger]
            self._lost_posture[worlds] = np.where(of, self._held_posture[worlds], self._lost_posture[worlds])
        self._lost |= released
        self._held &= ~released
        self._closure[released] = 0.0

        target = self._target.copy()
        squeezed = self._squeezed(self._held_posture)
        for finger in range(len(FINGERS)):
            of = _FINGER_JOINTS[finger]
            held = act & self._held[:, finger]
            target[np.ix_(held, of)] = squeezed[np.ix_(held, of)]
            free = act & ~self._held[:, finger]
            if not free.any():
                continue
            closure = np.minimum(1.0, self._closure[free, finger] + p.closing_rate * dt)
            self._closure[free, finger] = closure
            lost = self._lost[free, finger]
            base = np.where(lost[:, None], self._lost_posture[np.ix_(free, of)], self._base[np.ix_(free, of)])
            goal = base + closure[:, None] * (self.plan.closed[of] - base)
            previous = self._target[np.ix_(free, of)]
            move = goal - previous
            limit = p.follow_speed * self.plan.speed[finger] * dt
            distance = row_norms(move)
            scale = np.where(distance <= limit, 1.0, limit / np.where(distance > 0, distance, 1.0))
            target[np.ix_(free, of)] = previous + move * scale[:, None]  # move * 1.0 is move, bit for bit
        self._target[act] = np.clip(target[act], self.plan.limits[:, 0], self.plan.limits[:, 1])
        moving = np.flatnonzero(act & self._reaching)  # palms on their way to the recalled grasps' places
        if len(moving):
            move = self._palm_goal[moving] - self.palm_offset[moving]
            limit = p.reach_speed * dt
            distance = row_norms(move)
            scale = np.where(distance <= limit, 1.0, limit / np.where(distance > 0, distance, 1.0))
            self.palm_offset[moving] = self.palm_offset[moving] + move * scale[:, None]
            self._reaching[moving] = np.any(self.palm_offset[moving] != self._palm_goal[moving], axis=1)

        changed = act & np.any(touching != self._touching, axis=1)
        self._touching[changed] = touching[changed]
        self._stable_since[changed] = self.time
        settled = np.all(touching | (self._closure >= 1.0), axis=1)
        finished = act & ((touching.any(axis=1) & settled & ~self._reaching
                           & (self.time - self._stable_since >= p.stable_time))
                          | (self.time >= p.timeout))
        self.done |= finished
        self.phase[finished] = PHASES.index("done")
        self.time_to_grasp[finished] = self.time
        return self._target.copy()

    def _squeezed(self, postures: np.ndarray) -> np.ndarray:
        """`controller.squeezed` of every row."""
        return squeezed(postures, self.params.squeeze)

    def _match(self, act: np.ndarray, joints: np.ndarray, touching_segments: np.ndarray,
               any_touch: np.ndarray) -> None:
        """Phase B / C of every acting world: the best-matching experienced posture becomes the
        base of the steered fingers (`GraspController._match`)."""
        p = self.params
        if self.preshape is not None:
            self._base[act & ~any_touch] = self.preshape
            candidates = act & any_touch
        else:
            candidates = act.copy()
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
        match = self.experience.references[winners]
        if math.isfinite(p.max_match_distance):
            trusted = _rms(match - joints[worlds], masks[worlds]) <= p.max_match_distance
            worlds, match, winners = worlds[trusted], match[trusted], winners[trusted]
        self.matches[worlds] += 1
        for world, winner in zip(worlds, winners):
            self.winners[world].append(int(winner))
        self._base[worlds] = np.where(self.plan.steered, match, self._base[worlds])
        if p.restart_closure or p.reach > 0:  # the first trusted match after a contact restarts the closure
            restart = worlds[any_touch[worlds] & ~self._recalled[worlds]]
            self._recalled[restart] = True
            touching = np.column_stack([touching_segments[np.ix_(restart, SEGMENT_FINGER == f)].any(axis=1)
                                        for f in FINGERS]).reshape(len(restart), len(FINGERS))
            if p.reach > 0:
                for world, row in zip(restart, match[np.isin(worlds, restart)]):
                    self._start_reach(world, joints[world], row, touching_segments[world])
                reset = np.broadcast_to(self._steered_finger, touching.shape)
            else:
                reset = ~touching & ~self._held[restart] & self._steered_finger
            self._closure[restart] = np.where(reset, 0.0, self._closure[restart])

    def _start_reach(self, world: int, joints: np.ndarray, match: np.ndarray, touching: np.ndarray) -> None:
        """`GraspController._start_reach` for one world: the palm's way to the recalled grasp."""
        rows = np.flatnonzero(touching & (SEGMENT_FINGER != ""))
        if not len(rows):
            return
        self._palm_goal[world] = palm_shift(self.plan.kinematics, joints, match, rows, self.params.reach)
        self._reaching[world] = bool(np.any(self._palm_goal[world] != self.palm_offset[world]))
        self._held[world] = False
        self._lost[world] = False
