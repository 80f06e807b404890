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
rest is searched on first use (`start_cache.starting_postures`: seconds to half a minute per object) and
kept in `start_cache.cache_directory()`, so that the next process reads it (a user can also give their own:
`generate_postures(..., starts=...)`, each a `StartingPosture`, e.g. a rough grasp brought onto the surface
by `refinement.refine`). A mesh object
is searched with the designs of the primitive it is closest to in proportion (`designs_for`): the
designs place the palm relative to the object's principal axes and its extents, and the
least-squares refinement brings the fingertips onto the actual surface, so any watertight solid of
hand size gets its grasps this way.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cache, partial

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput, SimulationError
from ..base.io import load_npz, save_npz
from ..base.progress import progress_bar
from ..base.validation import check_choice
from ..base.workers import default_workers, parallel_map
from ..judging.replay import GraspVerifier
from ..sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, SEGMENTS, asset_path, segment_of_geoms
from ..sim.family import FAMILY
from ..sim.objects import GraspObject, get_object
from ..sim.posture import dict_to_posture
from ..sim.scene import GRASP_CENTRE_IN_PALM, PALM_HALF_THICKNESS, Scene
from .refinement import REFINEMENTS, Refiner, StartingPosture
from .start_geometry import SearchGeometry

STARTS_FILE = "starting_postures.npz"
CONTACT_GAP = 0.001  # a contact segment "touches" within 1 mm
MAX_PENETRATION = 0.002

#: the grasp types a design can be (Cutkosky's taxonomy, coarsely): power wraps, the two-finger
#: precision pinch, the three-finger tripod, and the lateral (key) grasp
GRASP_TYPES: tuple[str, ...] = ("power", "precision", "tripod", "lateral")
#: the families of designs `starting_postures` searches (see the module doc)
DESIGN_FAMILIES: tuple[str, ...] = ("five_fingertip", "grasp_types")


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
    check_choice(family, DESIGN_FAMILIES, "family")
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


def is_design_grasp(obj: str | GraspObject, start: StartingPosture) -> bool:
    """The start's contact segments touch (each has a geom within 1 mm), no segment is deeper than
    2 mm in the object, and every joint is inside its limits."""
    scene = Scene(obj)
    geometry = SearchGeometry(scene, start.contacts)
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
    nothing deeper than 2 mm, joints in range; `refinement.refine` brings a rough grasp there).

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
        check_choice(start.grasp_type, GRASP_TYPES, f"starts[{i}] ({start.name!r}).grasp_type")
        start = StartingPosture(str(start.name), arrays["hand_pos"], arrays["hand_quat"] / np.linalg.norm(
            arrays["hand_quat"]), arrays["posture"], tuple(start.contacts), start.grasp_type)
        if not is_design_grasp(obj, start):
            raise InvalidInput(f"starts[{i}] ({start.name!r}) is not a grasp of {obj.name}: its contact segments "
                               f"{start.contacts} must touch (within {CONTACT_GAP * 1000:g} mm), nothing may be deeper "
                               f"than {MAX_PENETRATION * 1000:g} mm in the object and every joint in range (refinement.refine "
                               "brings a rough grasp onto the surface)")
        checked.append(start)
    names = [s.name for s in checked]
    if len(set(names)) < len(names):
        raise InvalidInput(f"starts must have names of their own, got {names}")
    return checked


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


def _search_design(task: tuple[GraspObject, GraspDesign, Callable[[StartingPosture], bool] | None, float]
                   ) -> StartingPosture | None:
    """One design's start: the first of its refinements (all of `REFINEMENTS` when there is a check, else the
    plain one) that is a valid grasp and passes the check; None when none is. The refinements of one standoff
    share their first search (`Refiner`). With a perturbation, the design's palm position is moved by
    that much, relatively, in a direction drawn from the design's name (a check that the search does not turn on
    the last bits)."""
    obj, design, check, perturbation = task
    refiner = Refiner(obj, design.contacts)
    for refinement in REFINEMENTS if check is not None else REFINEMENTS[:1]:
        if refinement.standoff is not None and design.grasp_type != "power":
            continue
        shaped = replace(design, standoff=design.standoff if refinement.standoff is None else refinement.standoff)
        pos, quat = design_pose(obj, shaped)
        if perturbation:
            seed = int.from_bytes(design.name.encode()[:8].ljust(8, b"\0"), "little")
            pos = pos * (1.0 + perturbation * np.random.default_rng(seed).standard_normal(3))
        rough = StartingPosture(design.name, pos, quat, design_posture(design), design.contacts, design.grasp_type)
        start = refiner(rough, refinement.balance, refinement.press)
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
                           check: Callable[[StartingPosture], bool] | None = None, perturbation: float = 0.0,
                           progress: bool | None = None, workers: int | None = None) -> list[StartingPosture]:
    """Search every grasp design of the family for this object.

    `five_fingertip` (the paper's kind): each design refined once, kept when it is a valid grasp
    (`is_design_grasp`). `grasp_types`: each design refined in the ways of `REFINEMENTS` in turn and kept in
    the first that is a valid grasp and passes `check` (by default `verified`: it holds the object when the
    generator's verifier replays it, the controller's squeeze and then the hold test; the generator's own
    search, `start_cache.search_starting_postures`, also asks its neighbours to hold), so that every start of
    the family is a grasp that holds; a design none of whose refinements passes is left out. A bar counts the
    designs searched (a second or a few each; `progress` as `progress.progress_bar` takes it); the designs are
    searched in parallel.

    Args:
        obj: an object or its name.
        family: a design family (`DESIGN_FAMILIES`).
        check: what a grasp-types start must pass, a picklable function of the start (None: `verified`).
        perturbation: a relative change of every design's palm position (0, or e.g. 1e-12 to check that the
            search's outcome does not turn on the last bits; `scripts/check_starts.py`).
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
    tasks = [(obj, design, check if family == "grasp_types" else None, float(perturbation)) for design in designs]
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
                           and _same_solid(e["object"], obj.params())), (key, None))
    return None if entry is None else read_entry(arrays, key, entry, obj, family)


def _same_solid(shipped: dict, params: dict) -> bool:
    """Whether a shipped entry's object is this one: the same shape parameters (a mesh's digest among them), or the
    same member of the object family (`sim.family`, made by its name's recipe) whose sizes agree to 1e-9 m. A family
    mesh is computed where it is used, and its vertices' last bits, and so its digest, change with the arithmetic of
    the libraries that compute it (found with trimesh 5.2.0 and manifold3d 3.5.4: the bottles, frustums and the
    large ellipsoid, whose shipped starts were then searched again, with other designs)."""
    if geometry_params(shipped) == geometry_params(params):
        return True
    return (params["name"] in FAMILY and shipped["name"] == params["name"] and shipped["shape"] == params["shape"]
            and np.allclose(shipped["half_sizes"], params["half_sizes"], rtol=0.0, atol=1e-9))


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


def geometry_params(params: dict) -> dict:
    """An object's parameters less those that do not change where a grasp is (name, mass, friction): one mesh given
    as a file and as a `Trimesh` under another name has the same.

    Args:
        params: `GraspObject.params()`.

    Returns:
        The parameters of its shape (a mesh's digest among them).
    """
    return {k: v for k, v in params.items() if k not in ("name", "mass", "friction")}
