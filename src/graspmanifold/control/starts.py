"""Starting postures: designed grasps that the spring-based generator explores around.

The paper actuated its starting postures by hand, each a five-fingertip grasp. Here each one comes
from a designed grasp (a palm pose relative to the object, a hand posture and the segments that
must touch, see `GraspDesign`) refined by a deterministic least-squares search over the 22 joints
and a small hand-pose correction, which brings the design's contact segments onto the surface,
keeps every other segment out of the object and the fingers out of each other.

Two families of designs (`DESIGN_FAMILIES`): `five_fingertip`, the paper's kind (all five distal
segments touch; wraps of the object's nearest primitive shape, `GRASP_DESIGNS`), and
`grasp_types`, ours and the generator's default: those wraps (power grasps; on an elongated object also
moved along its axis, `SHIFTED_WRAPS`) and one design of each precision grasp type (`PRECISION_DESIGNS`:
a two-finger pinch of thumb and index tips, a tripod of thumb, index and middle tips, and a lateral grasp
pressing the object between the thumb's pad and the side of the index finger, each also at the object's
edge), with the fingers that take no part curled into the palm. A design of this
family is kept only in a refinement whose start holds the object when the generator's verifier replays
it (`REFINEMENTS`, `GraspVerifier`): the paper's wraps, refined to touch alone, mostly do not (their
thumb presses sideways and slides off under the squeeze), so the family's refinements also ask the
contacts' pushes to cancel.

The paper's objects and the benchmark's (`benchmark.OBJECTS`) ship their starting postures of both
families in `assets/starting_postures.npz` (made by `scripts/find_starting_postures.py`), the object family
its five-fingertip ones and the grasp-types ones of every member not held out (`family.HELD_OUT`); the
rest is searched on first use (`generator.starting_postures`: seconds to half a minute per object) and
kept in `generator.cache_directory()`, so that the next process reads it (a user can also give their own:
`generate_postures(..., starts=...)`, each a `StartingPosture`, e.g. a rough grasp brought onto the surface
by `refine`). A mesh object
is searched with the designs of the primitive it is closest to in proportion (`designs_for`): the
designs place the palm relative to the object's principal axes and its extents, and the
least-squares refinement brings the fingertips onto the actual surface, so any watertight solid of
hand size gets its grasps this way.
"""

from __future__ import annotations

import copy
import multiprocessing
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cache, partial

import mujoco
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput, SimulationError
from ..base.io import load_npz, save_npz
from ..base.poses import compose, invert, rotvec_quat
from ..base.progress import progress_bar
from ..base.workers import default_workers, parallel_map
from ..sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, SEGMENTS, asset_path, finger_of, segment_of_geoms
from ..sim.objects import GraspObject, get_object
from ..sim.posture import dict_to_posture
from ..sim.scene import GRASP_CENTRE_IN_PALM, PALM_HALF_THICKNESS, Scene
from .controller import FLEXION
from .judge import GraspVerifier

STARTS_FILE = "starting_postures.npz"
CONTACT_GAP = 0.001  # a contact segment "touches" within 1 mm
MAX_PENETRATION = 0.002
#: the search measures exactly only the distances below this (m); farther geoms are clear of each other
CLEAR = 0.01
#: the search's distances: MuJoCo's convex distance run to this tolerance and at most these iterations
#: (`mjOption.ccd_tolerance`, `ccd_iterations`; the simulation's 1e-6 and 35 leave about 1e-10 m of noise)
SEARCH_CCD_TOLERANCE = 1e-12
SEARCH_CCD_ITERATIONS = 200
#: the search takes a hand box for a box of rounded edges of this radius (m, at most half its smallest size)
BOX_ROUNDING = 0.004
#: a primitive's pushes (`_GraspGeometry.pushes`): points along each contact's core, and how fast a point's weight
#: falls with its distance to the object (m)
PUSH_SAMPLES = 9
PUSH_REACH = 0.002
#: the bend of a primitive's smooth outward directions at its edges (`_outward`), m
PUSH_BEND = 0.001
#: `_GraspGeometry.pressing`'s squeeze: how far it turns each flexion joint towards the closed hand (rad, or as far
#: as the closed angle, `controller.squeezed`), and how smoothly it bends between the two (rad)
SQUEEZE = 0.05
SQUEEZE_BEND = 0.005
#: the forward-difference step of the search's Jacobian (rad for joints and turns, m for the palm's position):
#: with distances good to about 1e-13 m its derivatives are good to about 1e-6 of their size
JACOBIAN_STEP = 1e-6
#: the trust-region search's most iterations (`_search`)
SEARCH_ITERATIONS = 300
#: `_polish`: Newton's steps at most, the step of its Hessian's differences, and its first trust region (in units
#: of `_SCALE`: the joints' radians, the palm's 3 cm and half radian, the reach of the search)
POLISH_STEPS = 150
HESSIAN_STEP = 1e-6
POLISH_REACH = 0.05
POLISH_FLOOR = 1e-12
_SCALE = np.concatenate([np.ones(22), np.full(3, 0.03), np.full(3, 0.5)])
#: the width of the search's smooth hinges (`soft_hinge`): of the clearances, m, and of the squeeze's cosine
HINGE_WIDTH = 2e-4
PRESS_WIDTH = 0.05
#: `refine(press=...)` asks the squeeze's motion of each contact to make at most about 45 degrees with its push
PRESS_COSINE = 0.7

#: the grasp types a design can be (Cutkosky's taxonomy, coarsely): power wraps, the two-finger
#: precision pinch, the three-finger tripod, and the lateral (key) grasp
GRASP_TYPES: tuple[str, ...] = ("power", "precision", "tripod", "lateral")
#: the families of designs `starting_postures` searches (see the module doc)
DESIGN_FAMILIES: tuple[str, ...] = ("five_fingertip", "grasp_types")


@dataclass(frozen=True)
class StartingPosture:
    """A designed grasp: palm pose in the object frame (pos, quat w x y z), 22 joint angles, the
    segments that touch the object (`contacts`, the five distal ones for the paper's kind) and the
    design's grasp type."""

    name: str
    hand_pos: np.ndarray
    hand_quat: np.ndarray
    posture: np.ndarray
    contacts: tuple[str, ...] = DISTAL_SEGMENTS
    grasp_type: str = "power"


