"""DexGraspBench's grasp files, read and written safely: other tools judge our grasps, we judge theirs.

A DexGraspBench grasp file is one `.npy` file per grasp holding a dict (a NumPy pickle): `obj_path` (a
processed object folder), `obj_scale`, `obj_pose` (7: position, quaternion w x y z) and, for each stage of
pregrasp, grasp and squeeze, the hand's root pose and joint positions: either inside `<stage>_qpos` (the 7
root values first, then the joints) or apart, as `<stage>_pose` (7) beside `<stage>_qpos` (the joints).
The joints are in the hand model's order (`HandModel.wrist_joints` then `finger_joints`, the order of
Menagerie's Shadow hand, which DexGraspBench uses) and senses; the root is the body the hand hangs from
(our `HandModel.mount`), its pose in the world, as the object's (`obj_pose`) is: the reader turns both into the
palm's pose in the object's frame. Every entry is checked (its kind of number, its count, finite values, a
quaternion of non-zero length, a positive scale, a palm within `replay.MAX_REACH` of the object) and a
fault named with its file.

A pickle can run any code while it is read, so `read_grasp_file` never hands one to `pickle` as it is:
it reads the .npy header itself and unpickles with an unpickler that admits only what NumPy arrays and
scalars need, each array's declared size bounded (`MAX_ELEMENTS`) before NumPy allocates it; the result must be
a dict of arrays, numbers and strings. Anything else is refused, the file named, before any of it runs.
"""

from __future__ import annotations

import io
import math
import os
import pickle
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base.errors import InvalidInput
from ..base.io import atomic_write
from ..base.poses import compose, invert
from ..base.validation import check_name, file_in
from ..judging.plans import STAGE_NAMES, OpenLoopGrasp
from ..manifold.postureset import PostureSet
from ..sim.hand import SEGMENTS, SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, make_object
from ..sim.scene import Scene

STAGES = STAGE_NAMES
#: the most elements an array of a grasp file may declare: a grasp file holds a few dozen numbers per entry, and
#: a small file can declare an array of any size (2**28 object elements took 2.2 GB before it was refused)
MAX_ELEMENTS = 10_000
#: the globals a pickle of NumPy arrays and scalars needs (NumPy 1 and 2 spell the module differently)
_ADMITTED = {(module, name) for module in ("numpy.core.multiarray", "numpy._core.multiarray")
             for name in ("_reconstruct", "scalar")} | {("numpy", "ndarray"), ("numpy", "dtype")}


class _BoundedArray(np.ndarray):
    """An array a grasp file's pickle builds, whose declared size is checked against `MAX_ELEMENTS` and against the
    data it brings before NumPy allocates it."""

    def __setstate__(self, state: tuple) -> None:
        shape, dtype, data = (state[1], state[2], state[4]) if len(state) == 5 else (state[0], state[1], state[3])
        size = math.prod(int(n) for n in shape)
        if not 0 <= size <= MAX_ELEMENTS:
            raise pickle.UnpicklingError(f"it declares an array of {size} elements (at most {MAX_ELEMENTS})")
        expected = size if np.dtype(dtype).hasobject else size * np.dtype(dtype).itemsize
        if len(data) != expected:
            raise pickle.UnpicklingError(f"an array of {size} elements brings {len(data)} "
                                         f"{'items' if np.dtype(dtype).hasobject else 'bytes'}, not {expected}")
        super().__setstate__(state)


