"""Where trials start: the grid of object poses in front of the open hand (paper Section 5).

The grid is given in the palm frame around a nominal wrap placement (object long axis across the
fingers, centred in front of the palm, see `scene.facing_pose`): shifts across the fingers (x) and
along them (z), the gap between palm and object, and a yaw of the object's axis about the palm
normal. Presets (`grid_preset`): 'quick' and 'paper' cover where the open hand can plausibly close
on the object; 'far' puts the object 3-5 cm out of the palm; 'hard' shifts it up to 3 cm and turns
it up to 0.8 rad. Every preset is a regular grid less the placements where the object would sit
inside (or within 1 mm of) the open hand, which no hand could have reached (`reachable`).
`coverage` says how near an experience base's palm poses come to each grid pose.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput
from ..base.poses import compose, invert, invert_many, quat_products, rotate, to_quat
from ..judging.plans import OpenLoopGrasp
from ..manifold.nearest import argmin_tied
from ..sim.hand import SEGMENTS, segment_of_geoms
from ..sim.objects import GraspObject, get_object
from ..sim.posture import open_posture
from ..sim.scene import MAX_GAP, Scene, placed_facing

GRID_COLUMNS = ("x", "z", "gap", "yaw")
GRID_PRESETS = ("quick", "paper", "far", "hard")
#: each preset in words (the values of `grid_preset`), for reports
GRID_DESCRIPTIONS = {
    "quick": "x and z in {-1.5, 0, 1.5} cm, gaps 1 and 2.5 cm, yaw in {-0.5, 0, 0.5} rad (a sphere: gaps 1-3.1 cm)",
    "paper": "x and z in 5 steps over ±2 cm, gaps 1, 2 and 3 cm, yaw in 5 steps over ±0.5 rad (a sphere: 9 gaps "
             "over 1-3.4 cm, no yaw)",
    "far": "gaps 3, 4 and 5 cm (a sphere: 3-5 cm in 5), x in {-1.5, 0, 1.5} cm, z in {-2, 0, 2} cm, yaw in {-0.5, 0, 0.5}",
    "hard": "x and z in {-3, -1.5, 0, 1.5, 3} cm, gaps 1 and 2.5 cm, yaw in {-0.8, -0.4, 0, 0.4, 0.8} rad",
}
START_CLEARANCE = 0.001  # m: the open hand must be at least this far from the object at a grid pose
#: m: a planned trial starts where the hand in the plan's pregrasp lies at most this deep inside the displaced object,
#: or no deeper than at the nominal pose (a verified pregrasp may start up to DexGraspBench's 1 cm inside; `check_grid`)
PLANNED_START_DEPTH = 0.001
#: m: the nominal pose's own depth, found again where the hand is put there anew, differs in its last bits
START_DEPTH_TOLERANCE = 1e-6
#: a grid pose is covered by the experience where a verified grasp holds the object's centre within this distance (m)
#: of where the pose puts it, seen from the palm, its long axis within `COVERED_ANGLE` (rad) (`covered`)
COVERED_WITHIN, COVERED_ANGLE = 0.01, math.radians(30.0)


def grid_preset(name: str, obj: str | GraspObject, table: bool = False) -> np.ndarray:
    """Grid poses of a preset: object shift across (x) and along (z) the fingers, palm gap, yaw.

    A regular grid less the poses the open hand cannot reach (`reachable`; `why_unreachable` says why one is
    refused: a cylinder turned by a positive yaw brings its end into the thumb, so the cylinder's grids keep
    only yaws <= 0). 'quick': x and z in {-1.5, 0, 1.5} cm, gaps 1 and 2.5 cm, yaw in {-0.5, 0, 0.5} before
    that (box 37, cylinder 30 poses); 'paper': x and z in 5 steps over +-2 cm, gaps 1-3 cm, 5 yaws over
    +-0.5 rad (box 263, cylinder 224). A sphere has no yaw, so it gets more gaps instead (quick 36, paper 225
    poses, all reachable). 'far': gaps 3, 4 and 5 cm, x in {-1.5, 0, 1.5} cm, z in {-2, 0, 2} cm, yaw in
    {-0.5, 0, 0.5}; 'hard': x and z in {-3, -1.5, 0, 1.5, 3} cm, gaps 1 and 2.5 cm, yaw in
    {-0.8, -0.4, 0, 0.4, 0.8}.

    Args:
        name: the preset, one of `GRID_PRESETS`.
        obj: the object, or its name.
        table: the object stands on a table (poses where the open hand would touch it are left out).

    Returns:
        The poses (n, 4): x, z, gap in m, yaw in rad.

    Raises:
        ValueError: an unknown preset, or no pose of it is reachable for this object.
    """
    obj = get_object(obj)
    sphere = obj.shape == "sphere"
    yaws: dict[str, Iterable[float]] = {
        "quick": [-0.5, 0.0, 0.5], "paper": np.linspace(-0.5, 0.5, 5), "far": [-0.5, 0.0, 0.5],
        "hard": [-0.8, -0.4, 0.0, 0.4, 0.8]}
    if name not in GRID_PRESETS:
        raise InvalidInput(f"unknown grid preset {name!r}; expected one of {GRID_PRESETS} or an (n, 4) array")
    yaw = [0.0] if sphere else yaws[name]
    axes: tuple[Iterable[float], ...]
    if name == "quick":
        axes = ([-0.015, 0.0, 0.015], [-0.015, 0.0, 0.015], [0.01, 0.017, 0.024, 0.031] if sphere else [0.01, 0.025], yaw)
    elif name == "paper":
        axes = (np.linspace(-0.02, 0.02, 5), np.linspace(-0.02, 0.02, 5),
                np.linspace(0.01, 0.034, 9) if sphere else [0.01, 0.02, 0.03], yaw)
    elif name == "far":
        axes = ([-0.015, 0.0, 0.015], [-0.02, 0.0, 0.02], [0.03, 0.035, 0.04, 0.045, 0.05] if sphere
                else [0.03, 0.04, 0.05], yaw)
    else:
        axes = (np.linspace(-0.03, 0.03, 5), np.linspace(-0.03, 0.03, 5), [0.01, 0.025], yaw)
    poses = np.array(list(itertools.product(*axes)), dtype=np.float64)
    poses = poses[reachable(obj, poses, table)]
    if not len(poses):
        raise InvalidInput(f"no pose of the {name!r} grid is reachable for {obj.name}: at every one the object lies "
                         f"inside (or within {START_CLEARANCE * 1000:.0f} mm of) the open hand{' or the table' if table else ''}; "
                         "an object this large needs a custom grid with larger gaps (graspmanifold.reachable)")
    return poses


def _nearest_to_hand(scene: Scene, pose: np.ndarray) -> tuple[float, str, str]:
    """(distance in m, the hand segment, 'object' or 'table') of the pair nearest the open hand at one grid
    pose (moves the hand there); negative distances are penetration."""
    model, data = scene.model, scene.data
    scene.set_hand_pose(*palm_pose_for(scene.object, pose))
    data.qpos[scene.finger_qpos] = open_posture()
    mujoco.mj_kinematics(model, data)
    segments = segment_of_geoms(model)
    fromto = np.zeros(6)
    pairs = [(scene.distance_to_object(g), SEGMENTS[segments[g]], "object")
             for g in np.flatnonzero(segments >= 0).tolist()]
    if scene.table_geom is not None:
        pairs += [(mujoco.mj_geomDistance(model, data, g, scene.table_geom, 0.05, fromto), SEGMENTS[segments[g]], "table")
                  for g in np.flatnonzero(segments >= 0)]
    return min(pairs, key=lambda pair: pair[0])


def clearance(scene: Scene, pose: np.ndarray) -> float:
    """Distance (m) between the open hand and the object of `scene` at one grid pose (moves the hand there)."""
    return _nearest_to_hand(scene, pose)[0]


def why_unreachable(obj: str | GraspObject, pose: object, table: bool = False) -> str | None:
    """Why no trial can start at a grid pose, or None when one can.

    Args:
        obj: the object, or its name.
        pose: one grid pose (x, z, gap, yaw), m and rad.
        table: the object stands on a table (the open hand must clear it too).

    Returns:
        None when the open hand is at least `START_CLEARANCE` from the object (and the table), otherwise
        which segment of the open hand comes too near and by how much, e.g. "the open hand's ffdistal
        is 3.2 mm inside the object".
    """
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (4,) or not np.all(np.isfinite(pose)):
        raise InvalidInput(f"pose must be four finite numbers {GRID_COLUMNS}, got {pose!r}")
    obj = get_object(obj)
    distance, segment, what = _nearest_to_hand(Scene(obj, free_object=True, table=table), pose)
    if distance >= START_CLEARANCE:
        return None
    where = f"{-distance * 1000:.1f} mm inside" if distance < 0 else f"{distance * 1000:.1f} mm from"
    return (f"the open hand's {segment} is {where} the {what if what == 'table' else obj.name} (a trial needs "
            f"{START_CLEARANCE * 1000:.0f} mm of clearance)")


def open_hand_clearance(obj: str | GraspObject, grid: np.ndarray, table: bool = False) -> np.ndarray:
    """Distance (m) between the open hand and the object (and the table, with one) at each grid pose;
    negative when inside."""
    scene = Scene(get_object(obj), free_object=True, table=table)
    return np.array([clearance(scene, pose) for pose in np.asarray(grid, dtype=float)])


def reachable(obj: str | GraspObject, grid: np.ndarray, table: bool = False) -> np.ndarray:
    """Which grid poses leave the open hand clear of the object (and of the table, with one).

    Args:
        obj: the object, or its name.
        grid: poses (n, 4): x, z, gap in m, yaw in rad.
        table: the object stands on a table.

    Returns:
        (n,) bool: True where a trial can start (at least `START_CLEARANCE` of clearance).
    """
    return open_hand_clearance(obj, grid, table) >= START_CLEARANCE


def check_grid(grid: object, obj: GraspObject, table: bool = False,
               plan: OpenLoopGrasp | None = None) -> tuple[str, np.ndarray]:
    """The grid's name and its poses (n, 4), refused where no trial can start.

    Args:
        grid: a preset name (`GRID_PRESETS`), or poses (n, 4) or one pose (4,): x, z, gap in m, yaw in rad.
        obj: the object.
        table: the object stands on a table.
        plan: a planned grasp: the poses are then the object's displacements from where it assumed the object
            (`displaced_palm_pose`), refused where the hand in the plan's pregrasp lies more than
            `PLANNED_START_DEPTH` inside the displaced object.

    Returns:
        ('custom' or the preset's name, the poses).

    Raises:
        InvalidInput: a bad grid, or a pose where no trial can start (the message says why).
    """
    if isinstance(grid, str):
        if plan is not None:
            raise InvalidInput(f"a planned trial's poses are the object's displacements (n, 4), not a preset ({grid!r})")
        return grid, grid_preset(grid, obj, table)
    try:
        poses = np.asarray(grid, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"grid must be one of {GRID_PRESETS} or an (n, 4) array of numbers {GRID_COLUMNS} "
                         f"(m, rad), got {grid!r:.80}") from None
    if poses.shape == (4,):  # one pose
        poses = poses.reshape(1, 4)
    if poses.ndim != 2 or poses.shape[1] != 4 or len(poses) == 0:
        raise InvalidInput(f"grid must be one of {GRID_PRESETS} or a non-empty (n, 4) array of {GRID_COLUMNS}, "
                         f"got shape {poses.shape}")
    if not np.all(np.isfinite(poses)):
        raise InvalidInput("grid poses must be finite")
    far = np.flatnonzero((np.abs(poses[:, :3]) > MAX_GAP).any(axis=1) | (np.abs(poses[:, 3]) > np.pi))
    if len(far):  # a pose 5 m away ran as a valid trial that failed
        raise InvalidInput(f"grid rows {far.tolist()[:10]} lie beyond the hand's reach: x, z and the gap must be within "
                         f"±{MAX_GAP} m and the yaw within ±π rad")
    if plan is not None:
        clear, depth, allowed = planned_start_clear(obj, plan.poses[0], plan.postures[0], poses, table)
        inside = np.flatnonzero(~clear)
        if len(inside):
            raise InvalidInput(f"displacements {inside.tolist()[:10]}{' ...' if len(inside) > 10 else ''} put the object "
                               f"inside the hand in the plan's pregrasp (row {inside[0]}: "
                               f"{depth[inside[0]] * 1000:.1f} mm deep; at most {allowed * 1000:.1f} mm), "
                               "where no trial can start; keep those that planned_start_clear allows")
        return "custom", poses
    inside = np.flatnonzero(~reachable(obj, poses, table))
    if len(inside):
        first = inside[0]
        raise InvalidInput(f"grid rows {inside.tolist()[:10]}{' ...' if len(inside) > 10 else ''} put the object inside "
                         f"(or within {START_CLEARANCE * 1000:.0f} mm of) the open hand, where no trial can start (row "
                         f"{first}, {dict(zip(GRID_COLUMNS, poses[first].round(4).tolist()))}: "
                         f"{why_unreachable(obj, poses[first], table)}); keep the reachable ones: "
                         "grid[graspmanifold.reachable(obj, grid)]")
    return "custom", poses


def palm_pose_for(obj: GraspObject, grid_pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Palm pose in the object frame that places the object at a grid pose relative to the palm."""
    x, z, gap, yaw = grid_pose
    object_in_palm = invert(*placed_facing(obj, gap))
    turn = to_quat(Rotation.from_rotvec([0.0, yaw, 0.0]))  # about the palm normal
    _, quat = compose(np.zeros(3), turn, np.zeros(3), object_in_palm[1])
    return invert(object_in_palm[0] + np.array([x, 0.0, z]), quat)


def palm_poses_for(obj: GraspObject, grid_poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`palm_pose_for` of many grid poses at once, in array arithmetic (equal to it but for the last bits).

    Args:
        obj: the object.
        grid_poses: (n, 4) x, z, gap in m, yaw in rad.

    Returns:
        The palm's positions (n, 3), m, and orientations (n, 4), w x y z, in the object frame.
    """
    x, z, gap, yaw = np.asarray(grid_poses, dtype=float).reshape(-1, 4).T
    facing = np.array([placed_facing(obj, g)[0] for g in np.unique(gap)])  # a few gaps: one pose each
    placed = facing[np.searchsorted(np.unique(gap), gap)]
    in_palm, in_palm_quat = invert_many(placed, placed_facing(obj, 0.0)[1])
    turn = np.column_stack([np.cos(yaw / 2), np.zeros_like(yaw), np.sin(yaw / 2), np.zeros_like(yaw)])
    return invert_many(in_palm + np.column_stack([x, np.zeros_like(x), z]), quat_products(turn, in_palm_quat))


def displaced_palm_pose(palm_pose: np.ndarray, displacement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The palm's pose in the frame of an object lying off the pose a plan assumed: the palm stays where the plan
    put it for the nominal pose; the object is moved, in the palm frame, by x across the fingers, z along them and
    gap further from the palm (along the palm normal), and turned by yaw about the palm normal through its centre.

    Args:
        palm_pose: (7,) the plan's palm position (m) and orientation (w x y z) in the nominal object's frame.
        displacement: (4,) x, z, gap in m, yaw in rad (the grid's columns, `GRID_COLUMNS`, read as a change).

    Returns:
        The palm's position (3,), m, and orientation (4,) in the displaced object's frame.
    """
    palm_pose, displacement = np.asarray(palm_pose, dtype=float), np.asarray(displacement, dtype=float)
    x, z, gap, yaw = displacement
    centre, quat = invert(palm_pose[:3], palm_pose[3:])  # the nominal object in the palm frame
    turn = to_quat(Rotation.from_rotvec([0.0, yaw, 0.0]))  # about the palm normal
    _, turned = compose(np.zeros(3), turn, np.zeros(3), quat)
    return invert(centre + np.array([x, -gap, z]), turned)


def oracle_correction(palm_pose: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    """How an arm's flange must carry the palm to undo an object's displacement (`displaced_palm_pose`): the palm
    turned by the object's yaw about its normal and moved so that the object sits in it as the plan had it. An
    oracle reads this (`TrialSetup.oracle`); no controller may.

    Args:
        palm_pose: (7,) the plan's palm position (m) and orientation (w x y z) in the nominal object's frame.
        displacement: (4,) x, z, gap in m, yaw in rad.

    Returns:
        (6,) the flange's set point from home (`Scene.steer_flange`): m along the palm's x, y, z and rad about
        them, in the palm's frame where the trial put it.
    """
    palm_pose, displacement = np.asarray(palm_pose, dtype=float), np.asarray(displacement, dtype=float)
    x, z, gap, yaw = displacement
    centre = invert(palm_pose[:3], palm_pose[3:])[0]  # the nominal object in the palm frame
    turn = Rotation.from_rotvec([0.0, yaw, 0.0])  # about the palm normal, as the object turned
    return np.concatenate([centre + np.array([x, -gap, z]) - turn.apply(centre), [0.0, yaw, 0.0]])


def planned_start_depth(obj: str | GraspObject, palm_pose: np.ndarray, posture: np.ndarray,
                        displacements: np.ndarray, table: bool = False) -> np.ndarray:
    """How deep (m) the hand lies inside the object at the start of each planned trial: the palm where the plan
    put it (`displaced_palm_pose`), the fingers in the plan's starting posture (0 where nothing overlaps).

    Args:
        obj: the object, or its name.
        palm_pose: (7,) the plan's starting palm pose in the nominal object's frame.
        posture: (22,) rad, the plan's starting posture.
        displacements: (n, 4) the objects' displacements (`displaced_palm_pose`).
        table: the object stands on a table.

    Returns:
        (n,) m.
    """
    scene = Scene(get_object(obj), free_object=True, table=table)
    depths = []
    for displacement in np.asarray(displacements, dtype=float).reshape(-1, 4):
        scene.set_posture(posture)
        scene.set_hand_pose(*displaced_palm_pose(palm_pose, displacement))
        depths.append(scene.penetration())
    return np.array(depths)


def planned_start_clear(obj: str | GraspObject, palm_pose: np.ndarray, posture: np.ndarray,
                        displacements: np.ndarray, table: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Where a planned trial can start: the hand in the plan's starting posture lies at most `PLANNED_START_DEPTH`
    inside the displaced object, or no deeper than at the nominal pose (`planned_start_depth`).

    Args:
        obj: the object, or its name.
        palm_pose: (7,) the plan's starting palm pose in the nominal object's frame.
        posture: (22,) rad, the plan's starting posture.
        displacements: (n, 4) the objects' displacements.
        table: the object stands on a table.

    Returns:
        ((n,) bool: clear, (n,) m: each start's depth, m: the depth allowed).
    """
    depth = planned_start_depth(obj, palm_pose, posture, np.vstack([np.zeros(4), np.reshape(displacements, (-1, 4))]),
                                table)
    allowed = max(PLANNED_START_DEPTH, float(depth[0]) + START_DEPTH_TOLERANCE)
    return depth[1:] <= allowed, depth[1:], allowed


def coverage(obj: str | GraspObject, grid: np.ndarray, hand_poses: np.ndarray) -> np.ndarray:
    """How near the experience comes to each grid pose, (n, 2): the distance (m) from the object's
    centre seen from the palm at the grid pose to the nearest experienced one, and the angle (rad)
    between the object's long axis seen from the palm there and at that nearest experience.

    Seen from the palm, the centre and the long axis (up to its sign) do not change under the
    object's symmetries (turning a cylinder about its axis, a sphere about anything), so a grasp
    from the other side of a cylinder counts as the same placement. `hand_poses` (m, 7) are
    experienced palm poses in the object frame (`PostureSet.hand_poses`).
    """
    obj = get_object(obj)
    poses = np.asarray(hand_poses, dtype=float)
    poses = poses[None] if poses.shape == (7,) else poses
    if poses.ndim != 2 or poses.shape[1] != 7 or not len(poses) or not np.all(np.isfinite(poses)):
        raise InvalidInput(f"hand_poses must be at least one finite experienced palm pose (m, 7): position (m) and "
                           f"orientation (w x y z), got shape {poses.shape}")

    def seen_from_palm(pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        centre, inverse = invert(pos, quat)
        return centre, rotate(np.array([0.0, 0.0, 1.0]), inverse)

    experienced = [seen_from_palm(p[:3], p[3:]) for p in poses]
    centres = np.array([c for c, _ in experienced])
    axes = np.array([a for _, a in experienced])
    out = np.empty((len(grid), 2))
    for i, grid_pose in enumerate(np.asarray(grid, dtype=float)):
        centre, axis = seen_from_palm(*palm_pose_for(obj, grid_pose))
        distances = np.linalg.norm(centres - centre, axis=1)
        nearest = argmin_tied(distances)
        angle = 0.0 if obj.shape == "sphere" else float(np.arccos(min(1.0, abs(float(axes[nearest] @ axis)))))
        out[i] = distances[nearest], angle
    return out


def covered(obj: str | GraspObject, grid: np.ndarray, hand_poses: np.ndarray, within: float = COVERED_WITHIN,
            angle: float = COVERED_ANGLE) -> np.ndarray:
    """Which grid poses the experience covers: a verified grasp of it (its palm pose in the object frame) holds the
    object's centre within `within` of where the pose puts it, seen from the palm, with the long axis within `angle`
    (`coverage`; the object's symmetries count as the same placement). The paper's grid read honestly: where nothing
    is covered, no recall of a verified grasp can hold the object without the palm moving.

    Args:
        obj: the object, or its name.
        grid: (n, 4) grid poses.
        hand_poses: (m, 7) the verified grasps' palm poses in the object frame (`PostureSet.hand_poses`).
        within: m.
        angle: rad.

    Returns:
        (n,) bool.
    """
    for name, value in (("within", within), ("angle", angle)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise InvalidInput(f"{name} must be a finite number >= 0, got {value!r}")
    near = coverage(obj, grid, hand_poses)
    return (near[:, 0] <= within) & (near[:, 1] <= angle)
