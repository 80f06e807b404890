"""The grasp controller's state over N worlds: the arrays it keeps of every world (`GraspState`, what a recall rule
changes), which joints and tactile segments belong to which finger, and the two operations on them that the
controller and its recall rules share (`per_finger`, `bounded_step`)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..base.moved import REMOVED_IN
from ..sim.grip import row_norms
from ..sim.hand import FINGER_JOINTS, FINGERS, N_FINGER_JOINTS, finger_of
from ..sim.posture import SEGMENT_FINGER

#: the index into FINGERS of each finger joint's finger: `per_finger[:, JOINT_FINGER]` spreads (n, 5) over (n, 22)
JOINT_FINGER = np.array([FINGERS.index(finger_of(j)) for j in FINGER_JOINTS])
#: (5, 22): which joints belong to which finger (FINGERS order)
FINGER_JOINT_MASKS = JOINT_FINGER[None, :] == np.arange(len(FINGERS))[:, None]
#: (5, len(SEGMENTS)): which tactile segments belong to which finger (FINGERS order)
FINGER_SEGMENT_MASKS = SEGMENT_FINGER[None, :] == np.array(FINGERS)[:, None]


def per_finger(values: np.ndarray, masks: np.ndarray, reduce: Callable = np.all) -> np.ndarray:
    """`reduce` of each row's columns of each finger.

    Args:
        values: (n, columns) per joint or per segment.
        masks: (5, columns) which columns are each finger's (FINGERS order): `FINGER_JOINT_MASKS`,
            `FINGER_SEGMENT_MASKS`.
        reduce: how a finger's columns make one value (`np.all`, `np.any`, ...).

    Returns:
        (n, 5) one value per finger.
    """
    return np.column_stack([reduce(values[:, mask], axis=1) for mask in masks])


def bounded_step(current: np.ndarray, goal: np.ndarray, limit: float | np.ndarray) -> np.ndarray:
    """Each row moved from `current` towards `goal` by at most `limit` (Euclidean), landing on the goal exactly when
    it is within reach.

    Args:
        current: (n, k) where the rows are.
        goal: (n, k) where they go.
        limit: how far a row may move: one, or (n,) one per row.

    Returns:
        (n, k) the rows moved.
    """
    move = goal - current
    distance = row_norms(move)
    scale = np.where(distance <= limit, 1.0, limit / np.where(distance > 0, distance, 1.0))
    return current + move * scale[:, None]  # move * 1.0 is move, bit for bit


def _renamed(state: GraspState, old: str, new: str) -> np.ndarray:
    """A state array read by its name before 0.2, with a warning."""
    warnings.warn(f"GraspState.{old} is GraspState.{new} since 0.2; the old name goes in {REMOVED_IN}",
                  DeprecationWarning, stacklevel=3)
    return getattr(state, new)


@dataclass
class GraspState:
    """What the controller keeps of every world besides what it reports (`BatchController`'s public attributes):
    one row per world. `new` makes it for a first grasp; `restart` makes these worlds' rows anew for their next
    attempt. Recall rules (`RecallRule`) read and write it.

    Attributes:
        closure: (N, 5) each finger's closure c of phase D, 0 to 1.
        held, held_posture: (N, 5) the fingers that hold where they touched, and (N, 22) rad where that was.
        lost, lost_posture: (N, 5) the fingers that lost their contact, and (N, 22) rad where they had held.
        last_touch: (N, 5) s, when each finger last touched.
        base: (N, 22) rad, where a closing finger closes from.
        aim: (N, 22) rad, where it closes to (its closure 1): the closed hand, unless a recall rule set it.
        way: (N, 22) rad, each finger's way to its last recall, from where it set out (`ApproachRecall`; 0: none).
        pace: (N, 5) rad/s, how fast each finger on its way to a recall moves (the heuristic's speed unless a rule
            set it).
        target: (N, 22) rad, the targets of the last cycle.
        touching, stable_since: (N, 5) the fingers touching, and (N,) s since when that set is unchanged.
        closure_restarted: (N,) the blend's first trusted match after a contact has come (it restarted the
            closure).
        palm_goal, reaching: (N, 3) m, where each palm is going (`BlendRecall.reach`), and (N,) whether it is.
        touched_once: (N,) something has touched in this attempt (the palm's guarded approach is over).
        palm_aim: (N, 2) m, where the palm re-centres to in its plane (x, z; NaN: nowhere yet), `PalmSteering`.
        approaching, heading, recalled_posture: (N, 5) the fingers on their way to a recalled posture ('target'),
            its key (a reference row + 1, 0 for the preshape), and (N, 22) rad where it is.
        visited: the `visit` index of every (world, finger, key) recall a finger is done with.
        previous: (N, 22) rad, the joints sensed one cycle before (NaN: none yet).
        started: (N,) s, when each world's attempt began.
        squeezing: (N,) how far each world's squeeze has come, 0 to 1 (`ControllerParams.squeeze_time`).
        grip: (N,) rad, how far each world's holding fingers press, while grasping and once done: the squeeze, or
            regulated to `ControllerParams.grip_force`.
        preshapes: (N, 22) rad, each world's phase-B preshape (NaN rows: none).
        rows: the recall keys one finger can have (the experience's reference rows + 1, for the preshape).
    """

    closure: np.ndarray
    held: np.ndarray
    held_posture: np.ndarray
    lost: np.ndarray
    lost_posture: np.ndarray
    last_touch: np.ndarray
    base: np.ndarray
    aim: np.ndarray
    way: np.ndarray
    pace: np.ndarray
    target: np.ndarray
    touching: np.ndarray
    stable_since: np.ndarray
    closure_restarted: np.ndarray
    palm_goal: np.ndarray
    reaching: np.ndarray
    touched_once: np.ndarray
    palm_aim: np.ndarray
    approaching: np.ndarray
    heading: np.ndarray
    recalled_posture: np.ndarray
    visited: np.ndarray
    previous: np.ndarray
    started: np.ndarray
    squeezing: np.ndarray
    grip: np.ndarray
    preshapes: np.ndarray
    rows: int

    @property
    def recall(self) -> np.ndarray:
        """`recalled_posture` before 0.2 (a `DeprecationWarning`; the name goes in 0.3)."""
        return _renamed(self, "recall", "recalled_posture")

    @property
    def recalled(self) -> np.ndarray:
        """`closure_restarted` before 0.2 (a `DeprecationWarning`; the name goes in 0.3)."""
        return _renamed(self, "recalled", "closure_restarted")

    @classmethod
    def new(cls, n: int, initial: np.ndarray, closed: np.ndarray, speed: np.ndarray, preshape: np.ndarray | None,
            rows: int) -> GraspState:
        """The state of n worlds before their first grasp, the hand at `initial` (22,), rad, closing towards
        `closed` (22,), rad, each finger at `speed` (5,), rad/s; `preshape` (22,) rad or None, every world's; `rows`
        recall keys per finger."""
        fingers = len(FINGERS)
        return cls(closure=np.zeros((n, fingers)), held=np.zeros((n, fingers), dtype=bool),
                   held_posture=np.zeros((n, N_FINGER_JOINTS)), lost=np.zeros((n, fingers), dtype=bool),
                   lost_posture=np.zeros((n, N_FINGER_JOINTS)), last_touch=np.full((n, fingers), -np.inf),
                   base=np.tile(initial, (n, 1)), aim=np.tile(closed, (n, 1)),
                   way=np.zeros((n, N_FINGER_JOINTS)), pace=np.tile(speed, (n, 1)), target=np.tile(initial, (n, 1)),
                   touching=np.zeros((n, fingers), dtype=bool), stable_since=np.zeros(n),
                   closure_restarted=np.zeros(n, dtype=bool), palm_goal=np.zeros((n, 3)),
                   reaching=np.zeros(n, dtype=bool),
                   touched_once=np.zeros(n, dtype=bool), palm_aim=np.full((n, 2), np.nan),
                   approaching=np.zeros((n, fingers), dtype=bool), heading=np.zeros((n, fingers), dtype=np.int64),
                   recalled_posture=np.tile(initial, (n, 1)), visited=np.zeros(0, dtype=np.int64),
                   previous=np.full((n, N_FINGER_JOINTS), np.nan), started=np.zeros(n), squeezing=np.zeros(n),
                   grip=np.zeros(n),
                   preshapes=np.full((n, N_FINGER_JOINTS), np.nan) if preshape is None else np.tile(preshape, (n, 1)),
                   rows=rows)

    def restart(self, worlds: np.ndarray, initial: np.ndarray, closed: np.ndarray, speed: np.ndarray,
                palm_offset: np.ndarray, time: float) -> None:
        """These worlds' next attempt: their fingers free and open-based at `initial` closing towards `closed` at
        `speed`, no way kept, the palm staying where it is
        (`palm_offset`, (N, 3) m), their recalls forgotten, started at `time` s; the preshapes stay (the regrasp
        has set them)."""
        for array in (self.closure, self.held, self.lost, self.touching, self.closure_restarted, self.reaching,
                      self.touched_once, self.approaching, self.heading, self.squeezing):
            array[worlds] = 0
        self.last_touch[worlds] = -np.inf
        self.base[worlds] = self.recalled_posture[worlds] = initial
        self.aim[worlds], self.way[worlds], self.pace[worlds] = closed, 0.0, speed
        self.palm_goal[worlds] = palm_offset[worlds]
        self.palm_aim[worlds] = self.previous[worlds] = np.nan
        self.started[worlds] = time
        self.visited = self.visited[~np.isin(self.visited // (len(FINGERS) * self.rows), worlds)]

    def visit(self, worlds: np.ndarray, fingers: np.ndarray, keys: np.ndarray) -> np.ndarray:
        """The visit index of (world, finger, recall key), broadcast: one integer each, for `visited`."""
        return (worlds * len(FINGERS) + fingers) * self.rows + keys

    def was_visited(self, visits: np.ndarray) -> np.ndarray:
        """Whether each visit index is in `visited` (a binary search in the sorted array: `np.isin`'s answer at a
        cost that grows with the log of the visits kept, not with their number).

        Args:
            visits: visit indices (`visit`), any shape.

        Returns:
            Booleans of that shape.
        """
        where = np.searchsorted(self.visited, visits)
        return (where < len(self.visited)) & (self.visited[np.minimum(where, len(self.visited) - 1)] == visits) \
            if len(self.visited) else np.zeros(np.shape(visits), dtype=bool)

    def mark_visited(self, visits: np.ndarray) -> None:
        """Add visit indices to `visited`, keeping it sorted and unique (`np.union1d`'s array, the new ones inserted
        where they belong instead of sorting all again).

        Args:
            visits: visit indices (`visit`).
        """
        new = np.unique(np.asarray(visits, dtype=np.int64).ravel())
        new = new[~self.was_visited(new)]
        if len(new):
            self.visited = np.insert(self.visited, np.searchsorted(self.visited, new), new)