class _ArraysOnly(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> object:
        if (module, name) not in _ADMITTED:
            raise pickle.UnpicklingError(f"it asks for {module}.{name}, which a file of arrays never needs")
        return _BoundedArray if (module, name) == ("numpy", "ndarray") else super().find_class(module, name)


def _plain(value: object) -> bool:
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "biufcUS"
    return isinstance(value, (str, bytes, int, float, bool, np.number, np.bool_))


def read_grasp_file(path: str | os.PathLike) -> dict[str, object]:
    """The dict of one DexGraspBench grasp file, read without running anything it holds.

    Args:
        path: the `.npy` file.

    Returns:
        {name: array, number or string}.

    Raises:
        ValueError: the file is missing, not a .npy file, truncated, or holds anything but a dict of arrays,
            numbers and strings (an arbitrary pickle is refused, not run); the message names the file.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise InvalidInput(f"grasp file {path}: cannot be read ({error.strerror})") from None
    stream = io.BytesIO(raw)
    try:
        version = np.lib.format.read_magic(stream)
        reader = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = reader(stream)
        if dtype.hasobject:
            content = _ArraysOnly(stream).load()
        else:  # a plain array is data, not a grasp
            raise InvalidInput(f"grasp file {path}: holds a plain {dtype} array, not a dict of a grasp")
    except InvalidInput:
        raise
    except Exception as error:  # noqa: BLE001 - every way a foreign or broken file fails is one refusal
        raise InvalidInput(f"grasp file {path}: refused, not a DexGraspBench grasp file of arrays ({error})") from None
    if isinstance(content, np.ndarray) and content.shape == () and content.dtype.hasobject:
        content = content.item()
    if not isinstance(content, dict) or not all(isinstance(k, str) and _plain(v) for k, v in content.items()):
        raise InvalidInput(f"grasp file {path}: refused, it must hold a dict of arrays, numbers and strings, got "
                           f"{type(content).__name__}")
    return {k: v.view(np.ndarray) if isinstance(v, np.ndarray) else v for k, v in content.items()}


def _numbers(content: dict, key: str, path: Path, size: int) -> np.ndarray:
    """A grasp file's entry as `size` finite real numbers, or a refusal naming the file, the entry and the fault."""
    value = np.asarray(content[key])
    kind = {"c": "complex numbers", "U": "text", "S": "text", "b": "booleans", "O": "objects"}.get(value.dtype.kind)
    if kind is not None or value.dtype.kind not in "iuf":
        raise InvalidInput(f"grasp file {path}: {key} must be real numbers, got {kind or value.dtype} "
                           f"({np.array2string(value.ravel()[:3], threshold=3)[:60]})")
    value = value.astype(float).ravel()
    if value.size != size:
        raise InvalidInput(f"grasp file {path}: {key} must hold {size} value{'s' if size > 1 else ''}, got "
                           f"{value.size}")
    if not np.all(np.isfinite(value)):
        raise InvalidInput(f"grasp file {path}: {key} holds non-finite values (NaN or infinite) at "
                           f"{np.flatnonzero(~np.isfinite(value))[:5].tolist()}")
    return value


def _pose(value: np.ndarray, key: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A pose of 7 finite values (position m, quaternion w x y z) as position and unit quaternion."""
    length = float(np.linalg.norm(value[3:]))
    if length < 1e-9:
        raise InvalidInput(f"grasp file {path}: {key}'s quaternion (its last 4 values, w x y z) has zero length")
    return value[:3], value[3:] / length


@dataclass(frozen=True)
class GraspFile:
    """One grasp read from a DexGraspBench grasp file.

    Attributes:
        path: the file.
        object_path: the processed object folder the file names (as written there).
        object_scale: the object's scale.
        object_pose: (7,) the object's pose (position m, quaternion w x y z) in the world.
        grasp: the pregrasp, grasp and squeeze: palm poses in the object frame and postures (paper order, rad).
        wrist: (3, 2) rad, the wrist joints per stage.
    """

    path: Path
    object_path: str
    object_scale: float
    object_pose: np.ndarray
    grasp: OpenLoopGrasp
    wrist: np.ndarray


def _mount_to_palm(hand: HandModel) -> tuple[np.ndarray, np.ndarray]:
    """The palm's pose in the frame of the body the hand hangs from (the wrist straight)."""
    scene = Scene("box", hand=hand)
    mount = scene.data.mocap_pos[scene.mount_id].copy(), scene.data.mocap_quat[scene.mount_id].copy()
    return compose(*invert(*mount), scene.data.xpos[scene.palm_id].copy(), scene.data.xquat[scene.palm_id].copy())


def read_grasp_files(folder: str | os.PathLike, hand: str | HandModel = SHADOW_HAND.name) -> list[GraspFile]:
    """Every DexGraspBench grasp file (`*.npy`) in a folder, for a Shadow hand (see the module doc).

    Args:
        folder: the folder (its files read in name order).
        hand: the hand model whose joint order and senses the files use, or its name.

    Returns:
        One `GraspFile` per file.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InvalidInput(f"folder must be a folder of grasp files, got {folder}")
    hand = hand if isinstance(hand, HandModel) else hand_model(hand)
    palm_in_mount = _mount_to_palm(hand)
    joints = len(hand.wrist_joints) + len(hand.finger_joints)
    grasps = []
    for path in sorted(folder.glob("*.npy")):
        content = read_grasp_file(path)
        missing = [k for k in ("obj_path", "obj_scale", "obj_pose", *(f"{s}_qpos" for s in STAGES)) if k not in content]
        if missing:
            raise InvalidInput(f"grasp file {path}: lacks {missing}")
        object_path = content["obj_path"]
        object_path = object_path.item() if isinstance(object_path, np.ndarray) and object_path.shape == () \
            else object_path
        if not isinstance(object_path, (str, np.str_)) or not str(object_path):
            raise InvalidInput(f"grasp file {path}: obj_path must be the text of a folder, got {object_path!r:.60}")
        scale = float(_numbers(content, "obj_scale", path, 1)[0])
        if scale <= 0:
            raise InvalidInput(f"grasp file {path}: obj_scale must be a positive number, got {scale}")
        world_to_object = invert(*_pose(_numbers(content, "obj_pose", path, 7), "obj_pose", path))
        poses, postures, wrists = [], [], []
        for stage in STAGES:
            if f"{stage}_pose" in content:
                root, qpos = (_numbers(content, f"{stage}_pose", path, 7),
                              _numbers(content, f"{stage}_qpos", path, joints))
            else:
                qpos = _numbers(content, f"{stage}_qpos", path, 7 + joints)
                root, qpos = qpos[:7], qpos[7:]
            # the root's pose is in the world, the object's too: the palm's in the object's frame
            palm = compose(*world_to_object, *compose(*_pose(root, f"{stage}'s root pose", path), *palm_in_mount))
            poses.append(np.r_[palm[0], palm[1]])
            wrists.append(qpos[: len(hand.wrist_joints)])
            postures.append(hand.from_model(qpos[len(hand.wrist_joints):]))
        try:
            grasp = OpenLoopGrasp(np.array(poses), np.array(postures))
        except InvalidInput as error:
            raise InvalidInput(f"grasp file {path}: {error}") from None
        obj_pose = _numbers(content, "obj_pose", path, 7)
        grasps.append(GraspFile(path, str(object_path), scale, np.r_[obj_pose[:3], _pose(obj_pose, "", path)[1]],
                                grasp, np.array(wrists)))
    return grasps


def write_grasp_files(folder: str | os.PathLike, grasps: list[OpenLoopGrasp], object_path: str,
                      object_scale: float = 1.0, hand: str | HandModel = SHADOW_HAND.name, prefix: str = "grasp") -> list[Path]:
    """Our grasps as DexGraspBench grasp files (the root pose inside `<stage>_qpos`, the wrist straight).

    Args:
        folder: where to write them (made when missing).
        grasps: the grasps (palm poses in the object frame, postures).
        object_path: the processed object folder to name in them.
        object_scale: the object's scale.
        hand: the hand model whose joint order and senses to write, or its name.
        prefix: the files are `<prefix>_00000.npy`, ...

    Returns:
        The files written.
    """
    check_name(prefix, "prefix")
    hand = hand if isinstance(hand, HandModel) else hand_model(hand)
    mount_in_palm = invert(*_mount_to_palm(hand))
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for k, grasp in enumerate(grasps):
        content: dict[str, object] = {"obj_path": str(object_path), "obj_scale": float(object_scale),
                                      "obj_pose": np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])}
        for stage, pose, posture in zip(STAGES, grasp.poses, grasp.postures):
            root = compose(pose[:3], pose[3:], *mount_in_palm)
            content[f"{stage}_qpos"] = np.concatenate([root[0], root[1], np.zeros(len(hand.wrist_joints)),
                                                       hand.to_model(posture)])
        path = file_in(folder, f"{prefix}_{k:05d}.npy", "prefix")
        with atomic_write(path) as handle:  # a full disk left a '.npy.partial' behind
            np.save(handle, np.array(content, dtype=object), allow_pickle=True)
        written.append(path)
    return written


#: where a processed object folder keeps its mesh, tried in turn (then any .obj, .stl or .ply in the folder, in name
#: order)
MESH_FILES: tuple[str, ...] = ("mesh/simplified.obj", "mesh/coacd.obj", "simplified.obj")


def grasp_object(grasp: GraspFile, root: str | os.PathLike | None = None, mass: float = 0.1) -> GraspObject:
    """The object a grasp file names: the mesh of its processed object folder (`obj_path`, relative to `root`),
    at the file's scale. The folder must lie inside `root` (a file's `../..` or absolute path that leads elsewhere
    is refused, not searched), and its meshes are looked for in it and the folders in it.

    Args:
        grasp: a grasp read by `read_grasp_files`.
        root: the folder the objects are in, that `obj_path` is relative to (None: the working directory).
        mass: kg (DexGraspBench sets its objects' mass by density; `protocols.PhysicsProfile` does on a scene).

    Returns:
        The mesh object, named after its folder.

    Raises:
        ValueError: the folder leads outside `root`, is missing, or holds no mesh; the message names it.
    """
    base = Path.cwd() if root is None else Path(root)
    folder = base / grasp.object_path
    if not folder.resolve().is_relative_to(base.resolve()) or folder.resolve() == base.resolve():
        raise InvalidInput(f"grasp file {grasp.path}: its obj_path {grasp.object_path!r} leads outside "
                           f"{'the working directory' if root is None else root} ({folder.resolve()}); an object folder "
                           "must lie inside the folder the objects are in (root)")
    if not folder.is_dir():
        raise InvalidInput(f"grasp file {grasp.path}: its object folder {folder} is missing (obj_path "
                           f"{grasp.object_path!r}{'' if root is None else f' under {root}'})")
    found = [folder / name for name in MESH_FILES if (folder / name).is_file()]
    # the folder and the folders in it, no deeper: a processed object keeps its meshes there
    found += sorted(p for pattern in ("*", "*/*") for p in folder.glob(pattern)
                    if p.suffix.lower() in (".obj", ".stl", ".ply") and p.is_file())
    if not found:
        raise InvalidInput(f"grasp file {grasp.path}: its object folder {folder} holds no mesh ({', '.join(MESH_FILES)}, "
                           "or any .obj, .stl or .ply)")
    return make_object("mesh", mesh=found[0], scale=grasp.object_scale, mass=mass, name=folder.name)


def posture_set(grasps: list[GraspFile]) -> PostureSet:
    """Grasps read from files as a posture set: the grasp stage's postures and palm poses, the pregrasp's and the
    squeeze's in its metadata (`pregrasp`, `pregrasp_poses`, `squeeze`, `squeeze_poses`, lists), the files' names
    in `files`.

    Args:
        grasps: grasps read by `read_grasp_files` (one object's, as a posture set holds one object's).

    Returns:
        The posture set (its contacts unknown: all False; one start, 'dexgraspbench').
    """
    if not grasps:
        raise InvalidInput("grasps must hold at least one grasp read from a file")
    stage = {name: np.array([g.grasp.postures[k] for g in grasps]) for k, name in enumerate(STAGES)}
    poses = {name: np.array([g.grasp.poses[k] for g in grasps]) for k, name in enumerate(STAGES)}
    metadata = {"source": "dexgraspbench", "files": [str(g.path) for g in grasps],
                **{name: stage[name].tolist() for name in ("pregrasp", "squeeze")},
                **{f"{name}_poses": poses[name].tolist() for name in ("pregrasp", "squeeze")}}
    return PostureSet(stage["grasp"], poses["grasp"], np.zeros(len(grasps), dtype=np.int64),
                      np.zeros((len(grasps), len(SEGMENTS)), dtype=bool), ("dexgraspbench",), metadata)
