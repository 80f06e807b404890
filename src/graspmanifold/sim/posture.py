"""Grasp postures: validation, conversions and the Partial Contact Posture mask (paper Eq. 1).

A grasp posture is a float array of the 22 finger joint angles in radians, in the order of
`FINGER_JOINTS`. The hand's actuators drive J1 + J2 of the four fingers together, so a posture
maps to 18 finger actuator targets (plus two for the wrist).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from ..base.errors import InvalidInput
from .hand import (
    FINGER_JOINTS,
    FINGER_SEGMENTS,
    JOINT_SEGMENT,
    N_FINGER_JOINTS,
    SEGMENTS,
    SHADOW_HAND,
    HandModel,
    finger_of,
)


def validate_posture(posture: object, *, name: str = "posture", check_limits: bool = False,
                     tol: float = 1e-6, hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """A posture as a float (22,) array, or a ValueError saying what is wrong.

    Args:
        posture: 22 finger joint angles, rad.
        name: what to call it in the message.
        check_limits: a joint further than `tol` outside its range is an error too.
        tol: rad.
        hand: the hand model whose ranges `check_limits` reads (default ours).

    Returns:
        The posture (22,), rad.
    """
    array = np.asarray(posture, dtype=float)
    if array.shape != (N_FINGER_JOINTS,):
        raise InvalidInput(f"{name} must have shape ({N_FINGER_JOINTS},) (finger joints in FINGER_JOINTS "
                         f"order), got shape {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        joints = [FINGER_JOINTS[i] for i in np.flatnonzero(bad)]
        raise InvalidInput(f"{name} has non-finite values at joints {joints}")
    if check_limits:
        limits = hand.limits()
        outside = (array < limits[:, 0] - tol) | (array > limits[:, 1] + tol)
        if outside.any():
            details = ", ".join(f"{FINGER_JOINTS[i]}={array[i]:.4f} not in [{limits[i, 0]:.4f}, "
                                f"{limits[i, 1]:.4f}]" for i in np.flatnonzero(outside))
            raise InvalidInput(f"{name} is outside the joint limits of the {hand.name!r} hand: {details}")
    return array


def within_limits(posture: np.ndarray, tol: float = 1e-6, hand: HandModel = SHADOW_HAND) -> bool:
    """Whether every joint of a posture lies inside its range.

    Args:
        posture: 22 finger joint angles, rad.
        tol: how far outside counts as inside, rad.
        hand: the hand model (default ours).

    Returns:
        True when every joint is within its range (± tol).
    """
    p, limits = validate_posture(posture), hand.limits()
    return bool(np.all((p >= limits[:, 0] - tol) & (p <= limits[:, 1] + tol)))


def clip_posture(posture: np.ndarray, hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """A copy of the posture with every joint clipped into its range.

    Args:
        posture: 22 finger joint angles, rad.
        hand: the hand model (default ours).

    Returns:
        The clipped posture (22,), rad.
    """
    limits = hand.limits()
    return np.clip(validate_posture(posture), limits[:, 0], limits[:, 1])


def posture_to_dict(posture: np.ndarray) -> dict[str, float]:
    """The joint angles of a posture by name.

    Args:
        posture: 22 finger joint angles, rad.

    Returns:
        {joint name: angle in rad} in `FINGER_JOINTS` order.
    """
    return dict(zip(FINGER_JOINTS, validate_posture(posture).tolist()))


def dict_to_posture(joints: Mapping[str, float]) -> np.ndarray:
    """A posture from a {joint name: angle} dict holding exactly the 22 finger joints.

    Args:
        joints: angle by joint name (`FINGER_JOINTS`), rad.

    Returns:
        The posture (22,) in `FINGER_JOINTS` order, rad.
    """
    unknown = sorted(set(joints) - set(FINGER_JOINTS))
    if unknown:
        raise InvalidInput(f"joints has unknown joint names {unknown}; expected names from FINGER_JOINTS")
    missing = [j for j in FINGER_JOINTS if j not in joints]
    if missing:
        raise InvalidInput(f"joints is missing finger joints {missing}")
    return validate_posture([joints[j] for j in FINGER_JOINTS], name="joints")


def posture_to_ctrl(posture: np.ndarray, wrist: Iterable[float] = (0.0, 0.0),
                    hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """Actuator targets for a finger posture and wrist angles.

    J1 and J2 of FF, MF, RF and LF become one target J0 = J1 + J2, as on the real hand (our model; another
    model's actuators as its MJCF couples them, `HandModel.ctrl_matrix`).

    Args:
        posture: 22 finger joint angles, rad.
        wrist: (WRJ2, WRJ1), rad.
        hand: the hand model.

    Returns:
        The targets in the hand's `actuators` order (20,), rad.
    """
    ctrl = hand.ctrl_matrix @ validate_posture(posture)
    wrist = np.asarray(tuple(wrist), dtype=float)
    if wrist.shape != (2,) or not np.all(np.isfinite(wrist)):
        raise InvalidInput(f"wrist must be two finite angles (WRJ2, WRJ1), got {wrist!r}")
    for name, angle in zip(hand.wrist_joints, wrist):
        low, high = hand.joint_ranges[name]
        if not low - 1e-9 <= angle <= high + 1e-9:
            raise InvalidInput(f"wrist angle {name} = {angle:.4g} rad is outside its range [{low:.4g}, {high:.4g}]")
    ctrl[hand.wrist_rows] = wrist
    return ctrl


_SEGMENT_DEPTH = {seg: depth for segs in FINGER_SEGMENTS.values() for depth, seg in enumerate(segs)}
_JOINT_FINGER = np.array([finger_of(j) for j in FINGER_JOINTS])
_JOINT_DEPTH = np.array([_SEGMENT_DEPTH[JOINT_SEGMENT[j]] for j in FINGER_JOINTS])


def pcp_mask(segments: Iterable[str]) -> np.ndarray:
    """Partial Contact Posture mask (paper Eq. 1): which of the 22 joints are specified.

    Joint j of finger i is specified when the segment it moves, or any segment further out on the same
    finger, is among the touching `segments`. Palm, wrist and forearm contacts specify nothing.

    Args:
        segments: the touching segments (names from `SEGMENTS`).

    Returns:
        (22,) bool in `FINGER_JOINTS` order.
    """
    segments = list(segments)
    unknown = sorted({s for s in segments if s not in SEGMENTS})
    if unknown:
        raise InvalidInput(f"segments has unknown segment names {unknown}; expected names from SEGMENTS")
    return pcp_masks(np.isin(SEGMENTS, segments)[None])[0]


#: the finger of each segment in SEGMENTS order ("" for the palm)
SEGMENT_FINGER = np.array([finger_of(s) or "" for s in SEGMENTS])
_SEGMENT_DEPTH_ARRAY = np.array([_SEGMENT_DEPTH.get(s, -1) for s in SEGMENTS])


def pcp_masks(touching: np.ndarray) -> np.ndarray:
    """`pcp_mask` of many readings at once.

    Args:
        touching: which segments touch, (m, len(SEGMENTS)) bool in `SEGMENTS` order (e.g. `segment_forces > 0`).

    Returns:
        The masks (m, 22) bool in `FINGER_JOINTS` order.
    """
    touching = np.asarray(touching, dtype=bool)
    if touching.ndim != 2 or touching.shape[1] != len(SEGMENTS):
        raise InvalidInput(f"touching must have shape (m, {len(SEGMENTS)}) (SEGMENTS order), got {touching.shape}")
    depth = np.where(touching, _SEGMENT_DEPTH_ARRAY, -1)
    reach = np.column_stack([depth[:, SEGMENT_FINGER == f].max(axis=1) for f in _JOINT_FINGER])
    return _JOINT_DEPTH <= reach


def open_posture(hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """The controller's initial posture (phase A): fingers straight, thumb opposed but low (the hand
    model's keyframe `open`).

    The thumb is turned in front of the palm (THJ4) and swung towards the wrist (THJ5), so it is
    ready to close against the fingers yet stays clear of an object held 1 cm in front of the palm.
    Starting with the thumb in the palm plane instead makes it sweep into the object and land on top.

    Args:
        hand: the hand model (default ours).

    Returns:
        The posture (22,), rad.
    """
    return hand.keyframe_posture("open")


def closed_posture(hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """The generic closing target: every finger fully flexed, the thumb opposed and flexed (the hand
    model's keyframe `closed`).

    Args:
        hand: the hand model (default ours).

    Returns:
        The posture (22,), rad.
    """
    return hand.keyframe_posture("closed")
