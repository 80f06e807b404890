"""Starting postures: five-fingertip grasps that the spring-based generator explores around.

The paper actuated its starting postures by hand. Here each one comes from a designed grasp (a
palm pose relative to the object and a half-closed hand, see `GRASP_DESIGNS`) refined by a
deterministic least-squares search over the 22 joints and a small hand-pose correction, which
brings all five distal segments onto the surface, keeps every other segment out of the object and
the fingers out of each other. The paper's three objects ship their starting postures in
`assets/starting_postures.npz` (made by `scripts/find_starting_postures.py`); other objects get
theirs computed on first use. A mesh object is searched with the designs of the primitive it is
closest to in proportion (`designs_for`): the designs place the palm relative to the object's
principal axes and its extents, and the least-squares refinement brings the fingertips onto the
actual surface, so any watertight solid of hand size gets its five-fingertip grasps this way.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import mujoco
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from .hand import (
    DISTAL_SEGMENTS,
    FINGER_JOINTS,
    SEGMENTS,
    asset_path,
    finger_limits,
    finger_of,
    segment_of_geoms,
)
from .io import load_npz, save_npz
from .objects import GraspObject, get_object
from .poses import to_quat, to_rotation
from .posture import dict_to_posture
from .scene import GRASP_CENTRE_IN_PALM, PALM_HALF_THICKNESS, Scene

STARTS_FILE = "starting_postures.npz"
CONTACT_GAP = 0.001  # a distal segment "touches" within 1 mm
MAX_PENETRATION = 0.002


@dataclass(frozen=True)
class StartingPosture:
    """A five-fingertip grasp: palm pose in the object frame (pos, quat w x y z) and 22 joint angles."""

    name: str
    hand_pos: np.ndarray
    hand_quat: np.ndarray
    posture: np.ndarray


@dataclass(frozen=True)
class GraspDesign:
    """A grasp type: the object's centre point in the palm frame and the object axes' directions.

    `axis_in_palm` is the palm-frame direction of the object's long axis (z); `approach_tilt`
    rotates the object about the palm's normal. `standoff` is the gap between palm and surface.
    """

    name: str
    axis_in_palm: tuple[float, float, float]
    centre_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    standoff: float = 0.008
    roll: float = 0.0  # rotation of the object about its own long axis (radians)
    end_on: bool = False  # the palm faces the object's +z end instead of its side


def _designs(shape: str) -> tuple[GraspDesign, ...]:
    side = (1.0, 0.0, 0.0)  # object axis across the fingers: a wrap
    tilt = (np.cos(0.5), 0.0, np.sin(0.5))
    if shape == "sphere":
        return (
            GraspDesign("power", side, standoff=0.006),
            GraspDesign("precision", side, centre_offset=(0.0, 0.0, 0.03), standoff=0.03),
            GraspDesign("thumb_side", side, centre_offset=(0.02, 0.0, 0.01), standoff=0.015),
            GraspDesign("fingertip_low", side, centre_offset=(-0.01, 0.0, 0.015), standoff=0.022),
        )
    designs = [
        GraspDesign("wrap_mid", side),
        GraspDesign("wrap_tilted", tilt),
        GraspDesign("wrap_low", side, centre_offset=(0.0, 0.0, -0.012), standoff=0.012),
        GraspDesign("end_on", (0.0, 0.0, 1.0), centre_offset=(0.0, 0.0, 0.02), standoff=0.01, end_on=True),
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


def designs_for(obj: GraspObject) -> tuple[GraspDesign, ...]:
    """The grasp designs to search for an object: those of its `nearest_primitive` (a cylinder's:
    wraps about the long axis z, tilted, low, end-on; a box's add a wrap rolled 45 degrees). The
    refinement then adapts them to the actual surface."""
    return GRASP_DESIGNS[nearest_primitive(obj)]


_HALF_CLOSED = dict_to_posture({
    **{f"{f}J{j}": a for f in ("FF", "MF", "RF", "LF") for j, a in ((3, 0.7), (2, 0.6), (1, 0.5))},
    "FFJ4": 0.0, "MFJ4": 0.0, "RFJ4": 0.0, "LFJ4": 0.0, "LFJ5": 0.2,
    "THJ5": 0.7, "THJ4": 1.1, "THJ3": 0.1, "THJ2": 0.2, "THJ1": 0.4,
})


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
    """Fast kinematic queries on a scene for the search: geom distances for a posture and pose."""

    def __init__(self, scene: Scene):
        self.scene = scene
        model = scene.model
        segment_of = segment_of_geoms(model)
        hand_geoms = [int(g) for g in np.flatnonzero(segment_of >= 0)]
        self.distal = [model.geom(s).id for s in DISTAL_SEGMENTS]
        self.other = [g for g in hand_geoms if g not in self.distal and SEGMENTS[segment_of[g]] != "forearm"]
        fingers = {g: finger_of(SEGMENTS[segment_of[g]]) for g in hand_geoms}
        order = ["ff", "mf", "rf", "lf"]
        self.pairs = [(a, b) for a in hand_geoms for b in hand_geoms if a < b and fingers[a] and fingers[b]
                      and fingers[a] != fingers[b]
                      and (fingers[a] == "th" or fingers[b] == "th"
                           or abs(order.index(fingers[a]) - order.index(fingers[b])) == 1)]
        self._fromto = np.zeros(6)

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
           name: str = "start") -> StartingPosture:
    """Least-squares search from a rough grasp to one where all five distal segments touch."""
    scene = Scene(obj)
    geometry = _GraspGeometry(scene)
    limits = finger_limits()
    lower, upper = limits[:, 0] + 1e-3, limits[:, 1] - 1e-3
    base_rotation = to_rotation(quat)

    def unpack(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rotation = Rotation.from_rotvec(v[25:28]) * base_rotation
        q = to_quat(rotation)
        return v[:22], pos + v[22:25], q

    def residuals(v: np.ndarray) -> np.ndarray:
        joints, p, q = unpack(v)
        distal, other, pairs = geometry.distances(joints, p, q)
        return np.concatenate([
            100.0 * distal,                                   # touch: distal gap 0
            300.0 * np.maximum(0.0, 0.001 - other),           # other segments stay out of the object
            300.0 * np.maximum(0.0, 0.002 - pairs),           # fingers stay out of each other
            0.03 * (joints - posture),                        # stay close to the designed grasp type
            1.0 * v[22:25], 0.05 * v[25:28],                  # and near the designed hand pose
        ])

    start = np.concatenate([np.clip(posture, lower, upper), np.zeros(6)])
    bounds = (np.concatenate([lower, [-0.03] * 3, [-0.5] * 3]), np.concatenate([upper, [0.03] * 3, [0.5] * 3]))
    result = least_squares(residuals, start, bounds=bounds, x_scale="jac", max_nfev=400, diff_step=1e-6)
    joints, p, q = unpack(result.x)
    return StartingPosture(name, p, q, joints)


def is_five_fingertip_grasp(obj: str | GraspObject, start: StartingPosture) -> bool:
    """All five distal segments within 1 mm, no segment deeper than 2 mm, joints inside limits."""
    scene = Scene(obj)
    geometry = _GraspGeometry(scene)
    limits = finger_limits()
    if np.any(start.posture < limits[:, 0] - 1e-9) or np.any(start.posture > limits[:, 1] + 1e-9):
        return False
    distal, other, _ = geometry.distances(start.posture, start.hand_pos, start.hand_quat)
    return bool(np.all(np.abs(distal) <= CONTACT_GAP) and np.all(np.concatenate([distal, other]) >= -MAX_PENETRATION))


def find_starting_postures(obj: str | GraspObject) -> list[StartingPosture]:
    """Search every grasp design of the object's shape; keep the valid five-fingertip grasps."""
    obj = get_object(obj)
    found = []
    for design in designs_for(obj):
        pos, quat = design_pose(obj, design)
        start = refine(obj, pos, quat, _HALF_CLOSED, design.name)
        if is_five_fingertip_grasp(obj, start):
            found.append(start)
    return found


def save_starting_postures(path, starts_by_object: dict[str, list[StartingPosture]]) -> None:
    arrays, index = {}, {}
    for name, starts in starts_by_object.items():
        arrays[f"{name}/pos"] = np.array([s.hand_pos for s in starts])
        arrays[f"{name}/quat"] = np.array([s.hand_quat for s in starts])
        arrays[f"{name}/posture"] = np.array([s.posture for s in starts])
        index[name] = {"names": [s.name for s in starts], "object": get_object(name).params()}
    save_npz(path, "starting_postures", arrays, {"objects": index, "units": "m, radians",
                                                 "joints": list(FINGER_JOINTS)})


@cache
def _shipped() -> tuple[dict[str, np.ndarray], dict]:
    return load_npz(asset_path(STARTS_FILE), "starting_postures", {})


def starting_postures(obj: str | GraspObject) -> list[StartingPosture]:
    """The starting postures of an object: shipped for the paper's objects, else computed (once per
    object and process)."""
    return list(_starting_postures(get_object(obj)))


@lru_cache(maxsize=32)
def _starting_postures(obj: GraspObject) -> tuple[StartingPosture, ...]:
    try:
        arrays, meta = _shipped()
    except FileNotFoundError:
        arrays, meta = {}, {"objects": {}}
    entry = meta["objects"].get(obj.name)
    if entry is not None and entry["object"] == obj.params():
        return tuple(StartingPosture(n, arrays[f"{obj.name}/pos"][i], arrays[f"{obj.name}/quat"][i],
                                     arrays[f"{obj.name}/posture"][i]) for i, n in enumerate(entry["names"]))
    return tuple(find_starting_postures(obj))
