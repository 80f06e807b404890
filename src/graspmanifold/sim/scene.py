"""A simulated grasp scene: the hand and one object, composed with mujoco.MjSpec.

The object sits at the world origin (its body is named `object`); the hand hangs from the mocap
body `hand_mount`, so placing the hand is moving that body. With a flange (`Scene(flange=FlangeLimits())`,
`sim.flange`) the hand hangs on an arm's flange instead, whose base is the mocap body `arm_base`: placing the hand
moves the base with the flange at home, and a controller moves the palm by the flange's servos. Hand poses are always
the pose of the palm frame in the object frame (position in m, quaternion w x y z).
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterable

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from ..base.errors import InvalidInput, RenderingUnavailable, SimulationError
from ..base.poses import check_quat, check_vec3, compose, compose_many, invert
from ..base.validation import Bounds, check_choice, check_int, check_number
from .flange import (
    ARM_BASE,
    FLANGE_ACTUATORS,
    FLANGE_JOINTS,
    FlangeLimits,
    flanged_spec,
    palm_in_mount,
    without_empty_prefix_warning,
)
from .hand import SHADOW_HAND, HandModel
from .hand_models import hand_model
from .objects import GraspObject, get_object
from .posture import posture_to_ctrl, validate_posture
from .render import png_bytes, render_states
from .tactile import TactileReading, TactileSensor

GRAVITY = 9.81
OBJECT_RGBA = (0.25, 0.45, 0.8, 1.0)
_GEOM_TYPES = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
               "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}

#: A contact deeper than this (m) is a failure of the simulation, not a grasp: soft contacts of a
#: squeezing hand stay below about 1 mm (see RELIABILITY.md for the measurement)
PENETRATION_LIMIT = 0.005


_WARNINGS = sorted((int(getattr(mujoco.mjtWarning, name)), name.removeprefix("mjWARN_"))
                   for name in dir(mujoco.mjtWarning) if name.startswith("mjWARN_"))


#: Where an object touching the palm sits in the palm frame (x across the fingers, z along them).
GRASP_CENTRE_IN_PALM = np.array([0.008, 0.0, 0.075])
PALM_HALF_THICKNESS = 0.013


#: m, the farthest a grid pose or a facing pose may put the object from the palm: beyond the fingers' reach
MAX_GAP = 0.2


def facing_pose(obj: str | GraspObject, clearance: float = 0.01, height: float = 0.0
                ) -> tuple[np.ndarray, np.ndarray]:
    """A palm pose (object frame) for a side wrap: the palm faces the object from +x.

    The object's long axis (z) runs across the fingers (palm x), the object's surface is `clearance`
    in front of the palm's inner face, and `height` shifts the hand along the object's axis.

    Args:
        obj: the object, or its name.
        clearance: palm to object surface, 0 ... `MAX_GAP` m.
        height: shift along the object's axis, m.

    Returns:
        The palm's position (3,), m, and orientation (4,), a w x y z quaternion, in the object frame.
    """
    if not (isinstance(clearance, (int, float)) and math.isfinite(clearance) and 0.0 <= clearance <= MAX_GAP):
        raise InvalidInput(f"clearance must be 0 ... {MAX_GAP} m between the palm and the object, got {clearance!r} "
                         "(a negative one puts the palm inside the object)")
    return placed_facing(get_object(obj), clearance, height)


def placed_facing(obj: GraspObject, clearance: float, height: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """`facing_pose` without its checks, for a grid pose whose reachability is judged afterwards (a
    negative clearance puts the palm inside the object, which `grid.why_unreachable` then reports)."""
    # columns: palm x -> object z, palm y -> object x, palm z -> object y
    rotation = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.ravel())
    centre_in_palm = GRASP_CENTRE_IN_PALM - [0.0, PALM_HALF_THICKNESS + clearance + obj.half_extents[0], 0.0]
    pos = -rotation @ centre_in_palm + [0.0, 0.0, height]
    return pos, quat


#: Named cameras of every scene (see `Scene.render`), all aimed at the object: `hand` rides on the
#: palm (the same view of every grasp), `front` looks at the palm through the object in the nominal
#: placement, `side` from beyond the fingertips, `top` from above.
CAMERAS: dict[str, tuple[str, tuple[float, float, float]]] = {
    "hand": ("palm", (0.2, -0.33, 0.16)),
    "front": ("world", (-0.4, 0.05, 0.12)),
    "side": ("world", (0.05, 0.4, 0.12)),
    "top": ("world", (0.05, 0.0, 0.42)),
}


def _add_object_geoms(spec: mujoco.MjSpec, body: mujoco.MjsBody, obj: GraspObject) -> None:
    """The object's collision geometry: one primitive geom, or a mesh geom per convex part of a mesh
    (whose mass and inertia come from the whole mesh, not from the parts' hulls)."""
    contact = dict(friction=[obj.friction, 0.005, 0.0001], condim=4, contype=1, conaffinity=1, solref=[0.004, 1.0],
                   rgba=OBJECT_RGBA)
    if obj.shape != "mesh":
        size = np.zeros(3)
        size[: len(obj.half_sizes)] = obj.half_sizes
        body.add_geom(name="object", type=_GEOM_TYPES[obj.shape], size=size, mass=obj.mass, **contact)
        return
    body.explicitinertial = True
    body.mass = obj.mass
    body.ipos = [0.0, 0.0, 0.0]  # the object frame is at the centre of mass, on the principal axes
    mesh = obj.mesh
    assert mesh is not None  # a mesh object's (the primitives returned above)
    body.inertia = np.diag(mesh.moment_inertia) * obj.mass / mesh.mass
    for i, part in enumerate(obj.parts):
        name = "object" if i == 0 else f"object_{i}"
        spec.add_mesh(name=f"{name}_mesh", uservert=part.vertices.ravel().tolist(), userface=part.faces.ravel().tolist())
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_mesh", **contact)


#: where the segment forces a scene senses come from (`Scene(touch=...)`): the contacts' normal forces summed per
#: segment (ours, the default), MuJoCo's touch sensors (a site over each segment: they feel every contact in it, the
#: hand's own too), or MuJoCo's contact sensors between each segment and the object (they feel the object only)
TOUCH_SOURCES = ("contacts", "sensors", "contact-sensors")
#: contacts between one segment and the object a contact sensor reports (the largest forces first); more are
#: left out of its sum
CONTACT_SENSOR_SLOTS = 16
_CONTACT_FOUND_FORCE = 3  # a contact sensor's data: the count found (1) and each slot's force (2), as bits
_CONTACT_MAXFORCE = 2  # its slots sorted by force, the largest first
#: m the touch site over a segment's geom reaches beyond it: a contact point lies on the surfaces' midplane, up to
#: half a penetration inside the geom or outside it
TOUCH_SITE_MARGIN = 0.003
_SITE_TYPES = (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_ELLIPSOID,
               mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_BOX)


def _touch_sensors(model: mujoco.MjModel, hand: HandModel) -> list[tuple[int, int]]:
    """(sensordata address, segment index) of each touch sensor whose site sits on a tactile segment."""
    segment_of_body = {model.body(name).id: i for i, name in enumerate(hand.segments)}
    return [(int(model.sensor_adr[k]), segment_of_body[int(model.site_bodyid[model.sensor_objid[k]])])
            for k in range(model.nsensor) if model.sensor_type[k] == mujoco.mjtSensor.mjSENS_TOUCH
            and int(model.site_bodyid[model.sensor_objid[k]]) in segment_of_body]


def _add_touch_sensors(spec: mujoco.MjSpec, model: mujoco.MjModel, hand: HandModel) -> None:
    """A touch sensor over every colliding geom of every tactile segment: a site of the geom's shape (a box around a
    mesh), `TOUCH_SITE_MARGIN` larger, placed as the compiled geom is in its body."""
    for segment in hand.segments:
        body = model.body(segment).id
        for k, geom in enumerate(np.flatnonzero((model.geom_bodyid == body)
                                                & ((model.geom_contype != 0) | (model.geom_conaffinity != 0)))):
            kind, size, pos = model.geom_type[geom], model.geom_size[geom].copy(), model.geom_pos[geom].copy()
            if kind not in _SITE_TYPES:  # a mesh: the box around it, in the geom's frame
                kind, size, pos = mujoco.mjtGeom.mjGEOM_BOX, model.geom_aabb[geom][3:].copy(), pos + model.geom_aabb[geom][:3]
            grown = size + TOUCH_SITE_MARGIN
            if kind in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER):
                grown[2] = 0.0  # radius and half length only
            name = f"touch_{segment}_{k}"
            spec.body(segment).add_site(name=name, type=kind, size=grown.tolist(), pos=pos.tolist(),
                                        quat=model.geom_quat[geom].tolist(), group=4)
            spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_TOUCH, objtype=mujoco.mjtObj.mjOBJ_SITE,
                            objname=name)


