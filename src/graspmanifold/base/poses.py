"""Pose algebra: (position, quaternion) poses with MuJoCo's w x y z quaternions, and the
conversions to and from scipy's rotations (x y z w), in one place."""

from __future__ import annotations

from collections.abc import Iterable

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from .errors import InvalidInput


def check_quat(quat: Iterable[float], name: str) -> np.ndarray:
    """A unit quaternion (w, x, y, z) from any non-zero finite 4-vector, or ValueError naming it."""
    q = np.asarray(tuple(quat), dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-9:
        raise InvalidInput(f"{name} must be a non-zero finite quaternion (w, x, y, z), got {quat!r}")
    return q / np.linalg.norm(q)


def check_vec3(vec: Iterable[float], name: str) -> np.ndarray:
    """Three finite numbers, or ValueError naming them."""
    v = np.asarray(tuple(vec), dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InvalidInput(f"{name} must be three finite numbers, got {vec!r}")
    return v


def compose(pos_a: np.ndarray, quat_a: np.ndarray, pos_b: np.ndarray, quat_b: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Pose product a * b of two (position, quaternion) poses."""
    pos, quat = np.zeros(3), np.zeros(4)
    mujoco.mju_rotVecQuat(pos, pos_b, quat_a)
    mujoco.mju_mulQuat(quat, quat_a, quat_b)
    return pos + pos_a, quat


def invert(pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of a (position, quaternion) pose."""
    inv_quat, inv_pos = np.zeros(4), np.zeros(3)
    mujoco.mju_negQuat(inv_quat, quat)
    mujoco.mju_rotVecQuat(inv_pos, -np.asarray(pos, dtype=float), inv_quat)
    return inv_pos, inv_quat


def quat_products(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products a * b of quaternions (w x y z), row by row (broadcast).

    Args:
        a: (..., 4) quaternions.
        b: (..., 4) quaternions.

    Returns:
        (..., 4) the products.
    """
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def rotated(vecs: np.ndarray, quats: np.ndarray) -> np.ndarray:
    """Vectors rotated by unit quaternions (w x y z), row by row (broadcast): `rotate` over many.

    Args:
        vecs: (..., 3) vectors.
        quats: (..., 4) unit quaternions.

    Returns:
        (..., 3) the rotated vectors.
    """
    q = np.asarray(quats, dtype=float)
    w, u = q[..., :1], q[..., 1:]
    v = np.asarray(vecs, dtype=float)
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def compose_many(pos_a: np.ndarray, quat_a: np.ndarray, pos_b: np.ndarray, quat_b: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """`compose` of many poses at once, row by row (broadcast): a * b.

    Args:
        pos_a: (..., 3) m.
        quat_a: (..., 4) w x y z, unit.
        pos_b: (..., 3) m.
        quat_b: (..., 4) w x y z, unit.

    Returns:
        The positions (..., 3) m and orientations (..., 4) of the products.
    """
    return np.asarray(pos_a, dtype=float) + rotated(pos_b, quat_a), quat_products(quat_a, quat_b)


def invert_many(pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`invert` of many poses at once, row by row.

    Args:
        pos: (..., 3) m.
        quat: (..., 4) w x y z, unit.

    Returns:
        The inverse poses' positions (..., 3) m and orientations (..., 4).
    """
    conjugate = np.asarray(quat, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])
    return rotated(-np.asarray(pos, dtype=float), conjugate), conjugate


def rotate(vec: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """A vector rotated by a quaternion (w, x, y, z)."""
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vec, dtype=float), quat)
    return out


def rotvec_quat(rotvec: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """The rotation `quat` followed by a turn given as a rotation vector.

    Args:
        rotvec: (3,), the turn's axis times its angle (radians), in the world frame.
        quat: (4,), the first rotation (w x y z), a unit quaternion.

    Returns:
        (4,), the composed rotation's quaternion (w x y z).
    """
    angle = float(np.linalg.norm(rotvec))
    turn, out = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(4)
    if angle > 0.0:
        mujoco.mju_axisAngle2Quat(turn, np.asarray(rotvec, dtype=float) / angle, angle)
    mujoco.mju_mulQuat(out, turn, np.asarray(quat, dtype=float))
    return out


def to_rotation(quat: np.ndarray) -> Rotation:
    """scipy's Rotation of a quaternion (w, x, y, z)."""
    return Rotation.from_quat(np.asarray(quat, dtype=float)[[1, 2, 3, 0]])


def to_quat(rotation: Rotation) -> np.ndarray:
    """The quaternion (w, x, y, z) of a scipy Rotation."""
    return rotation.as_quat()[[3, 0, 1, 2]]
