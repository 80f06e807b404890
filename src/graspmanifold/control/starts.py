"""Starting postures: designed grasps that the spring-based generator explores around.

The paper actuated its starting postures by hand, each a five-fingertip grasp. Here each one comes
from a designed grasp (a palm pose relative to the object, a hand posture and the segments that
must touch, see `GraspDesign`) refined by a deterministic least-squares search over the 22 joints
and a small hand-pose correction, which brings the design's contact segments onto the surface,
keeps every other segment out of the object and the fingers out of each other.

Two families of designs (`DESIGN_FAMILIES`): `five_fingertip`, the paper's kind (all five distal
segments touch; wraps of the object's nearest primitive shape, `GRASP_DESIGNS`), and
`grasp_types`, ours and the generator's default: those wraps (power grasps) and one design of each
precision grasp type (`PRECISION_DESIGNS`: a two-finger pinch of thumb and index tips, a tripod of
thumb, index and middle tips, and a lateral grasp pressing the object between the thumb's pad and the
side of the index finger), with the fingers that take no part curled into the palm. A design of this
family is kept only in a refinement whose start holds the object when the generator's verifier replays
it (`REFINEMENTS`, `GraspVerifier`): the paper's wraps, refined to touch alone, mostly do not (their
thumb presses sideways and slides off under the squeeze), so the family's refinements also ask the
contacts' pushes to cancel.

The paper's objects and the benchmark's (`benchmark.OBJECTS`) ship their starting postures of both
families in `assets/starting_postures.npz` (made by `scripts/find_starting_postures.py`), the object family
its five-fingertip ones and the grasp-types ones of the medium size of each shape not held out
(`family.HELD_OUT`); the rest is searched on first use and kept in `cache_directory()`, so that the next
process reads it (a user can also give their own: `generate_postures(..., starts=...)`,
each a `StartingPosture`, e.g. a rough grasp brought onto the surface by `refine`). A mesh object
is searched with the designs of the primitive it is closest to in proportion (`designs_for`): the
designs place the palm relative to the object's principal axes and its extents, and the
least-squares refinement brings the fingertips onto the actual surface, so any watertight solid of
hand size gets its grasps this way.
"""

from __future__ import annotations

import multiprocessing
import os
import warnings
from dataclasses import dataclass, replace
from functools import cache, lru_cache
from pathlib import Path

import mujoco
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..base.checkpoints import result_key
from ..base.errors import InvalidInput, SimulationError
from ..base.io import load_npz, save_npz
from ..base.progress import progress_bar
from ..base.workers import default_workers, parallel_map
from ..base.poses import to_quat, to_rotation
from ..sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, SEGMENTS, asset_path, finger_of, segment_of_geoms
from ..sim.objects import GraspObject, get_object
from ..sim.posture import dict_to_posture
from ..sim.scene import GRASP_CENTRE_IN_PALM, PALM_HALF_THICKNESS, Scene
from .controller import squeezed
from .judge import GraspVerifier

STARTS_FILE = "starting_postures.npz"
CONTACT_GAP = 0.001  # a contact segment "touches" within 1 mm
MAX_PENETRATION = 0.002
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


def designs_for(obj: GraspObject, family: str = "five_fingertip") -> tuple[GraspDesign, ...]:
    """The grasp designs to search for an object in a family (`DESIGN_FAMILIES`).

    `five_fingertip`: those of its `nearest_primitive` (a cylinder's: wraps about the long axis z,
    tilted, low, end-on; a box's add a wrap rolled 45 degrees). `grasp_types`: these power grasps
    and the `PRECISION_DESIGNS`. The refinement then adapts each design to the actual surface;
    designs that do not fit the object (a pinch of a ball too big to pinch) find no valid grasp.
    """
    if family not in DESIGN_FAMILIES:
        raise InvalidInput(f"family must be one of {DESIGN_FAMILIES}, got {family!r}")
    power = GRASP_DESIGNS[nearest_primitive(obj)]
    return power if family == "five_fingertip" else power + PRECISION_DESIGNS


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
        0.0, PALM_HALF_THICKNESS + design.standoff + extent, 0.0]
    pos = -palm_in_object @ centre_in_palm
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, palm_in_object.ravel())
    return pos, quat


