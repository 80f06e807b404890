"""A grasp's postures made from its contacts: the fingers moved along the object's normals where they touch.

An open-loop grasp needs, besides the grasp, a pregrasp it approaches from and a squeeze it presses with. Both can
be made from the grasp's own contacts, as grasp synthesisers make them: the contact point of every finger segment
within `CONTACT_REACH` of the object is moved by a stated depth along the object's inward normal at its nearest
surface point (a negative depth: away from the object, a pregrasp that approaches along the normals without
sweeping the object; a positive depth: into it, a squeeze whose servos press every contact inwards). The normal
is the gradient of the object's signed distance by central differences `NORMAL_STEP` wide, so that it moves
continuously with the point, across an edge too. The joints that do it are found by damped least squares on the
contacts' Jacobians (MuJoCo's `mj_jac`; the motion along the normal counts fully, a slide along the surface less,
`SLIDE_WEIGHT`; joints no contact needs stay), a few Gauss-Newton steps with the kinematics recomputed, within the
joint ranges; a contact whose joints cannot move it that far (a proximal segment against the palm) moves as far
as the least squares allows. The palm stays.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..base.errors import InvalidInput
from .hand import segment_of_geoms
from .scene import Scene

#: m: a segment this near the object counts as a contact to be moved
CONTACT_REACH = 0.003
#: m, half the width of the central differences that give the object's normal at a contact
NORMAL_STEP = 0.001
#: Gauss-Newton steps of the offset's solve
ITERATIONS = 6
#: the weight of a contact's slide along the surface against its motion along the normal (a free slide lets a
#: segment turn about its contact point and sweep its other end into the object)
SLIDE_WEIGHT = 0.3
#: the damping of the least squares (m^2 per rad^2): keeps joints far from a segment's motion still
DAMPING = 1e-6


def offset_along_normals(scene: Scene, hand_pose: np.ndarray, posture: np.ndarray, depth: float) -> np.ndarray:
    """The posture whose touching finger segments' contact points lie `depth` m further along the object's inward
    normals than in `posture` (the palm at `hand_pose`), as far as the joints allow (see the module doc).

    Args:
        scene: a scene of the grasp's object and hand (its state is changed: the hand is put at the grasp).
        hand_pose: (7,) the palm's position (m) and orientation (w x y z) in the object frame.
        posture: (22,) rad, the grasp's finger joints.
        depth: m, along the inward normal (negative: away from the object).

    Returns:
        (22,) rad, within the hand's joint ranges; `posture` itself when no finger segment touches.
    """
    hand_pose, posture = np.asarray(hand_pose, dtype=float), np.asarray(posture, dtype=float)
    if hand_pose.shape != (7,) or posture.shape != (22,):
        raise InvalidInput(f"hand_pose must be (7,) and posture (22,), got {hand_pose.shape} and {posture.shape}")
    if not np.isfinite(depth):
        raise InvalidInput(f"depth must be a finite number of metres, got {depth!r}")
    model, data = scene.model, scene.data
    scene.set_posture(posture)
    scene.set_hand_pose(hand_pose[:3], hand_pose[3:])
    segment_of = segment_of_geoms(model, scene.hand)
    fingers = set(range(len(scene.hand.base_segments), len(scene.hand.segments)))
    found = []  # (body, the contact point on the hand, its nearest point on the object), both in the world
    fromto = np.zeros(6)
    for segment in sorted(fingers):
        geoms = np.flatnonzero(segment_of == segment)
        nearest = min(((mujoco.mj_geomDistance(model, data, int(g), o, 0.05, fromto), fromto.copy())
                       for g in geoms for o in scene.object_geoms), key=lambda pair: pair[0], default=None)
        if nearest is not None and nearest[0] <= CONTACT_REACH:
            found.append((int(model.geom_bodyid[geoms[0]]), nearest[1][:3], nearest[1][3:]))
    anchors = [(body, data.xmat[body].reshape(3, 3).T @ (on_hand - data.xpos[body]), on_hand, inward)
               for (body, on_hand, _), inward in zip(found, _inward_normals(scene, [f[2] for f in found]))]
    if not anchors:
        return posture.copy()
    dofs, signs, limits = scene.hand_dofs[2:], scene.hand.to_model(np.ones(22)), scene.hand.limits()
    jacobian = np.zeros((3, model.nv))
    moved = posture.copy()
    for _ in range(ITERATIONS):
        rows, residual = [], []
        for body, local, start, inward in anchors:
            point = data.xpos[body] + data.xmat[body].reshape(3, 3) @ local
            mujoco.mj_jac(model, data, jacobian, None, point, body)
            moves, along = jacobian[:, dofs] * signs, np.eye(3) - np.outer(inward, inward)
            rows += [inward @ moves, SLIDE_WEIGHT * along @ moves]
            residual += [[depth - inward @ (point - start)], -SLIDE_WEIGHT * along @ (point - start)]
        stacked, error = np.vstack(rows), np.concatenate(residual)
        step = np.linalg.solve(stacked.T @ stacked + DAMPING * np.eye(22), stacked.T @ error)
        moved = np.clip(moved + step, limits[:, 0], limits[:, 1])
        data.qpos[scene.finger_qpos] = scene.hand.to_model(moved)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
    return moved


def _inward_normals(scene: Scene, points: list[np.ndarray]) -> np.ndarray:
    """The object's inward normals (k, 3) at points on its surface (world frame): the gradient of its signed
    distance by central differences `NORMAL_STEP` wide, so that a point on an edge gets a normal between its faces'
    that moves continuously with it (a face's normal there flipped from one face to the other with the last bit of
    the point)."""
    if not points:
        return np.zeros((0, 3))
    rotation = scene.data.xmat[scene.object_body].reshape(3, 3)
    local = (np.array(points) - scene.data.xpos[scene.object_body]) @ rotation  # into the object's frame
    steps = NORMAL_STEP * np.vstack([np.eye(3), -np.eye(3)])
    distance = scene.object.signed_distance((local[:, None, :] + steps[None]).reshape(-1, 3)).reshape(len(local), 6)
    gradient = distance[:, :3] - distance[:, 3:]
    outward = gradient / np.maximum(np.linalg.norm(gradient, axis=1, keepdims=True), 1e-12)
    return -outward @ rotation.T
