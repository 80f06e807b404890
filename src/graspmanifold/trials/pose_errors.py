"""Pose uncertainty: the object lies off the pose a plan assumed, by a known error; and the open-loop baseline,
which executes the grasp planned for the nominal pose where the object really is.

The reason to close a grasp on touch is that the object is not where the plan assumed. `pose_errors` moves every
nominal grid pose by every level of error (stratified: each level holds every nominal pose once): by exactly the
level's distance in the palm's plane (across and along the fingers; the gap in front of the palm is kept) in a
direction drawn at random, and turned about the palm normal by a yaw drawn uniformly within +-30 degrees scaled
as the level is to the largest (within 0, 6, 12, 18, 30 degrees at 0, 1, 2, 3, 5 cm). A draw that would put the
object inside the open hand is drawn again; a nominal pose left with no clear draw at some level is left out at
every level. A trial runs at the true pose. A tactile controller senses joints and touch only: it never reads the
nominal pose or the error (`tests/test_uncertainty.py` spies on what it is given).

The open-loop baseline is what a planner without touch does. `plan` picks, for each nominal pose, the first of its
candidate postures (in order of preference) whose open-loop replay at that pose holds: a grasp verified for the
pose it was planned for. `open_loop` executes it where the arm sent the hand for the nominal pose while the object
lies at the true pose: the pregrasp, grasp and squeeze of `plans.open_loop_grasp` at the nominal pose,
carried into the true object's frame (`carried`), replayed by `replay.replay` and judged by our hold test.
"""

from __future__ import annotations

import functools
import math
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from ..base.errors import InvalidInput
from ..base.poses import compose, invert
from ..base.workers import parallel_map
from ..judging.protocols import DEFAULT_PROTOCOL
from ..judging.plans import OpenLoopGrasp, open_loop_grasp
from ..judging.replay import replay
from ..sim.hand import N_FINGER_JOINTS, SHADOW_HAND
from ..sim.objects import GraspObject, get_object
from .grid import palm_pose_for, reachable

#: m, the levels of position error, in the palm's plane
POSITION_ERRORS: tuple[float, ...] = (0.0, 0.01, 0.02, 0.03, 0.05)
#: rad, the largest yaw error (at the largest level; a level's bound scales with its distance)
MAX_YAW_ERROR = math.radians(30.0)
#: draws of one pose's error at one level before the pose is left out
REDRAWS = 50
#: open-loop replays per worker task
_REPLAYS_PER_TASK = 8


@dataclass(frozen=True)
class PoseErrors:
    """Nominal poses, each at every level of error.

    Attributes:
        nominal: (n, 4) grid poses the plan assumed (x, z, gap in m, yaw in rad).
        true: (n, 4) where the objects really are.
        level: (n,) m, the level of each row (its position error's length).
        kept: (m,) indices into the nominal poses given: those with a clear draw at every level (rows are pose-major:
            row k * len(levels) + j is kept pose k at level j).
    """

    nominal: np.ndarray
    true: np.ndarray
    level: np.ndarray
    kept: np.ndarray


def pose_errors(obj: str | GraspObject, nominal: np.ndarray, levels: tuple[float, ...] = POSITION_ERRORS,
                seed: int = 0) -> PoseErrors:
    """Every nominal pose at every level of error (the module doc says how each is drawn).

    Args:
        obj: the object, or its name (a draw must leave the open hand clear of it).
        nominal: (n, 4) grid poses.
        levels: m, the position errors, the largest last (it scales the yaw bound).
        seed: pose k's draws come from the generator seeded [seed, k], level by level.

    Returns:
        The `PoseErrors`.
    """
    obj = get_object(obj)
    nominal = np.asarray(nominal, dtype=float)
    if nominal.ndim != 2 or nominal.shape[1] != 4 or not np.all(np.isfinite(nominal)):
        raise InvalidInput(f"nominal must be finite grid poses (n, 4), got shape {nominal.shape}")
    levels = tuple(float(v) for v in levels)
    if not levels or any(not math.isfinite(v) or v < 0 for v in levels) or max(levels) != levels[-1]:
        raise InvalidInput(f"levels must be distances >= 0 (m), the largest last, got {levels}")
    rngs = [np.random.default_rng([seed, k]) for k in range(len(nominal))]
    true = np.repeat(nominal[:, None, :], len(levels), axis=1)
    clear = np.ones(len(nominal), dtype=bool)
    for j, level in enumerate(levels):
        if level == 0.0:
            continue
        yaw_bound = MAX_YAW_ERROR * level / levels[-1]
        pending = np.arange(len(nominal))
        for _ in range(REDRAWS):
            draws = np.array([rngs[k].uniform([0.0, -1.0], [2 * math.pi, 1.0]) for k in pending]).reshape(-1, 2)
            moved = nominal[pending] + np.column_stack([level * np.cos(draws[:, 0]), level * np.sin(draws[:, 0]),
                                                        np.zeros(len(pending)), yaw_bound * draws[:, 1]])
            ok = reachable(obj, moved) if len(pending) else np.zeros(0, dtype=bool)
            true[pending[ok], j] = moved[ok]
            pending = pending[~ok]
            if not len(pending):
                break
        clear[pending] = False
    kept = np.flatnonzero(clear)
    return PoseErrors(np.repeat(nominal[kept], len(levels), axis=0), true[kept].reshape(-1, 4),
                      np.tile(np.array(levels), len(kept)), kept)