class _GraspGeometry:
    """Fast kinematic queries on a scene for the search: geom distances for a posture and pose.

    `distal` are the geoms of the contact segments (the five distal ones unless told otherwise),
    `other` every other hand geom but the forearm's."""

    def __init__(self, scene: Scene, contacts: tuple[str, ...] = DISTAL_SEGMENTS):
        self.scene = scene
        model = scene.model
        segment_of = segment_of_geoms(model)
        hand_geoms = [int(g) for g in np.flatnonzero(segment_of >= 0)]
        self.distal = [int(g) for s in contacts for g in np.flatnonzero(segment_of == SEGMENTS.index(s))]
        self.other = [g for g in hand_geoms if g not in self.distal and SEGMENTS[segment_of[g]] != "forearm"]
        fingers = {g: finger_of(SEGMENTS[segment_of[g]]) for g in hand_geoms}
        order = ["ff", "mf", "rf", "lf"]
        self.pairs = [(a, b) for a in hand_geoms for b in hand_geoms if a < b and fingers[a] and fingers[b]
                      and fingers[a] != fingers[b]
                      and (fingers[a] == "th" or fingers[b] == "th"
                           or abs(order.index(fingers[a]) - order.index(fingers[b])) == 1)]
        self._fromto = np.zeros(6)
        capsule = mujoco.mjtGeom.mjGEOM_CAPSULE
        self._capsules = [g for g in self.distal if model.geom_type[g] == capsule]
        self._others = [g for g in self.distal if model.geom_type[g] != capsule]
        #: the contact geoms in the order of the rows of `pushes` and `pressing`
        self.pushing = self._capsules + self._others

    def pushes(self) -> np.ndarray:
        """Unit directions (len(distal), 3) in which the contact geoms (`pushing`) press the object at the current
        kinematics: from the point of a geom's core (a capsule's segment, another geom's centre) nearest the
        object towards the object's closest surface point. Smooth in the hand's pose while the core stays
        outside the object, for a mesh too (unlike its face normals)."""
        model, data = self.scene.model, self.scene.data
        along = np.linspace(-1.0, 1.0, 5)[None, :, None]
        half_axes = data.geom_xmat[self._capsules].reshape(-1, 3, 3)[:, :, 2] * model.geom_size[self._capsules, 1:2]
        cores = [data.geom_xpos[self._capsules][:, None, :] + along * half_axes[:, None, :],
                 np.repeat(data.geom_xpos[self._others][:, None, :], along.shape[1], axis=1)]
        points = np.concatenate(cores)  # (geoms, 5, 3); the object sits at the world origin, unrotated
        towards = self.scene.object.closest_point(points.reshape(-1, 3)).reshape(points.shape) - points
        gaps = np.linalg.norm(towards, axis=2)
        nearest = np.argmin(gaps, axis=1)
        rows = np.arange(len(points))
        return towards[rows, nearest] / np.maximum(gaps[rows, nearest], 1e-9)[:, None]

    def pressing(self, posture: np.ndarray, pushes: np.ndarray) -> np.ndarray:
        """Cosines (len(distal),) between where the controller's squeeze moves each contact geom (a small
        `controller.squeezed` of the posture, at the current hand pose) and its push on the object (`pushes`):
        1 when the squeeze presses it straight in, negative when it draws it away (the thumb of the paper's
        mid and low wraps: the squeeze flexes it off the object)."""
        model, data, geoms = self.scene.model, self.scene.data, self.pushing
        before = data.geom_xpos[geoms].copy()
        saved = data.qpos.copy()
        data.qpos[self.scene.finger_qpos] = squeezed(posture, 0.05, self.scene.hand)
        mujoco.mj_kinematics(model, data)
        moved = data.geom_xpos[geoms] - before
        data.qpos[:] = saved
        mujoco.mj_kinematics(model, data)
        return np.sum(moved * pushes, axis=1) / np.maximum(np.linalg.norm(moved, axis=1), 1e-9)

    def distances(self, posture: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, ...]:
        scene, model, data = self.scene, self.scene.model, self.scene.data
        data.qpos[scene.finger_qpos] = posture
        scene.set_hand_pose(pos, quat)  # runs mj_forward: kinematics for the distances below
        dist = lambda a, b: mujoco.mj_geomDistance(model, data, a, b, 0.3, self._fromto)  # noqa: E731
        distal = np.array([scene.distance_to_object(g, 0.3) for g in self.distal])
        other = np.array([scene.distance_to_object(g, 0.3) for g in self.other])
        pairs = np.array([dist(a, b) for a, b in self.pairs])
        return distal, other, pairs