@dataclass(frozen=True)
class GraspDesign:
    """A grasp design: the object's centre point in the palm frame, the object axes' directions, the
    hand's posture and the segments that must touch.

    `axis_in_palm` is the palm-frame direction of the object's long axis (z); `standoff` is the gap
    between palm and surface; `hand` lists the joints (name, radians) whose designed angle differs
    from the half-closed hand; `contacts` are the segments that must touch the object.
    """

    name: str
    axis_in_palm: tuple[float, float, float]
    centre_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    standoff: float = 0.008
    roll: float = 0.0  # rotation of the object about its own long axis (radians)
    end_on: bool = False  # the palm faces the object's +z end instead of its side
    edge: float = 0.0  # the object moved along the palm's z by -edge times its y half-extent: the grasp off its middle
    grasp_type: str = "power"
    contacts: tuple[str, ...] = DISTAL_SEGMENTS
    hand: tuple[tuple[str, float], ...] = ()


def _designs(shape: str) -> tuple[GraspDesign, ...]:
    side = (1.0, 0.0, 0.0)  # object axis across the fingers: a wrap
    tilt = (np.cos(0.5), 0.0, np.sin(0.5))
    if shape == "sphere":  # a ball in the whole hand, and held by the five fingertips (a precision sphere grasp)
        return (
            GraspDesign("power", side, standoff=0.006),
            GraspDesign("precision", side, centre_offset=(0.0, 0.0, 0.03), standoff=0.03, grasp_type="precision"),
            GraspDesign("thumb_side", side, centre_offset=(0.02, 0.0, 0.01), standoff=0.015, grasp_type="precision"),
            GraspDesign("fingertip_low", side, centre_offset=(-0.01, 0.0, 0.015), standoff=0.022,
                        grasp_type="precision"),
        )
    designs = [
        GraspDesign("wrap_mid", side),
        GraspDesign("wrap_tilted", tilt),
        GraspDesign("wrap_low", side, centre_offset=(0.0, 0.0, -0.012), standoff=0.012),
        # the five fingertips on the end: a precision disc grasp
        GraspDesign("end_on", (0.0, 0.0, 1.0), centre_offset=(0.0, 0.0, 0.02), standoff=0.01, end_on=True,
                    grasp_type="precision"),
    ]
    if shape == "box":
        designs.append(GraspDesign("wrap_edge", side, roll=np.pi / 4))
    return tuple(designs)


GRASP_DESIGNS = {shape: _designs(shape) for shape in ("box", "cylinder", "sphere")}

#: The `grasp_types` family's further grasps of an elongated object (a cylinder's or a box's designs), moved off
#: the object's middle, where a large or tapered solid can be too wide for the fingers to close around: the mid
#: and the tilted wrap moved along the long axis (`shifted`), and the mid wrap, the tilted wrap and the end-on
#: grasp moved across it (`side`: `edge` -0.3, the other way from the precision grasps' edge).
SHIFTED_WRAPS: tuple[GraspDesign, ...] = (
    GraspDesign("wrap_shifted", (1.0, 0.0, 0.0), centre_offset=(0.035, 0.0, 0.0)),
    GraspDesign("wrap_tilted_shifted", (np.cos(0.5), 0.0, np.sin(0.5)),
                centre_offset=(0.02 * np.cos(0.5), 0.0, 0.02 * np.sin(0.5))),
    *(replace(design, name=f"{design.name}_side", edge=-0.3) for design in GRASP_DESIGNS["cylinder"]
      if design.name in ("wrap_mid", "wrap_tilted", "end_on")),
)

#: a mesh whose longest extent is at most this many times its shortest is grasped like a sphere
ROUND_RATIO = 1.3
#: an elongated mesh whose two short extents differ by at most this factor is grasped like a cylinder
ROUND_SECTION_RATIO = 1.1


def nearest_primitive(obj: GraspObject) -> str:
    """The paper shape an object is closest to in proportion: its own for a primitive; for a mesh a
    sphere when it is about as long as it is wide (`ROUND_RATIO`), a cylinder when it is elongated
    with a round-ish section (`ROUND_SECTION_RATIO`), otherwise a box."""
    if obj.shape != "mesh":
        return obj.shape
    x, y, z = np.sort(obj.half_extents)
    if z <= ROUND_RATIO * x:
        return "sphere"
    return "cylinder" if y <= ROUND_SECTION_RATIO * x else "box"


def _curled(*fingers: str) -> tuple[tuple[str, float], ...]:
    """Joint angles that curl these fingers ('MF', 'RF', 'LF') into the palm, out of a precision grasp."""
    return tuple((f"{f}J{j}", a) for f in fingers for j, a in ((3, 1.3), (2, 1.4), (1, 1.0)))


#: One design per precision grasp type, for any object: the object's centre sits where the thumb's tip
#: meets the index (and middle) finger's tip, about 4 cm above the palm's centre and 2 cm in front of
#: it, or, for the lateral grasp, against the thumb-side face of the curled index finger's middle
#: segment; the refinement then moves the hand by up to 3 cm and 0.5 rad to make the contacts.
PRECISION_DESIGNS: tuple[GraspDesign, ...] = (
    GraspDesign("pinch", (1.0, 0.0, 0.0), centre_offset=(0.018, 0.0, 0.045), standoff=0.015, grasp_type="precision",
                contacts=("ffdistal", "thdistal"), hand=_curled("MF", "RF", "LF")),
    GraspDesign("tripod", (1.0, 0.0, 0.0), centre_offset=(0.008, 0.0, 0.04), standoff=0.02, grasp_type="tripod",
                contacts=("ffdistal", "mfdistal", "thdistal"), hand=_curled("RF", "LF")),
    GraspDesign("lateral", (1.0, 0.0, 0.0), centre_offset=(0.037, 0.0, 0.035), standoff=0.012, grasp_type="lateral",
                contacts=("ffmiddle", "thdistal"),
                hand=(("FFJ3", 1.0), ("FFJ2", 1.2), ("FFJ1", 0.6), ("THJ5", 0.2), ("THJ4", 0.7), ("THJ1", 0.2),
                      *_curled("MF", "RF", "LF"))),
)
#: the precision designs again at the object's edge, 60 % of the way from its middle (the rim of a ring, whose
#: middle is a hole; the edge of a plate or a box)
PRECISION_DESIGNS += tuple(replace(design, name=f"{design.name}_edge", edge=0.6) for design in PRECISION_DESIGNS)