def carried(obj: str | GraspObject, grasp: OpenLoopGrasp, nominal: np.ndarray, true: np.ndarray) -> OpenLoopGrasp:
    """A grasp planned in the frame of the object at its nominal grid pose, carried into the frame of the object
    at its true grid pose: the hand goes where the plan sent it, the object lies elsewhere.

    Args:
        obj: the object, or its name.
        grasp: its palm poses in the nominal object's frame.
        nominal: (4,) the grid pose the plan assumed.
        true: (4,) where the object is.

    Returns:
        The same grasp, its palm poses in the true object's frame.
    """
    obj = get_object(obj)
    to_true = compose(*palm_pose_for(obj, np.asarray(true, dtype=float)),
                      *invert(*palm_pose_for(obj, np.asarray(nominal, dtype=float))))
    poses = np.array([np.concatenate(compose(*to_true, pose[:3], pose[3:])) for pose in grasp.poses])
    return OpenLoopGrasp(poses, grasp.postures)


def _commanded(postures: np.ndarray) -> np.ndarray:
    """Postures as a plan commands them: within the joint limits (a posture sensed under load may lie a hair past
    one); NaN stays NaN."""
    limits = SHADOW_HAND.limits()
    return np.clip(postures, limits[:, 0], limits[:, 1])


def _replay_task(task: tuple[np.ndarray, np.ndarray, np.ndarray], obj: GraspObject) -> tuple[np.ndarray, list[str]]:
    postures, nominal, true = task
    grasps = [carried(obj, open_loop_grasp(np.concatenate(palm_pose_for(obj, n)), p), n, t)
              for p, n, t in zip(postures, nominal, true)]
    return replay(obj, grasps, DEFAULT_PROTOCOL)


def open_loop(obj: str | GraspObject, postures: np.ndarray, nominal: np.ndarray, true: np.ndarray, *,
              workers: int = 1, executor: Executor | None = None) -> tuple[np.ndarray, list[str]]:
    """Each posture, planned at its nominal pose, executed open loop where the object really is (the module doc).

    Args:
        obj: the object, or its name.
        postures: (n, 22) rad, the planned grasps (`plan`).
        nominal: (n, 4) the grid poses they were planned for.
        true: (n, 4) where the objects are.
        workers: worker processes; `executor`: run the replays there instead.

    Returns:
        (held (n,) bool under our hold test, faults: why a replay could not be judged, '' where it could).
    """
    obj = get_object(obj)
    postures, nominal, true = (np.asarray(a, dtype=float) for a in (postures, nominal, true))
    n = len(postures)
    if postures.shape != (n, N_FINGER_JOINTS) or nominal.shape != (n, 4) or true.shape != (n, 4):
        raise InvalidInput(f"postures (n, {N_FINGER_JOINTS}), nominal (n, 4) and true (n, 4) must hold the same n "
                           f"rows, got shapes {postures.shape}, {nominal.shape} and {true.shape}")
    if not (np.all(np.isfinite(postures)) and np.all(np.isfinite(nominal)) and np.all(np.isfinite(true))):
        raise InvalidInput("postures, nominal and true must be finite (a pose without a plan has no open-loop grasp)")
    postures = _commanded(postures)
    tasks = [(postures[i:i + _REPLAYS_PER_TASK], nominal[i:i + _REPLAYS_PER_TASK], true[i:i + _REPLAYS_PER_TASK])
             for i in range(0, n, _REPLAYS_PER_TASK)]
    results = parallel_map(functools.partial(_replay_task, obj=obj), tasks, workers, executor=executor)
    held = np.concatenate([r[0] for r in results]) if results else np.zeros(0, dtype=bool)
    return held, [fault for r in results for fault in r[1]]


def plan(obj: str | GraspObject, nominal: np.ndarray, candidates: np.ndarray, *, workers: int = 1,
         executor: Executor | None = None) -> np.ndarray:
    """The grasp planned for each nominal pose: the first of its candidates whose open-loop replay at that very
    pose holds.

    Args:
        obj: the object, or its name.
        nominal: (n, 4) grid poses.
        candidates: (k, n, 22) rad, k candidate postures per pose in order of preference (a NaN row: none).
        workers: worker processes; `executor`: run the replays there instead.

    Returns:
        (n, 22) rad, the plans (within the joint limits); NaN rows where no candidate held.
    """
    nominal, candidates = np.asarray(nominal, dtype=float), np.asarray(candidates, dtype=float)
    if candidates.ndim != 3 or candidates.shape[1:] != (len(nominal), N_FINGER_JOINTS):
        raise InvalidInput(f"candidates must be (k, {len(nominal)}, {N_FINGER_JOINTS}) postures for the {len(nominal)} "
                           f"nominal poses, got shape {candidates.shape}")
    plans = np.full((len(nominal), N_FINGER_JOINTS), np.nan)
    for rows in _commanded(candidates):
        open_ = np.flatnonzero(np.isnan(plans).any(axis=1) & np.isfinite(rows).all(axis=1))
        if not len(open_):
            continue
        held, _ = open_loop(obj, rows[open_], nominal[open_], nominal[open_], workers=workers, executor=executor)
        plans[open_[held]] = rows[open_[held]]
    return plans