def refine(obj: GraspObject, pos: np.ndarray, quat: np.ndarray, posture: np.ndarray,
           name: str = "start", contacts: tuple[str, ...] = DISTAL_SEGMENTS, grasp_type: str = "power",
           balance: float = 0.0, press: float = 0.0) -> StartingPosture:
    """Least-squares search from a rough grasp to one where the contact segments (by default all five
    distal ones) touch, every other segment stays clear of the object and the fingers of each other.

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
    base_rotation = to_rotation(quat)

    def unpack(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rotation = Rotation.from_rotvec(v[25:28]) * base_rotation
        q = to_quat(rotation)
        return v[:22], pos + v[22:25], q

    def residuals(v: np.ndarray) -> np.ndarray:
        joints, p, q = unpack(v)
        distal, other, pairs = geometry.distances(joints, p, q)
        pushes = geometry.pushes() if balance or press else None
        return np.concatenate([
            balance * pushes.mean(axis=0) if balance else [],  # the pushes cancel
            press * np.maximum(0.0, PRESS_COSINE - geometry.pressing(joints, pushes)) if press else [],  # squeeze in
            100.0 * distal,                                   # touch: contact gap 0
            300.0 * np.maximum(0.0, 0.001 - other),           # other segments stay out of the object
            300.0 * np.maximum(0.0, 0.002 - pairs),           # fingers stay out of each other
            0.03 * (joints - posture),                        # stay close to the designed grasp type
            1.0 * v[22:25], 0.05 * v[25:28],                  # and near the designed hand pose
        ])

    start = np.concatenate([np.clip(posture, lower, upper), np.zeros(6)])
    bounds = (np.concatenate([lower, [-0.03] * 3, [-0.5] * 3]), np.concatenate([upper, [0.03] * 3, [0.5] * 3]))
    result = least_squares(residuals, start, bounds=bounds, x_scale="jac", max_nfev=400, diff_step=1e-6)
    joints, p, q = unpack(result.x)
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


def _search_design(task: tuple[GraspObject, GraspDesign, bool]) -> StartingPosture | None:
    """One design's start: the first of its refinements (all of `REFINEMENTS` when `checked`, else the plain
    one) that is a valid grasp and, when `checked`, holds; None when none is."""
    obj, design, checked = task
    verifier = GraspVerifier(obj) if checked else None
    for refinement in REFINEMENTS if checked else REFINEMENTS[:1]:
        if refinement.standoff is not None and design.grasp_type != "power":
            continue
        shaped = replace(design, standoff=design.standoff if refinement.standoff is None else refinement.standoff)
        pos, quat = design_pose(obj, shaped)
        start = refine(obj, pos, quat, design_posture(design), design.name, design.contacts, design.grasp_type,
                       refinement.balance, refinement.press)
        if is_design_grasp(obj, start) and (verifier is None or holds(verifier, start)):
            return start
    return None


def find_starting_postures(obj: str | GraspObject, family: str = "five_fingertip", *,
                           progress: bool | None = None, workers: int | None = None) -> list[StartingPosture]:
    """Search every grasp design of the family for this object.

    `five_fingertip` (the paper's kind): each design refined once, kept when it is a valid grasp
    (`is_design_grasp`). `grasp_types`: each design refined in the ways of `REFINEMENTS` in turn and kept in
    the first that is a valid grasp and holds the object when the generator's verifier replays it
    (`GraspVerifier`: the controller's squeeze, then the hold test), so that every start of the family is a
    grasp that holds; a design none of whose refinements holds is left out. A bar counts the designs
    searched (seconds each for a primitive, a minute or more for a mesh; `progress` as
    `progress.progress_bar` takes it); the designs are searched in parallel.

    Args:
        obj: an object or its name.
        family: a design family (`DESIGN_FAMILIES`).
        progress: show the bar (None: as `progress.show_progress` says).
        workers: worker processes (None: `workers.default_workers()` in a main process, one inside a worker).

    Returns:
        The starting postures found, in the order of `designs_for(obj, family)`.
    """
    obj = get_object(obj)
    designs = designs_for(obj, family)
    if workers is None:  # a worker of a pool searches alone: no pools inside pools
        workers = min(default_workers(), len(designs)) if multiprocessing.parent_process() is None else 1
    tasks = [(obj, design, family == "grasp_types") for design in designs]
    with progress_bar(len(designs), f"starting postures {obj.name} ({family})", "designs", enabled=progress) as bar:
        found = parallel_map(_search_design, tasks, workers, lambda *_: bar.update(1))
    return [start for start in found if start is not None]


def _key(name: str, family: str) -> str:
    """The shipped file's key of an object's starts in a family (the five-fingertip ones keep the bare name)."""
    return name if family == "five_fingertip" else f"{name}@{family}"


def save_starting_postures(path, starts_by_object: dict[tuple[GraspObject, str], list[StartingPosture]]) -> None:
    """Write starting postures keyed by (object, design family) to an .npz file (the object's name and
    parameters are stored, so a changed object is never given another's starts)."""
    arrays, index = {}, {}
    for (obj, family), starts in starts_by_object.items():
        key = _key(obj.name, family)
        arrays[f"{key}/pos"] = np.array([s.hand_pos for s in starts]).reshape(-1, 3)
        arrays[f"{key}/quat"] = np.array([s.hand_quat for s in starts]).reshape(-1, 4)
        arrays[f"{key}/posture"] = np.array([s.posture for s in starts]).reshape(-1, len(FINGER_JOINTS))
        index[key] = {"names": [s.name for s in starts], "object": obj.params(), "family": family,
                      "contacts": [list(s.contacts) for s in starts], "grasp_types": [s.grasp_type for s in starts]}
    save_npz(path, "starting_postures", arrays, {"objects": index, "units": "m, radians",
                                                 "joints": list(FINGER_JOINTS)})


@cache
def _shipped() -> tuple[dict[str, np.ndarray], dict]:
    return load_npz(asset_path(STARTS_FILE), "starting_postures", {})


def cache_directory() -> Path:
    """Where starting postures searched for an object that ships none are kept, so that another process
    finds them: `$GRASPMANIFOLD_CACHE`, else `$XDG_CACHE_HOME/graspmanifold`, else `~/.cache/graspmanifold`.

    Returns:
        The folder (made when something is first stored there).
    """
    if os.environ.get("GRASPMANIFOLD_CACHE"):
        return Path(os.environ["GRASPMANIFOLD_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "graspmanifold"


def starting_postures(obj: str | GraspObject, family: str = "five_fingertip") -> list[StartingPosture]:
    """The starting postures of an object in a design family (`DESIGN_FAMILIES`): shipped for the
    paper's objects and the object family; else searched once (a few seconds per design for a
    primitive, longer for a mesh, with a progress bar) and stored in `cache_directory()`, under a key
    of the object's parameters (a mesh's digest among them) and the library's code, so that a second
    process reads them instead of searching again.

    Args:
        obj: an object or its name.
        family: 'five_fingertip' (the paper's kind) or 'grasp_types' (power, precision, tripod, lateral).

    Returns:
        The valid starting postures, in the order of `designs_for(obj, family)`.
    """
    if family not in DESIGN_FAMILIES:
        raise InvalidInput(f"family must be one of {DESIGN_FAMILIES}, got {family!r}")
    return list(_starting_postures(get_object(obj), family))


@lru_cache(maxsize=64)
def _starting_postures(obj: GraspObject, family: str) -> tuple[StartingPosture, ...]:
    try:
        arrays, meta = _shipped()
    except FileNotFoundError:
        arrays, meta = {}, {"objects": {}}
    key = _key(obj.name, family)
    entry = meta["objects"].get(key)
    if entry is None or entry["object"] != obj.params():  # a variant of a shipped object (another mass or
        # friction, `GraspObject.with_`) has the same geometry, so the same designed grasps
        key, entry = next(((k, e) for k, e in meta["objects"].items() if e.get("family", "five_fingertip") == family
                           and _geometry(e["object"]) == _geometry(obj.params())), (key, None))
    if entry is not None:
        return _read_entry(arrays, key, entry, obj, family)
    cached = cache_directory() / "starting_postures" / f"{obj.name}_{family}_{result_key(obj.params(), family)}.npz"
    if cached.exists():
        try:
            arrays, meta = load_npz(cached, "starting_postures", {})
            return _read_entry(arrays, _key(obj.name, family), meta["objects"][_key(obj.name, family)], obj, family)
        except (ValueError, KeyError, OSError) as error:  # a damaged file is searched again and replaced
            warnings.warn(f"the stored starting postures {cached} cannot be read ({error}): searching again",
                          stacklevel=3)
    warnings.warn(f"{obj.name} has no shipped starting postures ({family}): searching them now (seconds for a "
                  f"primitive, a minute or more for a mesh); they are kept in {cached.parent} for the next process",
                  stacklevel=3)
    found = find_starting_postures(obj, family)
    try:
        save_starting_postures(cached, {(obj, family): found})
    except OSError as error:  # a read-only home: the search is only lost for the next process
        warnings.warn(f"the starting postures could not be stored in {cached.parent} ({error}); set "
                      "GRASPMANIFOLD_CACHE to a writable folder to keep them", stacklevel=3)
    return tuple(found)


def _read_entry(arrays: dict[str, np.ndarray], key: str, entry: dict, obj: GraspObject, family: str
                ) -> tuple[StartingPosture, ...]:
    """The starting postures of one object and family in a file written by `save_starting_postures`."""
    count = len(entry["names"])
    contacts = entry.get("contacts", [list(DISTAL_SEGMENTS)] * count)
    designs = {d.name: d for d in designs_for(obj, family)}
    types = entry.get("grasp_types", [designs[n].grasp_type if n in designs else "power" for n in entry["names"]])
    return tuple(StartingPosture(n, arrays[f"{key}/pos"][i], arrays[f"{key}/quat"][i], arrays[f"{key}/posture"][i],
                                 tuple(contacts[i]), types[i]) for i, n in enumerate(entry["names"]))


def _geometry(params: dict) -> dict:
    """An object's parameters less those that do not change where a grasp is (name, mass, friction)."""
    return {k: v for k, v in params.items() if k not in ("name", "mass", "friction")}