def designs_for(obj: GraspObject, family: str = "five_fingertip") -> tuple[GraspDesign, ...]:
    """The grasp designs to search for an object in a family (`DESIGN_FAMILIES`).

    `five_fingertip`: those of its `nearest_primitive` (a cylinder's: wraps about the long axis z,
    tilted, low, end-on; a box's add a wrap rolled 45 degrees). `grasp_types`: these power grasps, for
    an elongated object (not sphere-like) the `SHIFTED_WRAPS`, and the `PRECISION_DESIGNS`. The refinement then adapts each design to the actual surface;
    designs that do not fit the object (a pinch of a ball too big to pinch) find no valid grasp.
    """
    if family not in DESIGN_FAMILIES:
        raise InvalidInput(f"family must be one of {DESIGN_FAMILIES}, got {family!r}")
    shape = nearest_primitive(obj)
    if family == "five_fingertip":
        return GRASP_DESIGNS[shape]
    return GRASP_DESIGNS[shape] + (SHIFTED_WRAPS if shape != "sphere" else ()) + PRECISION_DESIGNS


_HALF_CLOSED = dict_to_posture({
    **{f"{f}J{j}": a for f in ("FF", "MF", "RF", "LF") for j, a in ((3, 0.7), (2, 0.6), (1, 0.5))},
    "FFJ4": 0.0, "MFJ4": 0.0, "RFJ4": 0.0, "LFJ4": 0.0, "LFJ5": 0.2,
    "THJ5": 0.7, "THJ4": 1.1, "THJ3": 0.1, "THJ2": 0.2, "THJ1": 0.4,
})


def design_posture(design: GraspDesign) -> np.ndarray:
    """The hand posture a design starts its search from: the half-closed hand with the design's joints."""
    posture = _HALF_CLOSED.copy()
    for joint, angle in design.hand:
        posture[FINGER_JOINTS.index(joint)] = angle
    return posture


