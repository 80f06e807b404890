"""The geometry the search for starting postures measures (`refinement`): how far each hand geom is from the object
and from its neighbours, in which direction the contacts push the object, where the controller's squeeze moves
them, and the exact Jacobians of all of these with respect to the finger joints and the palm's pose.

Every quantity is smooth where the search differentiates it and computed to about 1e-13 of its size, so that the
search's outcome does not turn on the last bits of its inputs or of the arithmetic (issue 50): distances are
measured between the hand geoms' cores (a capsule's segment, a sphere's centre, a box shrunk and rounded) and the
object, by MuJoCo's convex distance run to a tight tolerance, and their gradients come from the nearest points'
Jacobians (MuJoCo's body Jacobians), on a primitive object from the exact nearest points; a primitive's pushes are
a smooth blend of directions sampled along each contact, and the squeeze bends smoothly where it reaches the closed
hand.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput
from ..base.poses import compose, invert
from ..sim.grip import FLEXION
from ..sim.hand import DISTAL_SEGMENTS, SEGMENTS, finger_of, segment_of_geoms
from ..sim.objects import GraspObject
from ..sim.scene import Scene

#: the geometry measures exactly only the distances below this (m); farther geoms are clear of each other
CLEAR = 0.01
#: the distances: MuJoCo's convex distance run to this tolerance and at most these iterations
#: (`mjOption.ccd_tolerance`, `ccd_iterations`; the simulation's 1e-6 and 35 leave about 1e-10 m of noise)
SEARCH_CCD_TOLERANCE = 1e-12
SEARCH_CCD_ITERATIONS = 200
#: the geometry takes a hand box for a box of rounded edges of this radius (m, at most half its smallest size)
BOX_ROUNDING = 0.004
#: a primitive's pushes (`SearchGeometry.pushes`): points along each contact's core, and how fast a point's weight
#: falls with its distance to the object (m)
PUSH_SAMPLES = 9
PUSH_REACH = 0.002
#: the forward-difference step of a mesh object's pushes' Jacobian (`push_jacobians`): m for a geom's move, rad for
#: its turn
PUSH_STEP = 1e-6
_PUSH_TURNS = Rotation.from_rotvec(PUSH_STEP * np.eye(3)).as_matrix()  # a turn of PUSH_STEP about each axis
#: the bend of a primitive's smooth outward directions at its edges (`outward`), m
PUSH_BEND = 0.001
#: `SearchGeometry.pressing`'s squeeze: how far it turns each flexion joint towards the closed hand (rad, or as far
#: as the closed angle, `sim.grip.squeezed`), and how smoothly it bends between the two (rad)
SQUEEZE = 0.05
SQUEEZE_BEND = 0.005


class SearchGeometry:
    """Fast kinematic queries for the search: geom distances and their Jacobians, pushes and the squeeze's motion,
    for a posture and a palm pose.

    The geometry measures on its own copy of the scene's model in which every hand geom is a core and a radius:
    a capsule's segment or a sphere's centre and its radius; a box shrunk by `BOX_ROUNDING` on every side, with
    that radius (a box with rounded edges, which the search takes for the box). Distances are measured between the
    cores and the object, where the shapes are millimetres apart even when the geoms touch, and the radius is
    subtracted: MuJoCo's convex distance is then smooth and, at `SEARCH_CCD_TOLERANCE`, good to about 1e-13 m
    (between touching shapes it was good to about 1e-10 m, with jumps where the distance changes sign), and the
    direction between the nearest points, which gives each distance's gradient, is always defined.
    `distal` are the geoms of the contact segments (the five distal ones unless told otherwise), `other` every
    other hand geom but the forearm's.
    """

    def __init__(self, scene: Scene, contacts: tuple[str, ...] = DISTAL_SEGMENTS):
        self.scene = scene
        self.model = model = copy.copy(scene.model)
        model.opt.ccd_tolerance, model.opt.ccd_iterations = SEARCH_CCD_TOLERANCE, SEARCH_CCD_ITERATIONS
        self.data = data = mujoco.MjData(model)
        segment_of = segment_of_geoms(model)
        hand_geoms = [int(g) for g in np.flatnonzero(segment_of >= 0)]
        self.distal = [int(g) for s in contacts for g in np.flatnonzero(segment_of == SEGMENTS.index(s))]
        self.other = [g for g in hand_geoms if g not in self.distal and SEGMENTS[segment_of[g]] != "forearm"]
        fingers = {g: finger_of(SEGMENTS[segment_of[g]]) or "" for g in hand_geoms}
        order = ["ff", "mf", "rf", "lf"]
        pairs = [(a, b) for a in hand_geoms for b in hand_geoms if a < b and fingers[a] and fingers[b]
                 and fingers[a] != fingers[b]
                 and (fingers[a] == "th" or fingers[b] == "th"
                      or abs(order.index(fingers[a]) - order.index(fingers[b])) == 1)]
        self._fromto = np.zeros(6)
        kinds = {int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_SPHERE)}
        if any(int(model.geom_type[g]) not in kinds for g in self.distal):
            raise InvalidInput(f"the contact segments {contacts} must be capsules or spheres for the start search")
        #: each geom's radius, taken off the distances of its core (the bounding radii stay the geoms' own: the
        #: culling in `distances` uses them)
        self.radius = np.zeros(model.ngeom)
        self._round = {g for g in hand_geoms if int(model.geom_type[g]) in kinds}
        for g in hand_geoms:
            if int(model.geom_type[g]) in kinds:
                self.radius[g], model.geom_size[g, 0] = model.geom_size[g, 0], 0.0
            elif int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_BOX):
                self.radius[g] = min(BOX_ROUNDING, 0.5 * float(model.geom_size[g].min()))
                model.geom_size[g] -= self.radius[g]
        #: the contact geoms in the order of the rows of `pushes` and `pressing`
        self.pushing = self.distal
        self._object = list(scene.object_geoms)
        #: the geoms of neighbouring fingers (n, 2) whose distances `distances` measures (`pairs`)
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self._dofs = np.asarray(scene.hand_dofs[2:])  # the finger joints' degrees of freedom
        self._bodies = sorted({int(model.geom_bodyid[g]) for g in hand_geoms})
        self._palm = np.zeros(3)
        self._placed_frames: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # `_frames` of this placement
        self._witnesses: list[list] = [[], [], []]
        mujoco.mj_kinematics(model, data)  # the palm's place on the mount (the wrist does not move)
        mount = data.mocap_pos[scene.mount_id].copy(), data.mocap_quat[scene.mount_id].copy()
        self._palm_to_mount = compose(*invert(data.xpos[scene.palm_id], data.xquat[scene.palm_id]), *mount)

    def place(self, posture: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Put the hand at this posture (22,), rad, and palm pose (object frame: pos (3,), m, quat (4,) w x y z)."""
        scene, model, data = self.scene, self.model, self.data
        data.qpos[scene.finger_qpos] = posture
        data.mocap_pos[scene.mount_id], data.mocap_quat[scene.mount_id] = compose(pos, quat, *self._palm_to_mount)
        mujoco.mj_kinematics(model, data)  # the geoms' poses are all the distances need
        self._palm = np.array(pos, dtype=float)
        self._placed_frames = None

    def _nearest_part(self, geom: int, cutoff: float) -> tuple[float, np.ndarray]:
        """The distance (m) from a geom's core to the nearest part of the object, and the two nearest points (6,),
        the core's first; `cutoff` when farther."""
        nearest, points = cutoff, np.zeros(6)
        for part in self._object:
            gap = mujoco.mj_geomDistance(self.model, self.data, geom, part, cutoff, self._fromto)
            if gap < nearest:
                nearest, points = gap, self._fromto.copy()
        return nearest, points

    def _to_object(self, geom: int, cutoff: float = 0.3) -> tuple[float, tuple]:
        """A hand geom's signed distance (m) to the object, radius included, and what its gradient needs."""
        gap, points = self._nearest_part(geom, cutoff + self.radius[geom])
        return gap - self.radius[geom], (geom, gap, points)

    def distances(self, posture: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, ...]:
        """Signed distances (m) of the hand at this posture and palm pose (object frame): of each contact geom
        to the object (`distal`), of every other geom to it (`other`) and of the geoms of neighbouring fingers
        to each other (`pairs`). An `other` or `pairs` distance beyond `CLEAR` is only a lower bound (its
        geoms' bounding spheres are that far apart): nothing asks more of it than that it is clear."""
        self.place(posture, pos, quat)
        model, data = self.model, self.data
        centres, bounds = data.geom_xpos, model.geom_rbound
        measured = [self._to_object(g) for g in self.distal]
        distal = np.array([d for d, _ in measured])
        witnesses: list[list] = [[w for _, w in measured], [None] * len(self.other), [None] * len(self.pairs)]
        apart = np.linalg.norm(centres[self.other][:, None] - centres[self._object][None], axis=2)
        other = np.min(apart - bounds[self.other][:, None] - bounds[self._object][None], axis=1)
        for i in np.flatnonzero(other < CLEAR):
            other[i], witnesses[1][i] = self._to_object(self.other[i])
        a, b = self.pairs.T
        pairs = np.linalg.norm(centres[a] - centres[b], axis=1) - bounds[a] - bounds[b]
        for i in np.flatnonzero(pairs < CLEAR):
            cores = self.radius[a[i]] + self.radius[b[i]]
            gap = mujoco.mj_geomDistance(model, data, a[i], b[i], 0.3 + cores, self._fromto)
            pairs[i], witnesses[2][i] = gap - cores, (a[i], b[i], gap, self._fromto.copy())
        self._witnesses = witnesses
        return distal, other, pairs

    def _frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`_body_frames` of the hand where `place` put it, computed once per placement."""
        if self._placed_frames is None:
            self._placed_frames = self._body_frames()
        return self._placed_frames

    def _body_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """How each hand body's origin moves and turns with the finger joints at the current kinematics ((nbody, 3,
        22) each: MuJoCo's body Jacobians), and where the origins are (nbody, 3)."""
        model, data = self.model, self.data
        mujoco.mj_comPos(model, data)  # the frames the Jacobians read
        moves, turns = np.zeros((model.nbody, 3, 22)), np.zeros((model.nbody, 3, 22))
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        for body in self._bodies:
            mujoco.mj_jacBody(model, data, jacp, jacr, body)
            moves[body], turns[body] = jacp[:, self._dofs], jacr[:, self._dofs]
        return moves, turns, data.xpos.copy()

    def _points_jacobian(self, points: np.ndarray, geoms: Sequence[int] | np.ndarray,
                         frames: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        """(n, 3, 28): how points (n, 3) fixed to hand geoms (n,) move with the finger joints (22), the palm's
        translation (3) and its rotation (3, a small turn about the palm's origin in the object frame), given the
        bodies' `_frames` at the kinematics the points were taken at."""
        moves, turns, origins = frames
        bodies = self.model.geom_bodyid[np.asarray(geoms, dtype=int)]
        arm = points - origins[bodies]
        joints = moves[bodies] - np.cross(arm[:, :, None], turns[bodies], axis=1)  # v + w x arm, for each joint
        turn = -_cross_matrices(points - self._palm)  # d(point) = dθ x (point - palm)
        return np.concatenate([joints, np.broadcast_to(np.eye(3), (len(points), 3, 3)), turn], axis=2)

    def distance_jacobians(self) -> tuple[np.ndarray, ...]:
        """The gradients of the last `distances` (the rows of `distal`, `other` and `pairs`, each (n, 28)) with
        respect to the finger joints (22, rad), the palm's translation (3, m) and its rotation (3, rad, a small
        turn about the palm's origin in the object frame): a distance changes by minus the motion of its core's
        nearest point along the direction to the other's nearest point (exact: the nearest points' own motion
        along the surfaces does not change the distance to first order). On a primitive object a capsule's or a
        sphere's nearest points are the exact ones (`_nearest_on_cores`). Lower bounds beyond `CLEAR` get zero
        rows."""
        frames = self._frames()
        found = [(k, i, *w) for k in (0, 1) for i, w in enumerate(self._witnesses[k]) if w is not None]
        rows = [np.zeros((len(self.distal), 28)), np.zeros((len(self.other), 28)), np.zeros((len(self.pairs), 28))]
        if found:
            kinds, index, geoms, gaps = (np.array([f[j] for f in found]) for j in range(4))
            points = np.array([f[4] for f in found])
            if self.scene.object.mesh is None:  # the exact nearest points of round geoms outside the object
                exact = np.flatnonzero(np.isin(geoms, list(self._round)) & (gaps > 0))
                if len(exact):
                    cores = self._nearest_on_cores(geoms[exact], points[exact, :3])
                    points[exact] = np.hstack([cores, self.scene.object.closest_point(cores)])
            away = np.sign(gaps)[:, None] * _unit(points[:, 3:] - points[:, :3])
            gradients = -np.einsum("ni,nij->nj", away, self._points_jacobian(points[:, :3], geoms, frames))
            for kind in (0, 1):
                rows[kind][index[kinds == kind]] = gradients[kinds == kind]
        pairs = [(i, *w) for i, w in enumerate(self._witnesses[2]) if w is not None]
        if pairs:
            index, a, b, gaps = (np.array([f[j] for f in pairs]) for j in range(4))
            points = np.array([f[4] for f in pairs])
            away = np.sign(gaps)[:, None] * _unit(points[:, 3:] - points[:, :3])
            motion = (self._points_jacobian(points[:, 3:], b, frames)
                      - self._points_jacobian(points[:, :3], a, frames))
            rows[2][index] = np.einsum("ni,nij->nj", away, motion)
        return tuple(rows)

    def pushes(self) -> np.ndarray:
        """Unit directions (len(distal), 3) in which the contact geoms (`pushing`) press the object at the current
        placement (`push_jacobians` says how: on a mesh object the direction between the nearest points, on a
        primitive a smooth blend of directions along each contact)."""
        return self.push_jacobians(rows=False)[0]

    def _mesh_push(self, geom: int) -> np.ndarray:
        """On a mesh object, the unit direction (3,) from the point of a geom's core nearest the object towards the
        object's nearest point (its collision geometry: the convex parts)."""
        points = self._nearest_part(geom, 1.0)[1]
        towards = points[3:] - points[:3]
        return towards / max(float(np.sqrt(towards @ towards)), 1e-9)

    def push_jacobians(self, rows: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """The `pushes` (len(distal), 3) and their Jacobians (len(distal), 3, 28) with respect to the finger joints,
        the palm's translation and its rotation (as `distance_jacobians`).

        On a mesh object a push is the direction between the nearest points of a contact's core and the object,
        which turns with the faces the nearest point crosses: its Jacobian is by forward differences of
        `PUSH_STEP` of each contact geom's own pose (three moves and three turns, MuJoCo's convex distance
        measured again, no kinematics), chained with how the geom moves and turns with the joints and the palm.
        On a primitive the pushes are the mean of the directions at `PUSH_SAMPLES` points along the core towards
        the object (`outward`), weighed by exp(-distance / `PUSH_REACH`): the nearer points count, and the
        direction turns smoothly where the nearest point reaches a segment's end or an edge of the object; their
        Jacobian is exact: each sample point's motion (mj_jac), the weights' change with the samples' distances,
        the outward directions' change with the samples (central differences of the closed form, `_outward`)."""
        if self.scene.object.mesh is not None:
            return self._mesh_push_jacobians(rows)
        obj, geoms = self.scene.object, self.pushing
        half = self.data.geom_xmat[geoms].reshape(-1, 3, 3)[:, :, 2] * self.model.geom_size[geoms, 1][:, None]
        along = np.linspace(-1.0, 1.0, PUSH_SAMPLES)
        samples = (self.data.geom_xpos[geoms][:, None] + along[None, :, None] * half[:, None]).reshape(-1, 3)
        towards = obj.closest_point(samples) - samples
        gaps = np.linalg.norm(towards, axis=1).reshape(len(geoms), -1)
        weights = np.exp(-(gaps - gaps.min(axis=1, keepdims=True)) / PUSH_REACH).reshape(-1)
        out = outward(obj, samples)
        inward = -_unit(out)
        total = np.sum((weights[:, None] * inward).reshape(len(geoms), -1, 3), axis=1)
        pushes = _unit(total)
        if not rows:
            return pushes, None
        moves = self._points_jacobian(samples, np.repeat(geoms, PUSH_SAMPLES), self._frames())  # (n, 3, 28)
        closer = -np.einsum("ni,nij->nj", _unit(towards), moves)  # each sample's distance
        step = 1e-7
        bend = np.stack([(outward(obj, samples + step * e) - outward(obj, samples - step * e)) / (2 * step)
                         for e in np.eye(3)], axis=2)  # (n, 3, 3): d out / d point
        across = (np.eye(3) - inward[:, :, None] * inward[:, None, :]) / np.linalg.norm(out, axis=1)[:, None, None]
        turned = -np.einsum("nij,njk,nkl->nil", across, bend, moves)  # d inward
        # d(weight) = -weight d(distance) / PUSH_REACH (the common factor of the nearest sample's does not turn
        # the sum, so it is left out)
        change = weights[:, None, None] * (turned - inward[:, :, None] * closer[:, None, :] / PUSH_REACH)
        change = change.reshape(len(geoms), -1, 3, 28).sum(axis=1)
        length = np.linalg.norm(total, axis=1)
        project = (np.eye(3) - pushes[:, :, None] * pushes[:, None, :]) / length[:, None, None]
        return pushes, np.einsum("gij,gjk->gik", project, change)

    def _mesh_push_jacobians(self, rows: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """`push_jacobians` on a mesh object."""
        geoms, data = self.pushing, self.data
        pushes = np.array([self._mesh_push(geom) for geom in geoms])
        if not rows:
            return pushes, None
        frames = self._frames()
        moves = self._points_jacobian(data.geom_xpos[geoms], geoms, frames)  # (g, 3, 28): each geom's centre
        turns = np.zeros((len(geoms), 3, 28))
        turns[:, :, :22] = frames[1][self.model.geom_bodyid[geoms]]
        turns[:, :, 25:28] = np.eye(3)
        push_rows = np.zeros((len(geoms), 3, 28))
        for i, geom in enumerate(geoms):
            position, orientation = data.geom_xpos[geom].copy(), data.geom_xmat[geom].copy()
            change = np.zeros((3, 6))
            for k, axis in enumerate(np.eye(3)):
                data.geom_xpos[geom] = position + PUSH_STEP * axis
                change[:, k] = self._mesh_push(geom)
                data.geom_xpos[geom] = position
                data.geom_xmat[geom] = (_PUSH_TURNS[k] @ orientation.reshape(3, 3)).ravel()
                change[:, 3 + k] = self._mesh_push(geom)
                data.geom_xmat[geom] = orientation
            change = (change - pushes[i][:, None]) / PUSH_STEP
            push_rows[i] = change[:, :3] @ moves[i] + change[:, 3:] @ turns[i]
        return pushes, push_rows

    def _nearest_on_cores(self, geoms: Sequence[int] | np.ndarray, cores: np.ndarray) -> np.ndarray:
        """The points (len(geoms), 3) of these capsules' or spheres' cores nearest a primitive object, exact:
        MuJoCo's (`cores`, the convex distance's witness points: good to about 1e-7 m on a curved object, although
        the distance is good to 1e-13 m, as a distance is flat at its minimum) taken two Newton steps along each
        capsule's segment on the slope of its exact distance to the object (the object's closed-form closest
        point)."""
        half = self.data.geom_xmat[geoms].reshape(-1, 3, 3)[:, :, 2] * self.model.geom_size[geoms, 1][:, None]
        first, span = self.data.geom_xpos[geoms] - half, 2.0 * half  # a sphere's core: a segment of length 0
        length = np.maximum(np.sum(span * span, axis=1), 1e-18)
        t = np.clip(np.sum((cores - first) * span, axis=1) / length, 0.0, 1.0)

        def slope(t: np.ndarray) -> np.ndarray:  # d/dt of the core point's distance to the object
            points = first + t[:, None] * span
            return -np.sum(span * _unit(self.scene.object.closest_point(points) - points), axis=1)

        for _ in range(2):
            now = slope(t)
            curvature = (slope(t + 1e-6) - now) / 1e-6
            t = np.where(curvature > 1e-12 * length, np.clip(t - now / np.maximum(curvature, 1e-300), 0.0, 1.0), t)
        return first + t[:, None] * span

    def _squeeze(self, posture: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The squeezed posture (22,) of `pressing` and its derivative by each joint (22,)."""
        towards = self.scene.hand.keyframe_posture("closed") - posture
        turn = towards - soft_hinge(towards - SQUEEZE, SQUEEZE_BEND) + soft_hinge(-towards - SQUEEZE, SQUEEZE_BEND)
        slope = 1.0 - hinge_slope(towards - SQUEEZE, SQUEEZE_BEND) - hinge_slope(-towards - SQUEEZE, SQUEEZE_BEND)
        return posture + turn * FLEXION, 1.0 - slope * FLEXION

    def pressing(self, posture: np.ndarray, pushes: np.ndarray) -> np.ndarray:
        """Cosines (len(distal),) between where the controller's squeeze moves each contact geom (a small
        `sim.grip.squeezed` of the posture, at the current hand pose, its bends made smooth over `SQUEEZE_BEND`)
        and its push on the object (`pushes`): 1 when the squeeze presses it straight in, negative when it draws
        it away (the thumb of the paper's mid and low wraps: the squeeze flexes it off the object)."""
        return self.pressing_jacobian(posture, pushes, None)[0]

    def pressing_jacobian(self, posture: np.ndarray, pushes: np.ndarray, push_rows: np.ndarray | None
                          ) -> tuple[np.ndarray, np.ndarray | None]:
        """`pressing` and, given the pushes' Jacobians (`push_jacobians`), the cosines' Jacobian (len(distal), 28),
        else None."""
        model, data, geoms, scene = self.model, self.data, self.pushing, self.scene
        before = data.geom_xpos[geoms].copy()
        saved = data.qpos.copy()
        squeezed_posture, slope = self._squeeze(posture)
        data.qpos[scene.finger_qpos] = squeezed_posture
        mujoco.mj_kinematics(model, data)
        after = data.geom_xpos[geoms].copy()
        if push_rows is not None:
            moves_after = self._points_jacobian(after, geoms, self._body_frames())  # of the squeezed hand
            moves_after[:, :, :22] *= slope
        data.qpos[:] = saved
        mujoco.mj_kinematics(model, data)
        moved = after - before
        length = np.maximum(np.linalg.norm(moved, axis=1), 1e-9)
        cosines = np.sum(moved * pushes, axis=1) / length
        if push_rows is None:
            return cosines, None
        moves_before = self._points_jacobian(before, geoms, self._frames())
        direction = moved / length[:, None]
        across = (pushes - cosines[:, None] * direction) / length[:, None]  # d cos / d moved
        rows = (np.einsum("gi,gij->gj", across, moves_after - moves_before)
                + np.einsum("gi,gij->gj", direction, push_rows))
        return cosines, rows


def outward(obj: GraspObject, points: np.ndarray) -> np.ndarray:
    """(n, 3): a primitive's outward direction at points (object frame, m) outside it, unnormalised and smooth: the
    point's excess beyond each face taken by a `soft_hinge` of `PUSH_BEND` (a box's three axes; a cylinder's radius
    and axis; a sphere's radius). Away from an edge it points along the face's normal, as the exact direction to
    the nearest point does; across an edge it turns smoothly, where the exact one turns with a kink."""
    half = np.asarray(obj.half_sizes, dtype=float)
    excess = lambda x, h: soft_hinge(x - h, PUSH_BEND) - soft_hinge(-x - h, PUSH_BEND)  # noqa: E731
    if obj.shape == "sphere":
        return points
    if obj.shape == "box":
        return excess(points, half)
    radial = np.linalg.norm(points[:, :2], axis=1)
    across = points[:, :2] * (excess(radial, half[0]) / np.maximum(radial, 1e-12))[:, None]
    return np.column_stack([across, excess(points[:, 2], half[1])])


def _cross_matrices(vectors: np.ndarray) -> np.ndarray:
    """(n, 3, 3): the matrices of the cross products with vectors (n, 3): a x b = matrix(a) @ b."""
    x, y, z = vectors.T
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], axis=1), np.stack([z, zero, -x], axis=1),
                     np.stack([-y, x, zero], axis=1)], axis=1)


def _unit(vectors: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length (a zero row stays zero)."""
    return vectors / np.maximum(np.linalg.norm(vectors, axis=1), 1e-9)[:, None]


def soft_hinge(x: np.ndarray, width: float) -> np.ndarray:
    """max(0, x) made smooth over `width`: width * log(1 + exp(x / width)), within 0.7 width of it everywhere.

    The search's one-sided terms are hinges; a hinge's kink, where a term switches on, sits right at the
    solution when a constraint is active, and there a trust-region search collapses its steps and stops wherever
    it is (a place that differs between processors). A smooth hinge keeps the residual differentiable.

    Args:
        x: the values.
        width: the width of the bend, in the units of x.

    Returns:
        The smooth hinge of each value.
    """
    return width * np.logaddexp(0.0, np.asarray(x) / width)


def hinge_slope(x: np.ndarray, width: float) -> np.ndarray:
    """The derivative of `soft_hinge` (a logistic function of x / width)."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x) / width))


def hinge_bend(x: np.ndarray, width: float) -> np.ndarray:
    """The second derivative of `soft_hinge`."""
    slope = hinge_slope(x, width)
    return slope * (1.0 - slope) / width