def _add_cameras(spec: mujoco.MjSpec, palm: str) -> None:
    for name, (parent, pos) in CAMERAS.items():
        body = spec.worldbody if parent == "world" else spec.body(palm if parent == "palm" else parent)
        body.add_camera(name=name, pos=list(pos), mode=mujoco.mjtCamLight.mjCAMLIGHT_TARGETBODY,
                        targetbody="object", fovy=40.0)


class Scene:
    """The hand and one object in a MuJoCo model, with helpers to pose, actuate and sense.

    `free_object=False` welds the object to the world (the posture generator holds it fixed); with
    `free_object=True` it hangs on a free joint and can be pushed and dropped. Gravity starts off.
    `table=True` adds a table top under the object (the object stands on it along its z axis, the
    world's z); `set_table(False)` takes it away, as lifting the object off it would.
    Every geom gets the object's sliding friction, so each hand-object contact has exactly that
    coefficient (MuJoCo would otherwise take the larger of the two geoms' values).

    Attributes:
        object: the object (`GraspObject`).
        spec: the `mujoco.MjSpec` the model was compiled from (`to_xml()` writes it out).
        model: the compiled `mujoco.MjModel`; change it in place (geom colours, options) as MuJoCo allows.
        data: the `mujoco.MjData` of the simulation; `run`, `step` and the setters keep it consistent.
        free_object: whether the object hangs on a free joint (True) or is welded to the world.
    """

    def __init__(self, obj: str | GraspObject = "cylinder", *, free_object: bool = False,
                 gravity: bool = False, table: bool = False, hand: str | HandModel = SHADOW_HAND.name,
                 touch: str = "contacts", flange: FlangeLimits | None = None):
        """The hand and one object in a new MuJoCo model.

        Args:
            obj: the object, or its name.
            free_object: the object hangs on a free joint (False: welded to the world).
            gravity: gravity on from the start.
            table: a table top under the object.
            hand: the hand model, or its name or the path of its MJCF file (`hand_models.hand_model`); postures stay the paper's 22
                joint angles in the paper's sense whatever the model's names and signs.
            touch: where the segment forces the controller senses come from (`TOUCH_SOURCES`): 'contacts', the
                normal forces of the hand-object contacts summed per segment (ours, `TactileSensor`); 'sensors',
                MuJoCo's own touch sensors (a hand model's, or added here: a site over each segment's collision
                geoms, `TOUCH_SITE_MARGIN` larger, with a `touch` sensor on it), summed per segment (`touch()`); or
                'contact-sensors', a MuJoCo `contact` sensor between each segment and the object, its slots'
                normal forces summed (up to `CONTACT_SENSOR_SLOTS` contacts a segment).
            flange: the hand on an arm's flange with these limits (`sim.flange`; `steer_flange` moves it), or None:
                the hand on its mocap mount, moved only by placing it.
        """
        self.object = get_object(obj)
        self.free_object = free_object
        self.hand = hand if isinstance(hand, HandModel) else hand_model(hand)
        if flange is not None and not isinstance(flange, FlangeLimits):
            raise InvalidInput(f"flange must be a FlangeLimits or None, got {flange!r}")
        self.flange_limits = flange
        self.touch_source = check_choice(touch, TOUCH_SOURCES, "touch")
        self.spec = self._spec(table)
        self.model = self._compiled(touch)
        self.model.geom_friction[:, 0] = self.object.friction  # one friction for every hand-object contact
        self.data = mujoco.MjData(self.model)
        self.sensor = TactileSensor(self.model, hand=self.hand)
        self._find_addresses(table)
        self.set_gravity(gravity)
        self.reset()

    def _spec(self, table: bool) -> mujoco.MjSpec:
        """The hand (on its flange where it has one), the object (free or welded), the table and the cameras."""
        flange = self.flange_limits
        spec = self.hand.spec()
        if flange is not None:
            spec = flanged_spec(spec, self.hand.mount, palm_in_mount(self.hand.model, self.hand.mount, self.hand.palm),
                                flange)
        spec.modelname = f"graspmanifold_{self.object.name}"
        body = spec.worldbody.add_body(name="object")
        if self.free_object:
            body.add_freejoint(name="object_free")
        _add_object_geoms(spec, body, self.object)
        spec.add_exclude(bodyname1="object", bodyname2=self.hand.base_segments[0])
        if table:  # a table top under the object, which stands on it along its z axis
            top = -float(self.object.half_extents[2])
            spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.25, 0.25, 0.01],
                                    pos=[0.0, 0.0, top - 0.01], contype=1, conaffinity=1, condim=4,
                                    solref=[0.004, 1.0], rgba=(0.55, 0.45, 0.35, 1.0))
        _add_cameras(spec, self.hand.palm)
        return spec

    def _compiled(self, touch: str) -> mujoco.MjModel:
        """The spec compiled, with the touch sensors the touch source needs added first."""
        spec = self.spec
        with without_empty_prefix_warning():
            model = spec.compile()
            if touch == "sensors" and not _touch_sensors(model, self.hand):
                _add_touch_sensors(spec, model, self.hand)
                model = spec.compile()
            if touch == "contact-sensors":
                for segment in self.hand.segments:
                    spec.add_sensor(name=f"contact_{segment}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                                    objtype=mujoco.mjtObj.mjOBJ_BODY, objname=segment, reftype=mujoco.mjtObj.mjOBJ_BODY,
                                    refname="object", intprm=[_CONTACT_FOUND_FORCE, _CONTACT_MAXFORCE,
                                                              CONTACT_SENSOR_SLOTS])
                model = spec.compile()
        return model

    def _find_addresses(self, table: bool) -> None:
        """The addresses other modules use to read and write the hand's state directly, the touch sensors', the
        mount's, the flange's, the palm's and the object's."""
        model, flange = self.model, self.flange_limits
        joint_ids = [model.joint(name).id for name in self.hand.wrist_joints + self.hand.finger_joints]
        self.hand_qpos = model.jnt_qposadr[joint_ids]
        self.hand_dofs = model.jnt_dofadr[joint_ids]
        self.finger_qpos = self.hand_qpos[2:]
        self.actuator_ids = np.array([model.actuator(name).id for name in self.hand.actuators])
        # the model's own touch sensors (a site each), by the segment their site sits on
        touch_sensors = _touch_sensors(model, self.hand)
        self._touch_adr = np.array([adr for adr, _ in touch_sensors], dtype=int)
        self._touch_segment = np.array([segment for _, segment in touch_sensors], dtype=int)
        self.mount_id = int(model.body(self.hand.mount if flange is None else ARM_BASE).mocapid[0])
        self.flange_locked = False
        if flange is not None:  # the flange's joints and servos (their set points are the servos' activations)
            self.flange_joints = np.array([model.joint(name).id for name in FLANGE_JOINTS])
            self.flange_qpos = model.jnt_qposadr[self.flange_joints]
            self.flange_dofs = model.jnt_dofadr[self.flange_joints]
            self.flange_actuators = np.array([model.actuator(name).id for name in FLANGE_ACTUATORS])
        self.palm_id = model.body(self.hand.palm).id
        self.object_body = model.body("object").id
        self.object_geoms = tuple(int(g) for g in np.flatnonzero(model.geom_bodyid == self.object_body))
        self._fromto = np.zeros(6)  # mj_geomDistance's output buffer, reused by distance_to_object
        self.table_geom = model.geom("table").id if table else None

    def __repr__(self) -> str:
        support = "free" if self.free_object else "welded"
        extras = (", table" if self.table_geom is not None else "") + (", flange" if self.flange_limits else "")
        return (f"Scene({self.object.name} ({self.object.shape}, {support}{extras}), t = {self.time:.3f} s, "
                f"{self.data.ncon} contacts)")

    # -- state -----------------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the model's initial state: hand open and straight, 5 cm in front of the object."""
        mujoco.mj_resetData(self.model, self.data)
        self.flange_locked = False
        self.max_penetration = 0.0  # m, the deepest contact `check` has seen since the reset
        self.set_hand_pose(*facing_pose(self.object, clearance=0.05))

    def forward(self) -> None:
        """Recompute positions, contacts and sensor values without advancing time."""
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        """Advance the physics by n timesteps of 2 ms.

        Args:
            n: timesteps, >= 0.

        Raises:
            SimulationError: the physics failed (see `check`).
        """
        for _ in range(check_int(n, "n (timesteps)", low=0)):
            mujoco.mj_step(self.model, self.data)
        self.check()

    def faults(self) -> list[str]:
        """What is wrong with the physics: MuJoCo's warnings since the last reset (by name, with
        their count), a non-finite state, a contact deeper than PENETRATION_LIMIT now; empty when healthy."""
        found = [f"MuJoCo warning {name} x{self.data.warning[index].number}"
                 for index, name in _WARNINGS if self.data.warning[index].number > 0]
        if not (np.all(np.isfinite(self.data.qpos)) and np.all(np.isfinite(self.data.qvel))):
            found.append("non-finite joint positions or velocities")
        if self.penetration() > PENETRATION_LIMIT:
            found.append(f"a contact penetrates {self.penetration() * 1000:.1f} mm "
                         f"(limit {PENETRATION_LIMIT * 1000:.0f} mm)")
        return found

    def healthy(self) -> bool:
        """No fault (see `faults`), checked fast: MuJoCo itself warns about (and resets) non-finite
        or huge positions, velocities and accelerations, so its warning counters and the deepest
        contact are all this reads."""
        return not self.data.warning.number.any() and self.penetration() <= PENETRATION_LIMIT

    def check(self) -> None:
        """Raise SimulationError if the physics failed (see `faults`); `step` and `run` call it.
        Keeps `max_penetration` up to date."""
        depth = self.penetration()
        self.max_penetration = max(self.max_penetration, depth)
        if self.data.warning.number.any() or depth > PENETRATION_LIMIT:
            found = self.faults()
            raise SimulationError(f"the simulation of the {self.object.name} scene failed at "
                                  f"t = {self.data.time:.3f} s: {'; '.join(found)}; its state is not "
                                  "physical (reset() to start again)")

    def penetration(self) -> float:
        """The deepest penetration (m) of any contact now (0 when nothing overlaps)."""
        ncon = self.data.ncon
        return max(0.0, -float(self.data.contact.dist[:ncon].min())) if ncon else 0.0

    def run(self, seconds: float) -> None:
        """Advance the physics by (about) this much simulated time, at least one timestep.

        Args:
            seconds: simulated seconds, > 0.

        Raises:
            SimulationError: the physics failed (see `check`).
        """
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds) \
                or seconds <= 0:
            raise InvalidInput(f"seconds must be a positive finite duration, got {seconds!r}")
        self.step(max(1, round(seconds / self.model.opt.timestep)))

    @property
    def time(self) -> float:
        return float(self.data.time)

    def set_object_support(self, stiffness: float = 0.0, damping: float = 0.0) -> None:
        """A spring-damper holding a free object near its start pose, like a support it rests on; 0, 0
        releases it.

        Args:
            stiffness: N/m (and N m/rad for rotation).
            damping: N s/m (and N m s/rad).
        """
        if not self.free_object:
            raise InvalidInput("set_object_support needs a Scene with free_object=True")
        if not (np.isfinite(stiffness) and np.isfinite(damping)) or stiffness < 0 or damping < 0:
            raise InvalidInput(f"stiffness and damping must be finite and >= 0, got {stiffness!r}, {damping!r}")
        joint = self.model.joint("object_free")
        self.model.jnt_stiffness[joint.id] = stiffness
        self.model.dof_damping[joint.dofadr[0]: joint.dofadr[0] + 6] = damping

    def anchor_object_support(self) -> None:
        """Move the support's rest pose (`set_object_support`) to where the free object lies now, and stop the
        object there: re-engaged, the support catches the object where it is instead of pulling it back to its
        start. It is stopped because the support's damping on a moving object is an impulse MuJoCo's contact
        solver cannot balance: the damping acts implicitly in the integration but as a force in the solve, and on
        a 10 g marble spinning at 3 rad/s that force is a thousand times what its inertia bears in a time step (a
        finger touching it then flung both at tens of m/s)."""
        if not self.free_object:
            raise InvalidInput("anchor_object_support needs a Scene with free_object=True")
        joint = self.model.joint("object_free")
        self.model.qpos_spring[joint.qposadr[0]: joint.qposadr[0] + 7] = self.data.qpos[joint.qposadr[0]:
                                                                                         joint.qposadr[0] + 7]
        self.data.qvel[joint.dofadr[0]: joint.dofadr[0] + 6] = 0.0

    def set_table(self, present: bool) -> None:
        """Put the table back or take it away (a Scene made with table=True).

        Args:
            present: True to put it back, False to take it away.
        """
        if self.table_geom is None:
            raise InvalidInput("set_table needs a Scene made with table=True")
        self.model.geom_contype[self.table_geom] = self.model.geom_conaffinity[self.table_geom] = int(bool(present))

    def set_gravity(self, gravity: bool | Iterable[float]) -> None:
        """Gravity on, off, or along a vector.

        Args:
            gravity: True (-z of the world), False, or a vector (3,), m/s^2.
        """
        if gravity is True:
            vector = np.array([0.0, 0.0, -GRAVITY])
        elif gravity is False:
            vector = np.zeros(3)
        else:
            vector = check_vec3(gravity, "gravity")
        self.model.opt.gravity[:] = vector

    # -- hand placement --------------------------------------------------------------------------
    def object_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Current object pose in the world (position, quaternion)."""
        return self.data.xpos[self.object_body].copy(), self.data.xquat[self.object_body].copy()

    def hand_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Current palm pose in the object frame."""
        mujoco.mj_kinematics(self.model, self.data)
        palm = self.data.xpos[self.palm_id], self.data.xquat[self.palm_id]
        return compose(*invert(*self.object_pose()), *palm)

    def mount_pose_for(self, pos: Iterable[float], quat: Iterable[float]) -> tuple[np.ndarray, np.ndarray]:
        """The pose of the mocap body `hand_mount` that puts the palm at (pos, quat) in the object frame, for
        the current joint angles.

        Args:
            pos: the palm's position (3,), m, object frame.
            quat: its orientation (4,), w x y z.

        Returns:
            The mount's position (3,), m, and orientation (4,).
        """
        pos, quat = check_vec3(pos, "pos"), check_quat(quat, "quat")
        mujoco.mj_kinematics(self.model, self.data)
        target = compose(*self.object_pose(), pos, quat)
        mount = self.data.mocap_pos[self.mount_id].copy(), self.data.mocap_quat[self.mount_id].copy()
        mount_to_palm = compose(*invert(*mount), self.data.xpos[self.palm_id], self.data.xquat[self.palm_id])
        return compose(*target, *invert(*mount_to_palm))

    def mount_poses_for(self, pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`mount_pose_for` of many palm poses at once, for the current joint angles, in array arithmetic (equal to
        it but for the last bits): where the hands of many trials are placed without a scene each.

        Args:
            pos: (n, 3) the palm's positions, m, object frame.
            quat: (n, 4) its orientations, w x y z, unit.

        Returns:
            The mount's positions (n, 3), m, and orientations (n, 4).
        """
        mujoco.mj_kinematics(self.model, self.data)
        mount = self.data.mocap_pos[self.mount_id].copy(), self.data.mocap_quat[self.mount_id].copy()
        mount_to_palm = compose(*invert(*mount), self.data.xpos[self.palm_id], self.data.xquat[self.palm_id])
        target = compose_many(*self.object_pose(), pos, quat)
        return compose_many(*target, *invert(*mount_to_palm))

    def set_hand_pose(self, pos: Iterable[float], quat: Iterable[float]) -> None:
        """Move the hand so that the palm frame has this pose in the object frame.

        Args:
            pos: the palm's position (3,), m.
            quat: its orientation (4,), w x y z.
        """
        if self.flange_limits is not None:  # placed with the flange at home, at rest, its servos holding it there
            self.data.qpos[self.flange_qpos] = self.data.qvel[self.flange_dofs] = 0.0
            self.data.ctrl[self.flange_actuators] = 0.0
        self.data.mocap_pos[self.mount_id], self.data.mocap_quat[self.mount_id] = self.mount_pose_for(pos, quat)
        self.forward()
        self._placed = self.data.mocap_pos[self.mount_id].copy(), self.data.xmat[self.palm_id].reshape(3, 3).copy()

    def shift_hand(self, offset: Iterable[float]) -> None:
        """Move the hand from where `set_hand_pose` last put it, as an arm would carry it; the joints and
        the object stay (the physics moves on at the next step).

        Args:
            offset: (3,), m, in the palm frame.
        """
        position, palm_rotation = self._placed
        self.data.mocap_pos[self.mount_id] = position + palm_rotation @ check_vec3(offset, "offset")

    # -- the flange --------------------------------------------------------------------------------
    def flange(self) -> np.ndarray:
        """Where the flange is from home.

        Returns:
            (6,): the slides along the palm's x, y, z (m), the hinges about them (rad).

        Raises:
            InvalidInput: the scene has no flange.
        """
        self._check_flange()
        return self.data.qpos[self.flange_qpos].copy()

    def flange_axes(self) -> np.ndarray:
        """The directions the flange's slides move the palm, in the world; they do not turn with the hinges, which
        follow the slides.

        Returns:
            (3, 3): one unit vector per row, the palm's x, y, z where the hand was placed.

        Raises:
            InvalidInput: the scene has no flange.
        """
        self._check_flange()
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.xaxis[self.flange_joints[:3]].copy()

    def flange_set_point(self) -> np.ndarray:
        """Where the flange's servos hold it (they pull the flange there with bounded force).

        Returns:
            (6,): m along the palm's x, y, z and rad about them, from home.

        Raises:
            InvalidInput: the scene has no flange.
        """
        self._check_flange()
        return self.data.ctrl[self.flange_actuators].copy()

    def steer_flange(self, target: ArrayLike, period: float) -> None:
        """Move the flange's set point towards a pose from home for one control period: each joint's by at most its
        speed (`FlangeLimits.speeds`) times `period`, within the travel; it stays there until steered again.

        Args:
            target: (6,), m along the palm's x, y, z and rad about them, from home (clipped to the travel).
            period: s, the control period (> 0).

        Raises:
            InvalidInput: the scene has no flange, it is locked, or not 6 finite values; a period not > 0.
        """
        self._check_flange()
        try:
            given = np.asarray(target)
        except ValueError:  # a ragged list
            given = np.full(0, np.nan)
        if given.shape != (6,) or given.dtype.kind not in "iuf" or not np.all(np.isfinite(given)):
            raise InvalidInput(f"target must be 6 finite real numbers (m, rad from home), got {target!r}")
        goal = given.astype(float)
        period = check_number(period, "period", Bounds(above_low=True, unit="s"))
        if self.flange_locked:
            raise InvalidInput("the flange is locked: unlock_flange() before steering it")
        limits, now = self.flange_limits, self.data.ctrl[self.flange_actuators]
        assert limits is not None  # _check_flange refused a scene without one
        step = np.clip(np.clip(goal, -limits.reach(), limits.reach()) - now, -limits.speeds() * period,
                       limits.speeds() * period)
        self.data.ctrl[self.flange_actuators] = now + step

    def lock_flange(self) -> None:
        """Lock the mount: the servos hold their set points and `steer_flange` is refused until `unlock_flange`."""
        self._check_flange()
        self.flange_locked = True

    def unlock_flange(self) -> None:
        """Let `steer_flange` move the flange again."""
        self._check_flange()
        self.flange_locked = False

    def _check_flange(self) -> None:
        if self.flange_limits is None:
            raise InvalidInput("this scene has no flange: make it with Scene(..., flange=FlangeLimits())")

    # -- postures --------------------------------------------------------------------------------
    def distance_to_object(self, geom: int, cutoff: float = 0.05) -> float:
        """Distance from a geom to the object's collision geometry at the current kinematics (the nearest
        of a mesh's convex parts).

        Args:
            geom: the geom's id.
            cutoff: the largest distance looked for, m.

        Returns:
            The distance, m: negative when they overlap, `cutoff` when farther.
        """
        return min(mujoco.mj_geomDistance(self.model, self.data, geom, g, cutoff, self._fromto)
                   for g in self.object_geoms)

    def touch(self) -> np.ndarray:
        """What the hand model's own touch sensors feel (a model with them, e.g. `gymnasium-robotics-touch`):
        the sum of each segment's sensors, the second way to feel besides the contact forces (`tactile`).

        Returns:
            Forces (len(SEGMENTS),), N, in `SEGMENTS` order.

        Raises:
            InvalidInput: the hand model has no touch sensors.
        """
        if not len(self._touch_adr):
            raise InvalidInput(f"the {self.hand.name!r} hand model has no touch sensors (e.g. gymnasium-robotics-touch)")
        return np.bincount(self._touch_segment, weights=self.data.sensordata[self._touch_adr],
                           minlength=len(self.hand.segments))

    def segment_forces(self) -> np.ndarray:
        """What the controller senses now: the normal force on each tactile segment, from the scene's touch source.

        Returns:
            Forces (len(SEGMENTS),), N, in `SEGMENTS` order: the hand-object contacts' (`TactileSensor`), the touch
            sensors' (`touch`) or the segment-object contact sensors'.
        """
        if self.touch_source == "contact-sensors":  # each slot: the count found, then its force (normal first)
            adr = self.model.sensor(f"contact_{self.hand.segments[0]}").adr[0]
            slots = self.data.sensordata[adr:adr + len(self.hand.segments) * CONTACT_SENSOR_SLOTS * 4]
            return slots.reshape(len(self.hand.segments), CONTACT_SENSOR_SLOTS, 4)[:, :, 1].sum(axis=1)
        return self.touch() if self.touch_source == "sensors" else self.sensor.segment_forces(self.data)

    def posture(self) -> np.ndarray:
        """The current 22 finger joint angles (radians, FINGER_JOINTS order, the paper's sense)."""
        return self.hand.from_model(self.data.qpos[self.finger_qpos])

    def set_posture(self, posture: np.ndarray, wrist: Iterable[float] = (0.0, 0.0)) -> None:
        """Put the hand in a posture at rest and make the actuators hold it.

        Args:
            posture: 22 finger joint angles, rad.
            wrist: (WRJ2, WRJ1), rad.
        """
        posture = validate_posture(posture, check_limits=True, hand=self.hand)
        ctrl = posture_to_ctrl(posture, wrist, self.hand)
        self.data.qpos[self.finger_qpos] = self.hand.to_model(posture)
        self.data.qpos[self.hand_qpos[:2]] = ctrl[self.hand.wrist_rows]
        self.data.qvel[self.hand_dofs] = 0.0
        self.data.ctrl[self.actuator_ids] = ctrl
        self.forward()

    def set_target(self, posture: np.ndarray, wrist: Iterable[float] = (0.0, 0.0)) -> None:
        """Command the actuators towards a posture (the hand moves when the physics steps).

        Args:
            posture: 22 finger joint angles, rad.
            wrist: (WRJ2, WRJ1), rad.
        """
        posture = validate_posture(posture, name="target", check_limits=True, hand=self.hand)
        self.data.ctrl[self.actuator_ids] = posture_to_ctrl(posture, wrist, self.hand)

    # -- pictures --------------------------------------------------------------------------------
    def state(self) -> np.ndarray:
        """What a picture of the scene depends on, as one flat array: joint positions and the
        hand mount's pose (`render_states` draws a list of them, e.g. the frames of a trial)."""
        return np.concatenate([self.data.qpos, self.data.mocap_pos[self.mount_id], self.data.mocap_quat[self.mount_id]])

    def render(self, camera: str = "hand", width: int = 320, height: int = 240) -> np.ndarray:
        """An RGB picture of the scene now, drawn offscreen (works on a headless machine).

        On a headless Linux machine the library chose the offscreen backend on import and the picture is
        drawn in this process; otherwise by one child process kept for the pictures that follow
        (`graspmanifold.sim.render` says when and why).

        Args:
            camera: one of `CAMERAS`, or `render.THUMB_SIDE`.
            width: pixels, 16 ... 4096.
            height: pixels, 16 ... 4096.

        Returns:
            The picture, (height, width, 3) uint8.

        Raises:
            RenderingUnavailable: no offscreen OpenGL backend works; the message says what to install.
        """
        return render_states(self, self.state()[None], camera, width, height)[0]

    def viewer(self) -> mujoco.viewer.Handle:
        """MuJoCo's interactive viewer on this scene, passive: the scene keeps stepping in this program.

        Call `.sync()` on the returned handle after `run` or `step` to show the new state, and `.close()`
        when done (`graspmanifold view` opens one from the command line).

        Returns:
            The viewer's handle (`mujoco.viewer.Handle`).

        Raises:
            RenderingUnavailable: there is no display (pictures work without one: `render`).
        """
        if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise RenderingUnavailable("the viewer needs a display (DISPLAY is not set); on a headless machine draw "
                                       "pictures with Scene.render or record_trial(...).save_gif")
        import mujoco.viewer

        return mujoco.viewer.launch_passive(self.model, self.data)

    def to_xml(self) -> str:
        """The scene's MJCF: the hand, the object (and the table, with one) as MuJoCo compiled them.

        Returns:
            The XML text, loadable with `mujoco.MjModel.from_xml_string` (a mesh object's convex
            parts are embedded as vertex lists; a flanged scene's test writes and loads it back).
        """
        with without_empty_prefix_warning():
            return self.spec.to_xml()

    def _repr_png_(self) -> bytes | None:
        """A notebook shows a scene as its picture from the hand camera (nothing without OpenGL)."""
        try:
            return png_bytes(self.render())
        except RenderingUnavailable:
            return None

    # -- sensing ---------------------------------------------------------------------------------
    def tactile(self) -> TactileReading:
        """Hand-object contacts now (see TactileReading)."""
        return self.sensor.read(self.data)