def design_pose(obj: GraspObject, design: GraspDesign) -> tuple[np.ndarray, np.ndarray]:
    """The palm pose (object frame) a grasp design asks for."""
    # rotation palm -> object: the object's z maps to `axis_in_palm` in the palm frame
    if design.end_on:
        # the palm's inner normal (-y) looks down the object's -z; fingers (palm z) along object x
        palm_in_object = np.column_stack([(0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
        extent = obj.half_extents[2]
    else:
        axis = np.asarray(design.axis_in_palm, dtype=float)
        axis /= np.linalg.norm(axis)
        normal = np.array([0.0, -1.0, 0.0])  # palm inner normal, in the palm frame
        third = np.cross(axis, normal)
        object_in_palm = np.column_stack([normal, third, axis]) @ Rotation.from_rotvec([0, 0, design.roll]).as_matrix()
        palm_in_object = object_in_palm.T
        extent = obj.half_extents[0]
    centre_in_palm = GRASP_CENTRE_IN_PALM + np.asarray(design.centre_offset) - [
        0.0, PALM_HALF_THICKNESS + design.standoff + extent, design.edge * obj.half_extents[1]]
    pos = -palm_in_object @ centre_in_palm
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, palm_in_object.ravel())
    return pos, quat


class _GraspGeometry:
    """Fast kinematic queries for the search: geom distances and their Jacobians, pushes and the squeeze's motion,
    for a posture and a palm pose.

    The geometry measures on its own copy of the scene's model in which every hand geom is a core and a radius:
    a capsule's segment or a sphere's centre and its radius; a box shrunk by `BOX_ROUNDING` on every side and
    that much (a box with rounded edges, which the search takes for the box). Distances are measured between the
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
        fingers = {g: finger_of(SEGMENTS[segment_of[g]]) for g in hand_geoms}
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
        self._pairs = np.array(pairs, dtype=int).reshape(-1, 2)  # geoms of neighbouring fingers
        self._dofs = np.asarray(scene.hand_dofs[2:])  # the finger joints' degrees of freedom
        self._bodies = sorted({int(model.geom_bodyid[g]) for g in hand_geoms})
        self._palm = np.zeros(3)
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
        witnesses: list[list] = [[w for _, w in measured], [None] * len(self.other), [None] * len(self._pairs)]
        apart = np.linalg.norm(centres[self.other][:, None] - centres[self._object][None], axis=2)
        other = np.min(apart - bounds[self.other][:, None] - bounds[self._object][None], axis=1)
        for i in np.flatnonzero(other < CLEAR):
            other[i], witnesses[1][i] = self._to_object(self.other[i])
        a, b = self._pairs.T
        pairs = np.linalg.norm(centres[a] - centres[b], axis=1) - bounds[a] - bounds[b]
        for i in np.flatnonzero(pairs < CLEAR):
            cores = self.radius[a[i]] + self.radius[b[i]]
            gap = mujoco.mj_geomDistance(model, data, a[i], b[i], 0.3 + cores, self._fromto)
            pairs[i], witnesses[2][i] = gap - cores, (a[i], b[i], gap, self._fromto.copy())
        self._witnesses = witnesses
        return distal, other, pairs

    def _frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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

    def _points_jacobian(self, points: np.ndarray, geoms: np.ndarray,
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
        rows = [np.zeros((len(self.distal), 28)), np.zeros((len(self.other), 28)), np.zeros((len(self._pairs), 28))]
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
        placement. On a mesh object: from the point of a geom's core (a capsule's segment, a sphere's centre)
        nearest the object towards the object's nearest point (its collision geometry: the convex parts). On a
        primitive (`push_jacobians`): the mean of the directions at `PUSH_SAMPLES` points along the core towards
        the object (`_outward`), weighed by exp(-distance / `PUSH_REACH`): the nearer points count, and the
        direction turns smoothly where the nearest point reaches a segment's end or an edge of the object."""
        if self.scene.object.mesh is not None:
            points = np.array([self._nearest_part(geom, 1.0)[1] for geom in self.pushing]).reshape(-1, 6)
            return _unit(points[:, 3:] - points[:, :3])
        return self.push_jacobians(rows=False)[0]

    def push_jacobians(self, rows: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """A primitive's `pushes` (len(distal), 3) and their Jacobians (len(distal), 3, 28) with respect to the
        finger joints, the palm's translation and its rotation (as `distance_jacobians`), exact: each sample point's
        motion (mj_jac), the weights' change with the samples' distances, the outward directions' change with
        the samples (central differences of the closed form, `_outward`)."""
        obj, geoms = self.scene.object, self.pushing
        half = self.data.geom_xmat[geoms].reshape(-1, 3, 3)[:, :, 2] * self.model.geom_size[geoms, 1][:, None]
        along = np.linspace(-1.0, 1.0, PUSH_SAMPLES)
        samples = (self.data.geom_xpos[geoms][:, None] + along[None, :, None] * half[:, None]).reshape(-1, 3)
        towards = obj.closest_point(samples) - samples
        gaps = np.linalg.norm(towards, axis=1).reshape(len(geoms), -1)
        weights = np.exp(-(gaps - gaps.min(axis=1, keepdims=True)) / PUSH_REACH).reshape(-1)
        out = _outward(obj, samples)
        inward = -_unit(out)
        total = np.sum((weights[:, None] * inward).reshape(len(geoms), -1, 3), axis=1)
        pushes = _unit(total)
        if not rows:
            return pushes, None
        moves = self._points_jacobian(samples, np.repeat(geoms, PUSH_SAMPLES), self._frames())  # (n, 3, 28)
        closer = -np.einsum("ni,nij->nj", _unit(towards), moves)  # each sample's distance
        step = 1e-7
        bend = np.stack([(_outward(obj, samples + step * e) - _outward(obj, samples - step * e)) / (2 * step)
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

    def _nearest_on_cores(self, geoms: list[int], cores: np.ndarray) -> np.ndarray:
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
        slope = 1.0 - _hinge_slope(towards - SQUEEZE, SQUEEZE_BEND) - _hinge_slope(-towards - SQUEEZE, SQUEEZE_BEND)
        return posture + turn * FLEXION, 1.0 - slope * FLEXION

    def pressing(self, posture: np.ndarray, pushes: np.ndarray) -> np.ndarray:
        """Cosines (len(distal),) between where the controller's squeeze moves each contact geom (a small
        `controller.squeezed` of the posture, at the current hand pose, its bends made smooth over `SQUEEZE_BEND`)
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
            moves_after = self._points_jacobian(after, geoms, self._frames())
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


def _outward(obj: GraspObject, points: np.ndarray) -> np.ndarray:
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


def _hinge_slope(x: np.ndarray, width: float) -> np.ndarray:
    """The derivative of `soft_hinge` (a logistic function of x / width)."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x) / width))


def _hinge_bend(x: np.ndarray, width: float) -> np.ndarray:
    """The second derivative of `soft_hinge`."""
    slope = _hinge_slope(x, width)
    return slope * (1.0 - slope) / width


def _left_jacobian(rotvec: np.ndarray) -> np.ndarray:
    """(3, 3): the small turn (rad, fixed frame) that a change of a rotation vector makes of its rotation."""
    angle = float(np.linalg.norm(rotvec))
    x, y, z = rotvec
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    if angle < 1e-6:  # the series' first terms
        return np.eye(3) + 0.5 * cross + cross @ cross / 6.0
    return (np.eye(3) + (1.0 - np.cos(angle)) / angle**2 * cross
            + (angle - np.sin(angle)) / angle**3 * cross @ cross)


def _search(measure: Callable[[np.ndarray], np.ndarray],
            measure_jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
            weigh: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
            anchor: np.ndarray, reference: np.ndarray, start: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]
            ) -> np.ndarray:
    """A least-squares search run to its local minimum over residuals of two kinds: weighed measures
    (`weigh(measure(v))`: each measure's weighed value, slope and bend: the terms of the geometry) and
    `anchor * (v - reference)` (the terms that keep the search near the design).

    A trust-region search (`scipy.optimize.least_squares`) brings it near the minimum; its Jacobian is the chain
    rule of the weights' exact slopes and the measures' Jacobian (`measure_jacobian`: the measures and their
    rows; a smooth hinge's bend is far sharper than the geometry's, and differencing through it gave derivatives
    off by a part in a thousand). That search models the cost by the Jacobian alone, and where the residuals are
    large (a press or balance term that cannot be met) or the cost is flat (the weak pull towards the design) it
    crawls and stops wherever its steps stop paying, a place that moves with the last bits of its inputs. So
    Newton's method then finishes (`_polish`)."""

    def fun(v: np.ndarray) -> np.ndarray:
        return np.concatenate([weigh(measure(v))[0], anchor * (v - reference)])

    def jacobian(v: np.ndarray) -> np.ndarray:
        measures, rows = measure_jacobian(v)
        return np.vstack([weigh(measures)[1][:, None] * rows, np.diag(anchor)])

    result = least_squares(fun, start, jac=jacobian, bounds=bounds, x_scale="jac", max_nfev=SEARCH_ITERATIONS,
                           ftol=None, xtol=1e-12, gtol=1e-8)
    return _polish(measure_jacobian, weigh, anchor, reference, result.x, bounds)


def _polish(measure_jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
            weigh: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
            anchor: np.ndarray, reference: np.ndarray, x: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]
            ) -> np.ndarray:
    """A trust-region Newton's method from near a minimum of `_search`'s cost to the minimum itself, whose place
    does not move with the last bits of where it started.

    The Hessian is the Jacobian's square, the weights' bends (exact) and the measures' own curvature, weighed by
    the residuals' slopes: differences of `HESSIAN_STEP` of the measures' Jacobian at the start, then kept by
    symmetric rank-one updates from the gradients of the points it tries (a structured quasi-Newton method, as
    NL2SOL's), so that large residuals and directions of negative curvature are modelled at the cost of one
    evaluation a step. Each step minimises that model within a trust region (of `POLISH_REACH` at first, in units
    of `_SCALE`); a joint or pose at its bound that the gradient pushes out stays there. It stops after
    `POLISH_STEPS` or at a step below 1e-11."""
    lower, upper = bounds

    def evaluate(v: np.ndarray) -> tuple:
        measures, rows = measure_jacobian(v)
        values, slopes, bends = weigh(measures)
        residuals = np.concatenate([values, anchor * (v - reference)])
        jacobian = np.vstack([slopes[:, None] * rows, np.diag(anchor)])
        return 0.5 * float(residuals @ residuals), values, slopes, bends, rows, jacobian, jacobian.T @ residuals

    def bent(rows: np.ndarray, pull: np.ndarray) -> np.ndarray:  # the measures' gradient, weighed by `pull`
        return rows.T @ pull

    radius = POLISH_REACH
    cost, values, slopes, bends, rows, jacobian, gradient = evaluate(x)
    pull = values * slopes
    curvature = np.column_stack([(bent(measure_jacobian(x + HESSIAN_STEP * e)[1], pull) - bent(rows, pull))
                                 / HESSIAN_STEP for e in np.eye(x.size)])
    curvature = 0.5 * (curvature + curvature.T)
    for _ in range(POLISH_STEPS):
        held = ((x - lower <= 1e-12) & (gradient > 0)) | ((upper - x <= 1e-12) & (gradient < 0))
        free = np.flatnonzero(~held)
        hessian = jacobian.T @ jacobian + rows.T @ ((values * bends)[:, None] * rows) + curvature
        hessian = hessian[np.ix_(free, free)]
        scale = _SCALE[free]
        step = np.zeros_like(x)
        step[free] = scale * _trust_step(scale[:, None] * hessian * scale[None, :], scale * gradient[free], radius)
        moved = np.clip(x + step, lower, upper) - x
        if np.abs(moved).max() < 1e-11:
            break
        predicted = -(gradient @ moved + 0.5 * moved[free] @ hessian @ moved[free])
        trial = evaluate(x + moved)
        # the secant of the measures' curvature between here and the trial point (a symmetric rank-one update)
        change = bent(trial[4], trial[1] * trial[2]) - bent(rows, trial[1] * trial[2]) - curvature @ moved
        if abs(change @ moved) > 1e-8 * np.linalg.norm(change) * np.linalg.norm(moved):
            curvature = curvature + np.outer(change, change) / (change @ moved)
        # below the cost's rounding (about 1e-12) the model's step is taken as it is: a ratio of two roundings
        # would shrink the region at random (a bound that cuts a step can leave it predicting no gain: shrink)
        ratio = -1.0 if predicted <= 0.0 else (cost - trial[0]) / predicted if predicted > POLISH_FLOOR else 1.0
        if ratio < 0.25:
            radius *= 0.25
        elif ratio > 0.75 and np.linalg.norm(moved[free] / scale) > 0.9 * radius:
            radius *= 2.0
        if ratio > 0.1:
            x = x + moved
            cost, values, slopes, bends, rows, jacobian, gradient = trial
    return x


def _trust_step(hessian: np.ndarray, gradient: np.ndarray, radius: float) -> np.ndarray:
    """The step that minimises gradient . p + p . hessian . p / 2 with |p|_inf... (the Euclidean norm) at most
    `radius`: Newton's step where the Hessian is positive definite and the step short enough, else the step
    (hessian + mu I)^-1 gradient whose length is the radius (mu by bisection)."""
    values, vectors = np.linalg.eigh(hessian)
    along = vectors.T @ gradient

    def step(mu: float) -> np.ndarray:
        return -vectors @ (along / (values + mu))

    if values[0] > 0.0:
        newton = step(0.0)
        if np.linalg.norm(newton) <= radius:
            return newton
    low = max(0.0, -values[0]) + 1e-12 * max(1.0, abs(values[-1]))
    high = low + np.linalg.norm(gradient) / radius + abs(values[-1])
    for _ in range(100):
        mu = 0.5 * (low + high)
        if np.linalg.norm(step(mu)) > radius:
            low = mu
        else:
            high = mu
    return step(high)


def refine(obj: GraspObject, pos: np.ndarray, quat: np.ndarray, posture: np.ndarray,
           name: str = "start", contacts: tuple[str, ...] = DISTAL_SEGMENTS, grasp_type: str = "power",
           balance: float = 0.0, press: float = 0.0) -> StartingPosture:
    """Least-squares search from a rough grasp to one where the contact segments (by default all five
    distal ones) touch, every other segment stays clear of the object and the fingers of each other.

    The residual is smooth (the one-sided terms are `soft_hinge`s, the distances measured between cores,
    `_GraspGeometry`), its distances' Jacobian exact, and the search runs to its local minimum, so that its
    result does not turn on the last bits of the inputs or of the arithmetic. With `balance` or `press` it runs
    twice: first to touch, then, from there, with those terms (whose pushes are defined only while the contacts'
    cores are outside the object; their Jacobian is by forward differences of `JACOBIAN_STEP`).

    Args:
        obj: the object.
        pos: (3,) m, the rough grasp's palm position in the object frame.
        quat: (4,) its palm orientation (w x y z); the search moves the palm by up to 3 cm and 0.5 rad.
        posture: (22,) rad, its finger joints.
        name: the start's name.
        contacts: the segments that must touch.
        grasp_type: the start's grasp type (`GRASP_TYPES`).
        balance: weight of a term that asks the contacts' pushes to cancel (the mean of their unit
            directions towards the object, `_GraspGeometry.pushes`, near zero): the thumb then opposes the
            fingers instead of pressing sideways; 0 leaves it out.
        press: weight of a term that asks the controller's squeeze to press each contact into the object
            (`_GraspGeometry.pressing`: the cosine between its motion under the squeeze and its push at least
            `PRESS_COSINE`); 0 leaves it out.

    Returns:
        The refined `StartingPosture` (check it with `is_design_grasp`).
    """
    scene = Scene(obj)
    geometry = _GraspGeometry(scene, contacts)
    limits = scene.hand.limits()
    lower, upper = limits[:, 0] + 1e-3, limits[:, 1] - 1e-3
    base_quat = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    touching, clear = len(geometry.distal), len(geometry.other)

    def unpack(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return v[:22], pos + v[22:25], rotvec_quat(v[25:28], base_quat)

    def pushing(v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The pushes' mean (3,) when `balance`, then the squeeze's cosines when `press`."""
        joints, p, q = unpack(v)
        geometry.place(joints, p, q)
        pushes = geometry.pushes()
        return np.concatenate(([pushes.mean(axis=0)] if balance else [])
                              + ([geometry.pressing(joints, pushes)] if press else []))

    def pushing_jacobian(v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The Jacobian of `pushing` (exact on a primitive, `push_jacobians`; by forward differences of
        `JACOBIAN_STEP` on a mesh, whose pushes turn with its faces)."""
        if obj.mesh is not None:
            pushed = pushing(v, balance, press)
            steps = v + JACOBIAN_STEP * np.eye(v.size)
            return np.column_stack([(pushing(step, balance, press) - pushed) / JACOBIAN_STEP for step in steps])
        joints, p, q = unpack(v)
        geometry.place(joints, p, q)
        pushes, push_rows = geometry.push_jacobians()
        rows = [push_rows.mean(axis=0)] if balance else []
        rows += [geometry.pressing_jacobian(joints, pushes, push_rows)[1]] if press else []
        rows = np.vstack(rows)
        rows[:, 25:28] = rows[:, 25:28] @ _left_jacobian(v[25:28])
        return rows

    def measure(v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The geometry's measures: distances (contacts, other geoms, finger pairs), then `pushing`'s terms."""
        distances = geometry.distances(*unpack(v))
        return np.concatenate([*distances, pushing(v, balance, press) if balance or press else []])

    def measure_jacobian(v: np.ndarray, balance: float, press: float) -> tuple[np.ndarray, np.ndarray]:
        """The measures and their Jacobian (len, 28)."""
        distances = geometry.distances(*unpack(v))
        rows = np.vstack(geometry.distance_jacobians())
        rows[:, 25:28] = rows[:, 25:28] @ _left_jacobian(v[25:28])
        if not (balance or press):
            return np.concatenate(distances), rows
        pushed = pushing(v, balance, press)
        return np.concatenate([*distances, pushed]), np.vstack([rows, pushing_jacobian(v, balance, press)])

    n_pairs = len(geometry._pairs)

    def weigh(m: np.ndarray, balance: float, press: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The residuals of the measures, their slopes and their bends (second derivatives)."""
        distal, other = m[:touching], m[touching:touching + clear]
        pairs, rest = m[touching + clear:touching + clear + n_pairs], m[touching + clear + n_pairs:]
        values = [100.0 * distal,                                  # touch: contact gap 0
                  300.0 * soft_hinge(0.001 - other, HINGE_WIDTH),  # other segments stay out of the object
                  300.0 * soft_hinge(0.002 - pairs, HINGE_WIDTH)]  # fingers stay out of each other
        slopes = [np.full(touching, 100.0), -300.0 * _hinge_slope(0.001 - other, HINGE_WIDTH),
                  -300.0 * _hinge_slope(0.002 - pairs, HINGE_WIDTH)]
        bends = [np.zeros(touching), 300.0 * _hinge_bend(0.001 - other, HINGE_WIDTH),
                 300.0 * _hinge_bend(0.002 - pairs, HINGE_WIDTH)]
        if balance:  # the pushes cancel
            values.append(balance * rest[:3])
            slopes.append(np.full(3, balance))
            bends.append(np.zeros(3))
            rest = rest[3:]
        if press:  # the squeeze presses each contact in
            values.append(press * soft_hinge(PRESS_COSINE - rest, PRESS_WIDTH))
            slopes.append(-press * _hinge_slope(PRESS_COSINE - rest, PRESS_WIDTH))
            bends.append(press * _hinge_bend(PRESS_COSINE - rest, PRESS_WIDTH))
        return np.concatenate(values), np.concatenate(slopes), np.concatenate(bends)

    # stay close to the designed grasp type, and near the designed hand pose
    anchor = np.concatenate([np.full(22, 0.03), np.full(3, 1.0), np.full(3, 0.05)])
    design = np.concatenate([np.asarray(posture, dtype=float), np.zeros(6)])
    start = np.concatenate([np.clip(posture, lower, upper), np.zeros(6)])
    bounds = (np.concatenate([lower, [-0.03] * 3, [-0.5] * 3]), np.concatenate([upper, [0.03] * 3, [0.5] * 3]))
    found = start
    for terms in [{"balance": 0.0, "press": 0.0}] + ([{"balance": balance, "press": press}] if balance or press else []):
        found = _search(partial(measure, **terms), partial(measure_jacobian, **terms), partial(weigh, **terms),
                        anchor, design, found, bounds)
    joints, p, q = unpack(found)
    return StartingPosture(name, p, q, joints, tuple(contacts), grasp_type)


def is_design_grasp(obj: str | GraspObject, start: StartingPosture) -> bool:
    """The start's contact segments touch (each has a geom within 1 mm), no segment is deeper than
    2 mm in the object, and every joint is inside its limits."""
    scene = Scene(obj)
    geometry = _GraspGeometry(scene, start.contacts)
    limits = scene.hand.limits()
    if np.any(start.posture < limits[:, 0] - 1e-9) or np.any(start.posture > limits[:, 1] + 1e-9):
        return False
    distal, other, _ = geometry.distances(start.posture, start.hand_pos, start.hand_quat)
    segment_of = segment_of_geoms(scene.model)
    touching = {SEGMENTS[segment_of[g]] for g, d in zip(geometry.distal, distal) if abs(d) <= CONTACT_GAP}
    return bool(set(start.contacts) <= touching and np.all(np.concatenate([distal, other]) >= -MAX_PENETRATION))


def check_starting_postures(starts: object, obj: str | GraspObject) -> list[StartingPosture]:
    """A user's own starting postures, checked: each a `StartingPosture` with a palm position (3,), m, a unit
    quaternion (4,), 22 joint angles in radians, contact segments among `SEGMENTS`, a grasp type among
    `GRASP_TYPES`, a name of its own, and a valid grasp of the object (`is_design_grasp`: its contacts touch,
    nothing deeper than 2 mm, joints in range; `refine` brings a rough grasp there).

    Args:
        starts: the starting postures (a non-empty list or tuple).
        obj: the object they grasp, or its name (palm poses in its frame).

    Returns:
        The starts, their arrays as float arrays.

    Raises:
        InvalidInput: naming the first start that is not as described, and why.
    """
    obj = get_object(obj)
    if not isinstance(starts, (list, tuple)) or not starts:
        raise InvalidInput(f"starts must be a non-empty list of StartingPosture, got {starts!r:.80}")
    checked = []
    for i, start in enumerate(starts):
        if not isinstance(start, StartingPosture):
            raise InvalidInput(f"starts[{i}] must be a StartingPosture, got {type(start).__name__}")
        arrays = {}
        for field, size in (("hand_pos", 3), ("hand_quat", 4), ("posture", len(FINGER_JOINTS))):
            value = np.asarray(getattr(start, field), dtype=float)
            if value.shape != (size,) or not np.all(np.isfinite(value)):
                raise InvalidInput(f"starts[{i}] ({start.name!r}).{field} must be {size} finite numbers, got shape "
                                   f"{value.shape}")
            arrays[field] = value
        if abs(np.linalg.norm(arrays["hand_quat"]) - 1.0) > 1e-3:
            raise InvalidInput(f"starts[{i}] ({start.name!r}).hand_quat must be a unit quaternion (w x y z)")
        unknown = [c for c in start.contacts if c not in SEGMENTS]
        if not start.contacts or unknown:
            raise InvalidInput(f"starts[{i}] ({start.name!r}).contacts must name segments of {SEGMENTS}, got "
                               f"{start.contacts!r}")
        if start.grasp_type not in GRASP_TYPES:
            raise InvalidInput(f"starts[{i}] ({start.name!r}).grasp_type must be one of {GRASP_TYPES}, got "
                               f"{start.grasp_type!r}")
        start = StartingPosture(str(start.name), arrays["hand_pos"], arrays["hand_quat"] / np.linalg.norm(
            arrays["hand_quat"]), arrays["posture"], tuple(start.contacts), start.grasp_type)
        if not is_design_grasp(obj, start):
            raise InvalidInput(f"starts[{i}] ({start.name!r}) is not a grasp of {obj.name}: its contact segments "
                               f"{start.contacts} must touch (within {CONTACT_GAP * 1000:g} mm), nothing may be deeper "
                               f"than {MAX_PENETRATION * 1000:g} mm in the object and every joint in range (starts.refine "
                               "brings a rough grasp onto the surface)")
        checked.append(start)
    names = [s.name for s in checked]
    if len(set(names)) < len(names):
        raise InvalidInput(f"starts must have names of their own, got {names}")
    return checked


@dataclass(frozen=True)
class Refinement:
    """One way to refine a design (`refine`): the weights of the terms that balance the contacts' pushes and
    that make the squeeze press each contact in, and the palm's gap to the surface in place of the design's
    (`standoff`, m; None keeps the design's)."""

    balance: float = 0.0
    press: float = 0.0
    standoff: float | None = None


#: Tried in turn for each design of the `grasp_types` family until its start holds (`GraspVerifier`): the
#: design as it is; then with the squeeze pressing every contact in (`refine(press=...)`: in the paper's mid
#: and low wraps the controller's squeeze draws the thumb off the object, its motion at about 140 degrees
#: from its push); with the contacts' pushes balanced (so the thumb opposes the fingers); both; for a
#: power grasp, the palm 1 mm off the surface (taking up what four fingers push more than the thumb); and
#: the balance weighed more (a pinch of a tapered or curved object needs its two pushes nearly opposed).
#: Whether one start holds turns on millimetres, so several are tried (docs/generator_defaults.md has what
#: each object got).
REFINEMENTS: tuple[Refinement, ...] = (
    Refinement(), Refinement(press=1.0), Refinement(balance=0.6), Refinement(balance=0.6, press=1.0),
    Refinement(press=1.0, standoff=0.001), Refinement(balance=0.6, standoff=0.001),
    Refinement(balance=2.5), Refinement(balance=6.0, press=1.0),
)


def holds(verifier: GraspVerifier, start: StartingPosture) -> bool:
    """Whether a start holds its object when replayed by the generator's verifier (its physics failing counts
    as not holding).

    Args:
        verifier: a `GraspVerifier` of the start's object.
        start: the starting posture (palm pose in the object frame, m).

    Returns:
        True when the hold test passes.
    """
    try:
        return bool(verifier(start.posture, start.hand_pos, start.hand_quat).hold)
    except SimulationError:
        return False


def _search_design(task: tuple[GraspObject, GraspDesign, Callable[[StartingPosture], bool] | None]
                   ) -> StartingPosture | None:
    """One design's start: the first of its refinements (all of `REFINEMENTS` when there is a check, else the
    plain one) that is a valid grasp and passes the check; None when none is."""
    obj, design, check = task
    for refinement in REFINEMENTS if check is not None else REFINEMENTS[:1]:
        if refinement.standoff is not None and design.grasp_type != "power":
            continue
        shaped = replace(design, standoff=design.standoff if refinement.standoff is None else refinement.standoff)
        pos, quat = design_pose(obj, shaped)
        start = refine(obj, pos, quat, design_posture(design), design.name, design.contacts, design.grasp_type,
                       refinement.balance, refinement.press)
        if is_design_grasp(obj, start) and (check is None or check(start)):
            return start
    return None


def verified(obj: GraspObject, start: StartingPosture) -> bool:
    """Whether a start holds its object under the generator's verifier (`holds` with a new `GraspVerifier`).

    Args:
        obj: the object.
        start: the starting posture (palm pose in the object frame, m).

    Returns:
        True when the hold test passes.
    """
    return holds(GraspVerifier(obj), start)


def find_starting_postures(obj: str | GraspObject, family: str = "five_fingertip", *,
                           check: Callable[[StartingPosture], bool] | None = None,
                           progress: bool | None = None, workers: int | None = None) -> list[StartingPosture]:
    """Search every grasp design of the family for this object.

    `five_fingertip` (the paper's kind): each design refined once, kept when it is a valid grasp
    (`is_design_grasp`). `grasp_types`: each design refined in the ways of `REFINEMENTS` in turn and kept in
    the first that is a valid grasp and passes `check` (by default `verified`: it holds the object when the
    generator's verifier replays it, the controller's squeeze and then the hold test; the generator's own
    search, `generator.search_starting_postures`, also asks its neighbours to hold), so that every start of
    the family is a grasp that holds; a design none of whose refinements passes is left out. A bar counts the
    designs searched (a second or a few each; `progress` as `progress.progress_bar` takes it); the designs are
    searched in parallel.

    Args:
        obj: an object or its name.
        family: a design family (`DESIGN_FAMILIES`).
        check: what a grasp-types start must pass, a picklable function of the start (None: `verified`).
        progress: show the bar (None: as `progress.show_progress` says).
        workers: worker processes (None: `workers.default_workers()` in a main process, one inside a worker).

    Returns:
        The starting postures found, in the order of `designs_for(obj, family)`.
    """
    obj = get_object(obj)
    designs = designs_for(obj, family)
    if workers is None:  # a worker of a pool searches alone: no pools inside pools
        workers = min(default_workers(), len(designs)) if multiprocessing.parent_process() is None else 1
    if family == "grasp_types" and check is None:
        check = partial(verified, obj)
    tasks = [(obj, design, check if family == "grasp_types" else None) for design in designs]
    with progress_bar(len(designs), f"starting postures {obj.name} ({family})", "designs", enabled=progress) as bar:
        found = parallel_map(_search_design, tasks, workers, lambda *_: bar.update(1))
    return [start for start in found if start is not None]


def starts_key(name: str, family: str) -> str:
    """The key of an object's starts in a family in a file of `save_starting_postures` (the five-fingertip ones
    keep the bare name).

    Args:
        name: the object's name.
        family: a design family (`DESIGN_FAMILIES`).

    Returns:
        The key.
    """
    return name if family == "five_fingertip" else f"{name}@{family}"


def save_starting_postures(path, starts_by_object: dict[tuple[GraspObject, str], list[StartingPosture]]) -> None:
    """Write starting postures keyed by (object, design family) to an .npz file (the object's name and
    parameters are stored, so a changed object is never given another's starts)."""
    arrays, index = {}, {}
    for (obj, family), starts in starts_by_object.items():
        key = starts_key(obj.name, family)
        arrays[f"{key}/pos"] = np.array([s.hand_pos for s in starts]).reshape(-1, 3)
        arrays[f"{key}/quat"] = np.array([s.hand_quat for s in starts]).reshape(-1, 4)
        arrays[f"{key}/posture"] = np.array([s.posture for s in starts]).reshape(-1, len(FINGER_JOINTS))
        index[key] = {"names": [s.name for s in starts], "object": obj.params(), "family": family,
                      "contacts": [list(s.contacts) for s in starts], "grasp_types": [s.grasp_type for s in starts]}
    save_npz(path, "starting_postures", arrays, {"objects": index, "units": "m, radians",
                                                 "joints": list(FINGER_JOINTS)})


@cache
def _shipped() -> tuple[dict[str, np.ndarray], dict]:
    try:
        return load_npz(asset_path(STARTS_FILE), "starting_postures", {})
    except FileNotFoundError:
        return {}, {"objects": {}}


def shipped_starting_postures(obj: GraspObject, family: str) -> list[StartingPosture] | None:
    """The starting postures `assets/starting_postures.npz` ships for an object in a design family, or for an
    object of the same geometry (a variant with another mass or friction, `GraspObject.with_`, has the same
    designed grasps).

    Args:
        obj: the object.
        family: a design family (`DESIGN_FAMILIES`).

    Returns:
        The starts, or None when none are shipped for it.
    """
    arrays, meta = _shipped()
    key = starts_key(obj.name, family)
    entry = meta["objects"].get(key)
    if entry is None or entry["object"] != obj.params():
        key, entry = next(((k, e) for k, e in meta["objects"].items() if e.get("family", "five_fingertip") == family
                           and _geometry(e["object"]) == _geometry(obj.params())), (key, None))
    return None if entry is None else read_entry(arrays, key, entry, obj, family)


def read_entry(arrays: dict[str, np.ndarray], key: str, entry: dict, obj: GraspObject, family: str
               ) -> list[StartingPosture]:
    """The starting postures of one object and family in a file written by `save_starting_postures`.

    Args:
        arrays: the file's arrays (`io.load_npz`).
        key: the entry's key (`starts_key`).
        entry: the entry's metadata (names, contacts, grasp types).
        obj: the object.
        family: its design family.

    Returns:
        The starts, palm poses in the object frame (m).
    """
    count = len(entry["names"])
    contacts = entry.get("contacts", [list(DISTAL_SEGMENTS)] * count)
    designs = {d.name: d for d in designs_for(obj, family)}
    types = entry.get("grasp_types", [designs[n].grasp_type if n in designs else "power" for n in entry["names"]])
    return [StartingPosture(n, arrays[f"{key}/pos"][i], arrays[f"{key}/quat"][i], arrays[f"{key}/posture"][i],
                            tuple(contacts[i]), types[i]) for i, n in enumerate(entry["names"])]


def _geometry(params: dict) -> dict:
    """An object's parameters less those that do not change where a grasp is (name, mass, friction)."""
    return {k: v for k, v in params.items() if k not in ("name", "mass", "friction")}
