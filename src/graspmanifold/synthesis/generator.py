"""Spring-based grasp posture generation (paper Section 5).

The object is held fixed. Each fingertip is pulled towards its closest point on the object surface
by a spring force applied in the simulation, while the finger servos hold the starting posture
only softly, so the fingers follow the springs. Around each starting posture the hand takes a
random walk through nearby positions and orientations, in steps small enough for the springs to
keep up; after each step the hand settles and the posture is tested. Postures in which all five
distal segments touch the object (gap <= 1 mm), nothing penetrates deeper than 2 mm, every joint is
inside its range and the hand is at rest are candidates. Because the walk stays near its starting
posture, the data clusters around the starting postures, as the paper's did.

The starting postures come from a family of designs (`GeneratorParams.designs`, `starts.DESIGN_FAMILIES`):
by default every grasp type (power wraps, pinch, tripod, lateral), each start one that holds when
verified, where only the design's own contact segments are pulled by springs (a fingertip by its tip,
another segment at its point nearest the object) and must touch, while the fingers that take no part
stay curled; or the paper's five-fingertip grasps (the presets of `reproduce`, the paper's procedure).

Our extension of the paper's procedure verifies every candidate as a grasp
(`GeneratorParams.verify`, on by default) by the one open-loop replay of the library
(`replay.replay_grasp`, the replay DexGraspBench's protocol judges grasps by): from a pregrasp (the open
hand 2 cm back, or the fingers backed off along the contacts' normals: `GeneratorParams.stages`) the hand moves
to the candidate and its squeeze on the free, unsupported object, and the protocol named by
`GeneratorParams.verify_protocol` judges it (ours: six gravity directions of `verify_hold_seconds` each;
DexGraspBench's: its physics and external-force test); only candidates that hold are kept, with their epsilon (at the object's friction) and largest
displacement recorded in the set. `generate_postures(obj, n)` returns n postures either way: with
verification it draws candidates in waves until n hold, at most `max_candidates_per_posture` times
n of them, and names the yield when that is not enough (`GenerationError`).

Work is cut into jobs (a starting posture and a chunk of candidates) with their own random streams,
so the set depends on the seed alone (not on the number of workers), jobs run in parallel
processes, and a run with a checkpoint directory resumes after an interruption without redoing
finished jobs.
"""

from __future__ import annotations

import itertools
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import asdict, dataclass, replace
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..base.checkpoints import JOB_PARTS, PartStore, result_key
from ..base.errors import GenerationError, InvalidInput, SimulationError
from ..base.io import library_version, load_npz, save_npz
from ..base.moved import current_name, moved_keyword
from ..base.paper_numbers import DATASET_SIZES
from ..base.poses import to_quat, to_rotation
from ..base.progress import progress_bar
from ..base.validation import check_choice, check_int
from ..base.workers import parallel_map, split_workers, workers_for
from ..judging.judge import VERIFY_HOLD_SECONDS
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOL_NAMES
from ..judging.replay import GRASP_STAGES, VERIFY_STAGES, GraspStages, GraspVerifier
from ..manifold.postureset import PostureSet
from ..sim.grip import SQUEEZE
from ..sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, SEGMENTS, SHADOW_HAND, HandModel, segment_of_geoms
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, get_object
from ..sim.scene import Scene
from .starts import (
    CONTACT_GAP,
    DESIGN_FAMILIES,
    MAX_PENETRATION,
    StartingPosture,
    check_starting_postures,
    designs_for,
    find_starting_postures,
    geometry_params,
    read_entry,
    save_starting_postures,
    shipped_starting_postures,
    verified,
)

DATASET_PRESETS: dict[str, dict[str, int]] = {
    "paper": dict(DATASET_SIZES),
    "quick": {"box": 240, "cylinder": 240, "sphere": 160},
}
"""Postures per object: the paper's dataset sizes (Section 5), and a small set for tests and demos."""


#: postures that pay for a worker process when `workers` is not given (a pool's start costs about a second)
GENERATE_PER_WORKER = 50
VERIFY_PER_WORKER = 20
#: the most postures one call makes (the paper's sets are a few thousand; a million take a day on two cores)
MAX_POSTURES = 1_000_000
#: `verify_postures` warns when fewer than this share of the candidates hold
FEW_HOLD = 0.1

#: how candidates are taken along the walk (`GeneratorParams.mode`)
MODES = ("settled", "recording")


@dataclass(frozen=True)
class GeneratorParams:
    """Settings of the spring generator (SI units, radians)."""

    spring_stiffness: float = 150.0  # N/m, fingertip to closest surface point
    spring_max_force: float = 2.0  # N
    servo_stiffness_scale: float = 0.15  # finger servo gains are scaled down so the fingers follow
    walk_radius: float = 0.012  # m, how far the hand strays from its starting pose
    walk_angle: float = 0.2  # rad, how far it turns
    step_size: float = 0.003  # m, standard deviation of one walk step
    step_angle: float = 0.04  # rad
    move_steps: int = 15  # physics steps to move the hand by one walk step
    settle_steps: int = 150  # physics steps at most to come to rest
    rest_speed: float = 0.1  # rad/s, the hand is at rest below this joint speed
    job_size: int = 200  # postures per job (the unit of parallel work and of checkpoints)
    #: "settled": one candidate per walk step, once the hand has come to rest; "recording": like the
    #: paper's procedure, a candidate every `record_every` physics steps along the hand's slow motion
    #: (while it glides to the next placement and while it dwells there)
    mode: str = "settled"
    record_every: int = 5  # physics steps between recorded postures in "recording" mode
    max_tries_per_posture: int = 40  # a job gives up after this many walk steps per candidate of its quota
    verify: bool = True  # keep only candidates that hold when replayed open loop (`replay.replay_grasp`)
    verify_hold_seconds: float = VERIFY_HOLD_SECONDS  # s per gravity direction of the verifying hold test
    #: the verifier's judging protocol, by name (`protocols.PROTOCOLS`): ours (`protocols.DEFAULT_PROTOCOL`, the
    #: hold test of `verify_hold_seconds`), or DexGraspBench's (its physics profile and external-force test)
    verify_protocol: str = DEFAULT_PROTOCOL
    #: how the replay's pregrasp and squeeze are made (`replay.GRASP_STAGES`): "contacts" (the touching
    #: segments 2 cm out along the object's normals, then 1 cm in) or "open" (the open hand 2 cm back, the
    #: flexion joints squeezed by `squeeze` rad)
    stages: str = VERIFY_STAGES
    squeeze: float = SQUEEZE  # rad, as the controller presses (the "open" stages' squeeze)
    #: with verification, draw at most this many candidates per requested posture (GenerationError beyond)
    max_candidates_per_posture: int = 50
    #: the family of starting postures (starts.DESIGN_FAMILIES); None (the default): with verification every
    #: grasp type, each start one that holds ("grasp_types"), without it the paper's five-fingertip grasps
    #: ("five_fingertip"): verify=False is the paper's procedure, its designs included
    designs: str | None = None
    #: the hand model the postures are generated on (`hand_models.HAND_MODELS`, or an MJCF file's path)
    hand: str = SHADOW_HAND.name

    def __post_init__(self) -> None:
        if self.designs is None:
            object.__setattr__(self, "designs", "grasp_types" if self.verify else "five_fingertip")
        check_choice(self.mode, MODES, "GeneratorParams.mode")
        object.__setattr__(self, "verify_protocol", current_name("protocol", self.verify_protocol))  # before 0.2
        object.__setattr__(self, "hand", current_name("hand", self.hand))
        check_choice(self.verify_protocol, PROTOCOL_NAMES, "GeneratorParams.verify_protocol")
        check_choice(self.stages, GRASP_STAGES, "GeneratorParams.stages")
        check_choice(self.designs, DESIGN_FAMILIES, "GeneratorParams.designs")
        if not isinstance(self.hand, str) or not self.hand:
            raise InvalidInput(f"GeneratorParams.hand must be a hand model's name or an MJCF file's path, "
                               f"got {self.hand!r}")
        for name, value in asdict(self).items():
            if name in ("verify", "mode", "designs", "verify_protocol", "stages", "hand"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
                raise InvalidInput(f"GeneratorParams.{name} must be a finite number >= 0, got {value!r}")
        for name in ("job_size", "move_steps", "settle_steps", "max_tries_per_posture", "record_every",
                     "max_candidates_per_posture"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise InvalidInput(f"GeneratorParams.{name} must be a positive integer, got {getattr(self, name)!r}")
        if self.verify_hold_seconds <= 0:  # 0 marked every candidate verified without a hold test
            raise InvalidInput(f"GeneratorParams.verify_hold_seconds must be > 0 s, got {self.verify_hold_seconds!r}")

    @property
    def grasp_stages(self) -> GraspStages:
        """The replay's stages (`stages`), the open hand's squeeze by `squeeze` rad."""
        return replace(GRASP_STAGES[self.stages], squeeze_angle=self.squeeze)


#: The generator settings of each preset, the paper's procedure: every candidate with its five fingertips
#: on the object is kept (the paper describes no verification). The quick preset takes one settled posture
#: per walk step (small and fast, for tests and demos); the paper preset records along the hand's motion
#: as the paper did, at every physics step: of the modes measured, the one whose maps come closest to the
#: paper's inter-node distances (docs/studies/data_character.md).
PRESET_PARAMS: dict[str, GeneratorParams] = {
    "quick": GeneratorParams(verify=False),
    "paper": GeneratorParams(mode="recording", record_every=1, verify=False),
}


class SpringRig:
    """A scene with springs on a starting posture's contact segments and compliant finger servos.

    A distal contact segment is pulled by its fingertip site, any other contact segment (the index
    finger's middle segment in a lateral grasp) at its point nearest the object; the segments that
    must touch for a candidate are the contact segments (the five distal ones for the paper's kind).

    It is public as the generator's profiling hook: a profiler (`studies.trial_profile`) times its phases by
    wrapping `simulate` (every physics step of a walk or a settle), `move_to` (the walk to a pose), `settle` and
    `accepted_posture` (the candidate test) on the class.
    """

    def __init__(self, obj: GraspObject, params: GeneratorParams, contacts: tuple[str, ...] = DISTAL_SEGMENTS,
                 hand: str = SHADOW_HAND.name):
        self.scene = Scene(obj, hand=hand)
        self.params = params
        model, hand_model = self.scene.model, self.scene.hand
        fingers = np.delete(self.scene.actuator_ids, hand_model.wrist_rows)  # every servo but the wrist's
        model.actuator_gainprm[fingers, 0] *= params.servo_stiffness_scale
        model.actuator_biasprm[fingers, 1] *= params.servo_stiffness_scale
        tips = [hand_model.fingertip_sites[DISTAL_SEGMENTS.index(c)] for c in contacts if c in DISTAL_SEGMENTS]
        self.tip_sites = [model.site(s).id for s in tips]
        self.tip_bodies = [int(model.site_bodyid[s]) for s in self.tip_sites]
        segment_of = segment_of_geoms(model, hand_model)
        self.segment_geoms = [[int(g) for g in np.flatnonzero(segment_of == i)] for i in range(len(SEGMENTS))]
        geom_of = {c: self.segment_geoms[SEGMENTS.index(c)][0] for c in contacts}  # a finger segment has one
        self.side_geoms = [geom_of[c] for c in contacts if c not in DISTAL_SEGMENTS]
        self.contact_geoms = [geom_of[c] for c in contacts]
        self.finger_dofs = self.scene.hand_dofs[2:]
        self.limits = hand_model.limits()
        self._torque = np.zeros(3)
        self._fromto = np.zeros(6)

    def apply_springs(self) -> None:
        scene, data = self.scene, self.scene.data
        data.qfrc_applied[:] = 0.0
        pieces = [data.site_xpos[self.tip_sites]]  # the object sits at the world origin, unrotated
        bodies = list(self.tip_bodies)
        for geom in self.side_geoms:  # the segment's point nearest the object (of its nearest convex part)
            nearest = min(scene.object_geoms, key=lambda g: mujoco.mj_geomDistance(
                scene.model, data, geom, g, 0.1, self._fromto))
            mujoco.mj_geomDistance(scene.model, data, geom, nearest, 0.1, self._fromto)
            pieces.append(self._fromto[None, :3].copy())
            bodies.append(int(scene.model.geom_bodyid[geom]))
        points = np.concatenate(pieces)
        pull = self.params.spring_stiffness * (scene.object.closest_point(points) - points)
        norm = np.linalg.norm(pull, axis=1, keepdims=True)
        pull *= np.minimum(1.0, self.params.spring_max_force / np.maximum(norm, 1e-12))
        for force, point, body in zip(pull, points, bodies):
            mujoco.mj_applyFT(scene.model, data, force, self._torque, point, body, data.qfrc_applied)

    def simulate(self, steps: int, on_step: Callable[[], None] | None = None) -> None:
        for _ in range(steps):
            self.apply_springs()
            mujoco.mj_step(self.scene.model, self.scene.data)
            if on_step is not None:
                on_step()

    def move_to(self, pos: np.ndarray, quat: np.ndarray, on_step: Callable[[], None] | None = None) -> None:
        """Glide the hand so the palm reaches a pose in `move_steps` physics steps, springs on;
        `on_step()` is called after every physics step."""
        data, mount = self.scene.data, self.scene.mount_id
        start_pos, start_quat = data.mocap_pos[mount].copy(), data.mocap_quat[mount].copy()
        end_pos, end_quat = self.scene.mount_pose_for(pos, quat)
        turn = to_rotation(start_quat)
        delta = (turn.inv() * to_rotation(end_quat)).as_rotvec()
        steps = self.params.move_steps
        for k in range(1, steps + 1):
            f = k / steps
            data.mocap_pos[mount] = start_pos + f * (end_pos - start_pos)
            data.mocap_quat[mount] = to_quat(turn * Rotation.from_rotvec(f * delta))
            self.simulate(1, on_step)

    def settle(self, on_step: Callable[[], None] | None = None) -> bool:
        """Step until the fingers rest (True) or `settle_steps` run out (False)."""
        for _ in range(0, self.params.settle_steps, 5):
            self.simulate(5, on_step)
            if np.max(np.abs(self.scene.data.qvel[self.finger_dofs])) < self.params.rest_speed:
                return True
        return False

    def accepted_posture(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(posture, contacts) when the current state is an acceptable grasp, else None."""
        scene, model, data = self.scene, self.scene.model, self.scene.data
        posture = scene.posture()
        if np.any(posture < self.limits[:, 0] - 1e-3) or np.any(posture > self.limits[:, 1] + 1e-3):
            return None
        clipped = np.clip(posture, self.limits[:, 0], self.limits[:, 1])
        saved = data.qpos.copy()
        data.qpos[scene.finger_qpos] = scene.hand.to_model(clipped)  # judge exactly what is stored
        mujoco.mj_kinematics(model, data)
        gap = scene.distance_to_object
        try:
            if any(gap(g) > CONTACT_GAP for g in self.contact_geoms):
                return None
            distances = [min(gap(g) for g in geoms) for geoms in self.segment_geoms]
            if min(distances) < -MAX_PENETRATION:
                return None
            return clipped, np.array(distances) <= CONTACT_GAP
        finally:
            data.qpos[:] = saved
            mujoco.mj_kinematics(model, data)

    def reset_to(self, start: StartingPosture) -> None:
        scene = self.scene
        mujoco.mj_resetData(scene.model, scene.data)
        scene.set_hand_pose(start.hand_pos, start.hand_quat)
        scene.set_posture(start.posture)


@dataclass(frozen=True)
class _Job:
    start_index: int
    chunk: int
    quota: int  # candidates to find


def _run_job(obj: GraspObject, start: StartingPosture, job: _Job, seed: int, params: GeneratorParams,
             hand: str = SHADOW_HAND.name) -> dict[str, np.ndarray]:
    """Walk around one starting posture until `job.quota` candidates are found (or the walk gives up
    after `max_tries_per_posture` steps per candidate: `exhausted`); keep the verified ones."""
    rng = np.random.default_rng([seed, job.start_index, job.chunk])
    rig = SpringRig(obj, params, start.contacts, hand)
    verifier = verifier_of(obj, params, hand) if params.verify else None
    rig.reset_to(start)
    rig.scene.set_target(start.posture)
    base = to_rotation(start.hand_quat)
    offset, turn = np.zeros(3), np.zeros(3)
    postures, poses, contacts, epsilons, displacements = [], [], [], [], []
    tries, walks, misses, candidates, faults, steps = 0, 0, 0, 0, 0, 0
    first_fault = ""  # what the first failed simulation reported
    exhausted = False
    recording = params.mode == "recording"
    frames: list[tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]] = []

    def record() -> None:
        """Recording mode: test the posture every `record_every` physics steps along the motion."""
        nonlocal tries, steps
        steps += 1
        if steps % params.record_every == 0 and candidates + len(frames) < job.quota:
            tries += 1
            result = rig.accepted_posture()
            if result is not None:
                frames.append((result, rig.scene.hand_pose()))

    while candidates < job.quota:
        walks += 1
        if not recording:
            tries += 1
        if walks > params.max_tries_per_posture * job.quota:
            exhausted = True  # the springs rarely make the design's contacts here: this start gives up
            break
        offset = _bounded(offset + rng.normal(0.0, params.step_size, 3), params.walk_radius)
        turn = _bounded(turn + rng.normal(0.0, params.step_angle, 3), params.walk_angle)
        frames.clear()
        rig.move_to(start.hand_pos + offset, to_quat(Rotation.from_rotvec(turn) * base), record if recording else None)
        settled = rig.settle(record if recording else None)
        if not rig.scene.healthy():  # the physics failed: nothing of this walk can be trusted
            faults += 1
            first_fault = first_fault or "; ".join(rig.scene.faults())
            rig.reset_to(start)
            offset, turn, misses = np.zeros(3), np.zeros(3), 0
            continue
        if not recording:
            result = rig.accepted_posture() if settled else None
            if result is not None:
                frames.append((result, rig.scene.hand_pose()))
        if not frames:
            misses += 1
            if misses >= 5:  # lost the grasp: back to the starting posture
                rig.reset_to(start)
                offset, turn, misses = np.zeros(3), np.zeros(3), 0
            continue
        misses = 0
        for (posture, touching), (pos, quat) in frames:
            candidates += 1
            try:
                judgement = verifier(posture, pos, quat) if verifier is not None else None
            except SimulationError as error:  # the replay's physics failed: not a verified grasp
                faults += 1
                first_fault = first_fault or str(error)
                continue
            if judgement is not None and not judgement.hold:
                continue
            postures.append(posture)
            contacts.append(touching)
            poses.append(np.concatenate([pos, quat]))
            epsilons.append(np.nan if judgement is None else judgement.epsilon)
            displacements.append(np.nan if judgement is None else judgement.displacement)
    return {"postures": np.array(postures).reshape(-1, len(FINGER_JOINTS)), "hand_poses": np.array(poses).reshape(-1, 7),
            "contacts": np.array(contacts).reshape(-1, len(SEGMENTS)),
            "epsilon": np.array(epsilons), "hold_displacement": np.array(displacements),
            "tries": np.array(tries), "candidates": np.array(candidates), "faults": np.array(faults),
            "first_fault": np.array(first_fault), "exhausted": np.array(exhausted)}


#: candidates the generator walks around a grasp-types start before it is kept (`holds_with_neighbours`)
NEIGHBOURS = 6


def holds_with_neighbours(obj: GraspObject, start: StartingPosture) -> bool:
    """Whether a start holds its object under the verifier, the generator's walk around it finds its first
    `NEIGHBOURS` candidates without giving up, and at least one of them holds too (a start can hold on a
    knife-edge whose neighbours all drop, or be one the springs rarely settle near: either would give the
    generator nothing). The check of the generator's own search for starting postures
    (`search_starting_postures`).

    Args:
        obj: the object.
        start: the starting posture (palm pose in the object frame, m).

    Returns:
        True when both hold.
    """
    if not verified(obj, start):
        return False
    walked = _run_job(obj, start, _Job(0, 0, NEIGHBOURS), seed=0, params=GeneratorParams(designs="grasp_types"))
    return len(walked["postures"]) > 0 and not bool(walked["exhausted"])


def search_starting_postures(obj: str | GraspObject, family: str = "five_fingertip", *, perturbation: float = 0.0,
                             progress: bool | None = None, workers: int | None = None) -> list[StartingPosture]:
    """Search an object's starting postures as the generator uses them: `starts.find_starting_postures`, a
    grasp-types start kept only when it and its neighbours hold (`holds_with_neighbours`). What
    `starting_postures` runs for an object that ships none, and what `scripts/find_starting_postures.py` ships.

    Args:
        obj: an object or its name.
        family: a design family (`starts.DESIGN_FAMILIES`).
        perturbation: a relative change of every design's palm position (`starts.find_starting_postures`).
        progress: show the bar (None: as `progress.show_progress` says).
        workers: worker processes (None: `workers.default_workers()` in a main process, one inside a worker).

    Returns:
        The starting postures found, in the order of `designs_for(obj, family)`.
    """
    obj = get_object(obj)
    return find_starting_postures(obj, family, check=partial(holds_with_neighbours, obj), perturbation=perturbation,
                                  progress=progress, workers=workers)


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
    """The starting postures of an object in a design family (`starts.DESIGN_FAMILIES`): shipped for the
    paper's objects and the object family; else searched once (`search_starting_postures`: seconds to half a
    minute per object, with a progress bar) and stored in `cache_directory()`, under a key of the object's
    shape (`starts.geometry_params`: a mesh's digest, not its name) and the library's code, so that a second process,
    or the same mesh under another name, reads them instead of searching again.

    Args:
        obj: an object or its name.
        family: 'five_fingertip' (the paper's kind) or 'grasp_types' (power, precision, tripod, lateral).

    Returns:
        The valid starting postures, in the order of `designs_for(obj, family)`.
    """
    return list(_starting_postures(get_object(obj), check_choice(family, DESIGN_FAMILIES, "family")))


def starts_cache_path(obj: GraspObject, family: str) -> Path:
    """Where `starting_postures` keeps an object's searched starts: a file of its shape (`starts.geometry_params`: a
    mesh's digest, not its name, mass or friction) and the library's code, so the same mesh under another name, or
    given as a file and as a `Trimesh`, reads the one search.

    Args:
        obj: the object.
        family: a design family.

    Returns:
        The file's path in `cache_directory()`.
    """
    shape = geometry_params(obj.params())
    return cache_directory() / "starting_postures" / f"{obj.shape}_{family}_{result_key(shape, family)}.npz"


@lru_cache(maxsize=64)
def _starting_postures(obj: GraspObject, family: str) -> tuple[StartingPosture, ...]:
    shipped = shipped_starting_postures(obj, family)
    if shipped is not None:
        return tuple(shipped)
    cached = starts_cache_path(obj, family)
    if cached.exists():
        try:
            arrays, meta = load_npz(cached, "starting_postures", {})
            (key, entry), = meta["objects"].items()
            return tuple(read_entry(arrays, key, entry, obj, family))
        except (ValueError, KeyError, OSError) as error:  # a damaged file is searched again and replaced
            warnings.warn(f"the stored starting postures {cached} cannot be read ({error}): searching again",
                          stacklevel=3)
    warnings.warn(f"{obj.name} has no shipped starting postures ({family}): searching them now (seconds to half "
                  f"a minute); they are kept in {cached.parent} for the next process", stacklevel=3)
    found = search_starting_postures(obj, family)
    try:
        save_starting_postures(cached, {(obj, family): found})
    except OSError as error:  # a read-only home: the search is only lost for the next process
        warnings.warn(f"the starting postures could not be stored in {cached.parent} ({error}); set "
                      "GRASPMANIFOLD_CACHE to a writable folder to keep them", stacklevel=3)
    return tuple(found)


def _size_text(obj: GraspObject, hand: HandModel) -> str:
    """The object's size against the hand's, in words."""
    return (f"it is {100 * obj.narrowest_width:.1f} cm across at its narrowest and {200 * obj.half_extents.max():.1f} "
            f"cm at its longest; the {hand.name!r} hand spans {100 * hand.span:.1f} cm (thumb tip to the farthest "
            "fingertip, open)")


def _check_graspable(obj: GraspObject, hand: HandModel) -> None:
    """Refuse an object wider at its narrowest than the hand's span before any search: no design can close
    around it."""
    if obj.narrowest_width > hand.span:
        raise GenerationError(f"{obj.name} cannot be grasped by this hand: {_size_text(obj, hand)}, so no grasp "
                              "can close around it (use an object that is narrower somewhere than the hand spans)")


def verifier_of(obj: GraspObject, params: GeneratorParams, hand: str = SHADOW_HAND.name) -> GraspVerifier:
    """The generator's verifier of a candidate: its open-loop replay (`replay.replay_grasp`) with the
    stages, the protocol and the hold of `params`.

    Args:
        obj: the object.
        params: the generator's parameters (`grasp_stages`, `verify_hold_seconds`, `verify_protocol`).
        hand: the hand model's name.

    Returns:
        The `GraspVerifier`.
    """
    return GraspVerifier(obj, params.grasp_stages, params.verify_hold_seconds, hand, params.verify_protocol)


def _bounded(v: np.ndarray, radius: float) -> np.ndarray:
    norm = np.linalg.norm(v)
    return v if norm <= radius else v * (radius / norm)


def _allocate(n: int, capacity: list[int | None], order: list[int] | None = None) -> list[int]:
    """Split n postures over the starting postures as evenly as their capacity allows: a start with a
    capacity (it can give no more than that) gets at most that, the others share the rest evenly, one more
    each where it does not divide, taken in `order` (None: the starts' order)."""
    allocation = [0] * len(capacity)
    open_starts, remaining = list(range(len(capacity))), n
    while open_starts:
        fair = remaining / len(open_starts)
        limited = {s: most for s in open_starts if (most := capacity[s]) is not None and most <= fair}
        if not limited:
            break
        for s, most in limited.items():
            allocation[s] = int(most)
            remaining -= allocation[s]
            open_starts.remove(s)
    if open_starts:
        share, extra = divmod(remaining, len(open_starts))
        ranked = sorted(open_starts, key=(order or list(range(len(capacity)))).index)
        for k, s in enumerate(ranked):
            allocation[s] = share + (1 if k < extra else 0)
    return allocation


def _round_robin(kinds: Sequence[str]) -> list[int]:
    """Indices in the order that takes one of each kind in turn (first-seen kind first): the first of each kind,
    then the second of each, ..."""
    rank = {kind: k for k, kind in enumerate(dict.fromkeys(kinds))}
    seen: dict[str, int] = {}
    place = []
    for i, kind in enumerate(kinds):
        seen[kind] = seen.get(kind, -1) + 1
        place.append((seen[kind], rank[kind], i))
    return [i for *_, i in sorted(place)]


def _chunks(start: int, first_chunk: int, candidates: int, job_size: int) -> Iterator[_Job]:
    """Jobs of at most `job_size` candidates for one start, numbered on from `first_chunk` (made as they
    are taken: a wave of a billion candidates is not held in memory)."""
    return (_Job(start, first_chunk + k, min(job_size, candidates - done))
            for k, done in enumerate(range(0, candidates, job_size)))


def _job_file(directory: Path, job: _Job) -> Path:
    return directory / f"job_{job.start_index:03d}_{job.chunk:04d}.npz"


def _job_worker(args: tuple) -> tuple[_Job, dict[str, np.ndarray]]:
    obj, start, job, seed, params, hand = args
    return job, _run_job(obj, start, job, seed, params, hand)


def _read_job(path: Path) -> tuple[tuple[_Job | None, dict[str, np.ndarray]], dict]:
    """A stored job's result, with the job it says it is (None when its metadata names none)."""
    arrays, meta = load_npz(path, "generator_job", {"postures": (None, len(FINGER_JOINTS))})
    job = meta.get("job")
    return (_Job(**job) if isinstance(job, dict) and set(job) == set(_Job.__dataclass_fields__) else None, arrays), meta


def _hand_into_params(kwargs: dict[str, Any], hand: object) -> None:
    """`generate_postures(hand=...)` of 0.1: the hand is `GeneratorParams.hand` now."""
    params = kwargs.get("params") or GeneratorParams()
    if params.hand not in (GeneratorParams().hand, hand):
        raise InvalidInput(f"hand={hand!r} (the 0.1 keyword) and params.hand={params.hand!r} disagree: give the hand "
                           "once, as GeneratorParams(hand=...)")
    kwargs["params"] = replace(params, hand=hand)


@moved_keyword("hand", "params=GeneratorParams(hand=...)", _hand_into_params)
def generate_postures(obj: str | GraspObject, n: int, seed: int = 0, workers: int | Executor | None = None, *,
                      params: GeneratorParams | None = None, checkpoint_dir: str | os.PathLike | None = None,
                      progress: bool | None = None, starts: Sequence[StartingPosture] | None = None) -> PostureSet:
    """Generate n grasp postures for an object with the spring generator.

    Without verification (`params.verify=False`, the paper's procedure) the n postures are the first
    n candidates. With it (the default) candidates are drawn in waves until n of them hold the
    object: each wave asks every starting posture that is short of its share for as many candidates
    as its yield so far says it needs; a start that used up its part of the budget
    (`max_candidates_per_posture` times n over the starts) or whose springs rarely make its contacts
    gives up, as does one none of whose first `max_candidates_per_posture` candidates held, and the
    others share its part. The shares are as even as the starts allow.

    Args:
        obj: an object or its name.
        n: postures to return (>= 1).
        seed: the random seed; the same seed gives the same set, whatever the number of workers or
            the executor the jobs run on.
        workers: worker processes (None: `workers.default_workers()`, one for fewer than
            `GENERATE_PER_WORKER` postures), or an executor that runs the jobs elsewhere (a Dask cluster's,
            `workers.cluster_executor`).
        params: generator settings (`GeneratorParams`); `params.designs` picks the starting postures, `params.hand`
            the hand model (`hand_models.HAND_MODELS`, or an MJCF path; the postures record it, `metadata["hand"]`).
        checkpoint_dir: every finished job is saved there, and a rerun with the same arguments picks
            them up.
        progress: show a progress bar of the postures found (None: as `progress.show_progress` says, on by
            default).
        starts: your own starting postures (`StartingPosture`s, palm poses in the object's frame; checked by
            `starts.check_starting_postures`), used instead of those of `params.designs`.

    Returns:
        A `PostureSet` of n postures; its metadata says how many candidates were drawn and how many
        held (`candidates`, `verified_ratio`, and per starting posture `candidates_by_start`,
        `verified_by_start`, `kept_by_start`).

    Raises:
        GenerationError: the object is wider at its narrowest than the hand spans (`HandModel.span`), no
            starting posture was found (the message gives the object's size against the hand's and the designs
            tried), or with verification fewer than n candidates held within the budget (the message gives the
            yield per starting posture).
        InvalidInput: a start of `starts` that is not a valid grasp of the object (the message names it).
    """
    seed = check_int(seed, "seed", low=0)
    obj = get_object(obj)
    n = check_int(n, "n", high=MAX_POSTURES)
    workers, executor = split_workers(workers)
    workers = workers_for(workers, n, GENERATE_PER_WORKER)
    params = params or GeneratorParams()
    model = hand_model(params.hand)  # the hand refused here when unknown
    _check_graspable(obj, model)
    own = starts is not None
    starts = _starts_on(obj, params, model, starts)
    key = result_key({"object": obj.params(), "seed": seed, "n": int(n), "params": asdict(params),
                      "starts": [s.name for s in starts], "hand": model.digest},
                     *([np.concatenate([s.hand_pos, s.hand_quat, s.posture]) for s in starts] if own else []))
    waves = _Waves(obj, starts, n, seed, params, model.name)
    with progress_bar(n, f"generate {obj.name}", "postures", enabled=progress) as report:
        waves.run(PartStore(checkpoint_dir, key, _read_job) if checkpoint_dir is not None else None, workers,
                  executor, report)
    return waves.posture_set()


def _starts_on(obj: GraspObject, params: GeneratorParams, model: HandModel,
               starts: Sequence[StartingPosture] | None) -> list[StartingPosture]:
    """One's own starts checked, or those of `params.designs` found; either in the hand's ranges."""
    family = params.designs
    assert family is not None  # GeneratorParams names the default family
    starts = check_starting_postures(starts, obj) if starts is not None else starting_postures(obj, family)
    if not starts:
        tried = ", ".join(design.name for design in designs_for(obj, family))
        raise GenerationError(f"no starting posture could be found for {obj.name}: {_size_text(obj, model)}; none of "
                              f"the {params.designs!r} designs ({tried}) "
                              "closes the hand on it with its contacts touching (an object too small for the "
                              "fingertips to meet on it, or of a shape none of them fits)")
    # the designs' postures (searched on our hand) in this hand's ranges
    return [replace(s, posture=np.clip(s.posture, *model.limits().T)) for s in starts]


class _Waves:
    """The generator's scheduler: waves of jobs over the starting postures until n candidates held (or the budget
    is spent), then the posture set built from what the jobs found (`posture_set`).

    Each wave asks every start short of its share (`_allocate`) for as many candidates as its yield so far says it
    needs; a start past its part of the budget, or none of whose first `max_candidates_per_posture` candidates
    held, gives up, and the others share its part.
    """

    def __init__(self, obj: GraspObject, starts: list[StartingPosture], n: int, seed: int, params: GeneratorParams,
                 hand: str):
        self.obj, self.starts, self.n, self.seed, self.params, self.hand = obj, starts, n, seed, params, hand
        self.results: list[list[dict[str, np.ndarray]]] = [[] for _ in starts]  # per start, in chunk order
        self.given_up = [False] * len(starts)
        self.budget = params.max_candidates_per_posture * n if params.verify else None
        self.spread = _round_robin([s.grasp_type for s in starts])  # fewer postures than starts: every type first

    def held(self, s: int) -> int:
        return sum(len(r["postures"]) for r in self.results[s])

    def drawn(self, s: int) -> int:
        return sum(int(r["candidates"]) for r in self.results[s])

    def allocation(self) -> list[int]:
        return _allocate(self.n, [self.held(s) if self.given_up[s] else None for s in range(len(self.starts))],
                         self.spread)

    def plan(self) -> list[tuple[int, int, int]] | None:
        """The next wave: (start, its first chunk in this wave, candidates to draw); [] when some start gave up
        now (the shares change), None when nothing is left to draw."""
        allocation = self.allocation()
        short = [s for s in range(len(self.starts)) if not self.given_up[s] and self.held(s) < allocation[s]]
        if not short:
            return None
        params, budget = self.params, self.budget
        for s in short:  # a start past its part of the budget gives up, and one none of whose first
            # max_candidates_per_posture candidates held (by the rule of three its yield is then below
            # 3 / max_candidates_per_posture, 6 % by default, with 95 % confidence)
            if budget is not None and (self.drawn(s) >= budget / len(self.starts)
                                       or (self.held(s) == 0 and self.drawn(s) >= params.max_candidates_per_posture)):
                self.given_up[s] = True
        if any(self.given_up[s] for s in short):
            return None if all(self.given_up) else []
        plan = []
        for s in short:
            wanted = allocation[s] - self.held(s)
            if params.verify and budget is not None and self.results[s]:  # as many as the yield so far says,
                # and a tenth more, but at most as many again as drawn so far (a start whose first few candidates
                # all dropped is not sent for tenfold that many at once)
                rate = (self.held(s) + 1) / (self.drawn(s) + 2)
                wanted = min(int(np.ceil(1.1 * wanted / rate)), max(wanted, self.drawn(s)),
                             int(budget / len(self.starts)) - self.drawn(s))
            plan.append((s, len(self.results[s]), max(1, wanted)))
        return plan

    def run(self, store: PartStore | None, workers: int, executor: Executor | None, report: Any) -> None:
        """Every wave, its jobs on `workers` processes or `executor`, each finished job kept in `store` (a rerun
        takes it from there; a job's file must be where its name says: a renamed file is not taken for another)."""
        saved: dict[tuple[int, int], dict[str, np.ndarray]] = {}
        if store is not None:
            stored = store.load(JOB_PARTS, lambda path, part, _: part[0] is not None
                                and path == _job_file(store.directory, part[0])).values()
            saved = {(job.start_index, job.chunk): arrays for job, arrays in stored}
        while (plan := self.plan()) is not None:
            if plan:
                self.run_wave(plan, saved, store, workers, executor, report)

    def run_wave(self, plan: list[tuple[int, int, int]], saved: dict, store: PartStore | None, workers: int,
                 executor: Executor | None, report: Any) -> None:
        """One wave's jobs (those saved by an earlier run taken as they are), their results kept per start."""
        job_size = self.params.job_size

        def jobs() -> Iterator[_Job]:
            return itertools.chain.from_iterable(_chunks(*step, job_size) for step in plan)

        pending = ((self.obj, self.starts[job.start_index], job, self.seed, self.params, self.hand)
                   for job in jobs() if (job.start_index, job.chunk) not in saved)
        finished = {key: result for key, result in saved.items() if any(
            key[0] == s and first <= key[1] < first + -(-wanted // job_size) for s, first, wanted in plan)}

        def keep(_: int, done: tuple[_Job, dict[str, np.ndarray]]) -> None:
            job, result = done
            finished[(job.start_index, job.chunk)] = result
            if store is not None:  # written here, where a rerun reads it, not on a cluster worker's disk
                store.save(_job_file(store.directory, job).name,
                           lambda path, meta: save_npz(path, "generator_job", result, meta), job=asdict(job))
            report.update(min(len(result["postures"]), self.n - report.n))  # a job may find more than is kept

        report.update(min(sum(len(r["postures"]) for r in finished.values()), self.n - report.n))
        parallel_map(_job_worker, pending, workers, keep, executor)
        for job in jobs():
            result = finished[(job.start_index, job.chunk)]
            self.results[job.start_index].append(result)
            if bool(result.get("exhausted", False)):
                self.given_up[job.start_index] = True

    def posture_set(self) -> PostureSet:
        """The first `kept` postures of each start, start after start, with what made them; GenerationError when
        fewer than n held (the message says why: the simulation's faults, or the yield per start)."""
        obj, starts, n, params = self.obj, self.starts, self.n, self.params
        allocation, indices = self.allocation(), range(len(starts))
        kept = [min(self.held(s), allocation[s]) for s in indices]
        candidates = sum(self.drawn(s) for s in indices)
        held = sum(self.held(s) for s in indices)
        self.check_enough(sum(kept), candidates, held)
        present = [s for s in indices if self.results[s]]

        def take(key: str) -> np.ndarray:
            """Each start's first `kept` rows of a result array, start after start."""
            return np.concatenate([np.concatenate([r[key] for r in self.results[s]])[: kept[s]] for s in present])

        tries = sum(int(r["tries"]) for rs in self.results for r in rs)
        faults = sum(int(r.get("faults", 0)) for rs in self.results for r in rs)
        return PostureSet(
            postures=take("postures"), hand_poses=take("hand_poses"),
            start_ids=np.concatenate([np.full(kept[s], s) for s in present]).astype(np.int64),
            contacts=take("contacts").astype(bool), epsilon=take("epsilon"),
            hold_displacement=take("hold_displacement"), start_names=tuple(f"{obj.name}:{s.name}" for s in starts),
            metadata={"object": obj.params(), "seed": self.seed, "generator": asdict(params), "n": int(n),
                      "acceptance_ratio": candidates / tries, "simulation_faults": faults, "verified": params.verify,
                      "candidates": int(candidates), "verified_ratio": held / candidates,
                      "verified_by_start": {starts[s].name: self.held(s) / self.drawn(s) for s in present
                                            if self.drawn(s)},
                      "candidates_by_start": {starts[s].name: self.drawn(s) for s in present},
                      "kept_by_start": {starts[s].name: kept[s] for s in present},
                      "grasp_types": {start.name: start.grasp_type for start in starts},
                      "library_version": library_version(), "hand": self.hand,
                      "starting_postures": {s.name: {"hand_pos": s.hand_pos.tolist(),
                                                     "hand_quat": s.hand_quat.tolist(), "posture": s.posture.tolist(),
                                                     "contacts": list(s.contacts), "grasp_type": s.grasp_type}
                                            for s in starts}},
        )

    def check_enough(self, kept: int, candidates: int, held: int) -> None:
        """GenerationError when fewer than n postures were kept."""
        if kept >= self.n:
            return
        obj, params, n = self.obj, self.params, self.n
        tries = sum(int(r["tries"]) for rs in self.results for r in rs)
        faults = sum(int(r.get("faults", 0)) for rs in self.results for r in rs)
        if faults:
            first = next(str(r["first_fault"]) for rs in self.results for r in rs if str(r.get("first_fault", "")))
            raise GenerationError(
                f"only {kept} of the {n} {obj.name} postures asked for were found, and the simulation failed "
                f"{faults} times in {tries} walk steps (first: {first}): check GeneratorParams (spring_stiffness "
                f"{params.spring_stiffness:g} N/m, spring_max_force {params.spring_max_force:g} N, "
                f"servo_stiffness_scale {params.servo_stiffness_scale:g}) and the object's mass and size")
        by_start = ", ".join(f"{start.name} {self.held(s)} of {self.drawn(s)}" + (" (gave up)" if self.given_up[s]
                                                                                   else "")
                             for s, start in enumerate(self.starts))
        raise GenerationError(
            f"only {kept} of the {n} {obj.name} postures asked for were found: of {candidates} candidates "
            f"{held} held (yield {held / max(1, candidates):.1%}; by starting posture: {by_start}). Ask for fewer "
            "postures, raise GeneratorParams.max_candidates_per_posture"
            + (", or keep every candidate (verify=False)" if params.verify else ", or max_tries_per_posture"))


def _verify_chunk(task: tuple[GraspObject, GeneratorParams, np.ndarray, np.ndarray, str]) -> np.ndarray:
    """(hold, epsilon, displacement) rows of the verifier for a chunk of postures (m, 22) and palm poses (m, 7) on
    a hand."""
    obj, params, postures, poses, hand = task
    verifier = verifier_of(obj, params, hand)
    rows = []
    for posture, pose in zip(postures, poses):
        try:
            judgement = verifier(posture, pose[:3], pose[3:])
            rows.append((float(judgement.hold), judgement.epsilon, judgement.displacement))
        except SimulationError:  # the replay's physics failed: not a verified grasp
            rows.append((0.0, np.nan, np.nan))
    return np.array(rows).reshape(-1, 3)


def verify_postures(postures: PostureSet, obj: str | GraspObject, workers: int | Executor | None = None, *,
                    params: GeneratorParams | None = None, progress: bool | None = None) -> PostureSet:
    """Keep the postures of a set that hold the object, judged as the generator verifies a candidate.

    Each posture is replayed open loop at its palm pose as the generator verifies a candidate
    (`replay.replay_grasp` with the stages, protocol and hold of `params`). `generate_postures(obj, n, params=GeneratorParams(verify=False))` followed
    by this keeps exactly the candidates that the generator with verification keeps among its first
    n (the walk does not depend on the verification).

    Args:
        postures: the set to verify (its palm poses are in the object frame of `obj`).
        obj: the object the set was generated on, or its name.
        workers: worker processes (None: `workers.default_workers()`, one for fewer than `VERIFY_PER_WORKER`), or
            an executor that runs the replays elsewhere (a Dask cluster: `workers.cluster_executor`), with the same
            result.
        params: the verification's settings (`verify_protocol`, `stages`, `verify_hold_seconds`, `squeeze`); the
            defaults otherwise.
        progress: show a progress bar (None: as `progress.show_progress` says, on by default).

    Returns:
        The postures that held, with their epsilon and largest hold displacement (m); the metadata
        counts the candidates (`candidates`, `verified_ratio`, `verified_by_start`).
    """
    obj = get_object(obj)
    params = params or GeneratorParams()
    workers, executor = split_workers(workers)
    workers = workers_for(workers, len(postures), VERIFY_PER_WORKER)
    chunks = np.array_split(np.arange(len(postures)), max(1, min(len(postures), 8 * workers)))
    hand = postures.hand
    tasks = [(obj, params, postures.postures[c], postures.hand_poses[c], hand) for c in chunks if len(c)]
    with progress_bar(len(postures), f"verify {obj.name}", "postures", enabled=progress) as report:
        rows = np.concatenate(parallel_map(_verify_chunk, tasks, workers, lambda _, r: report.update(len(r)), executor)
                              or [np.zeros((0, 3))])
    held = rows[:, 0] > 0
    kept = postures.subset(held)
    if len(held) and held.mean() < FEW_HOLD:
        warnings.warn(f"only {int(held.sum())} of {len(held)} {obj.name} candidates hold ({held.mean():.0%}): too few to "
                      "map a grasp manifold on; more candidates, another mode or design family "
                      "(GeneratorParams.mode, .designs), or the paper's procedure (every candidate) give more",
                      stacklevel=2)
    names = [name.split(":", 1)[-1] for name in postures.start_names]
    by_start = {names[i]: float(held[postures.start_ids == i].mean()) for i in np.unique(postures.start_ids)}
    made = {**postures.metadata.get("generator", {}), "verify": True, "verify_protocol": params.verify_protocol,
            "stages": params.stages, "squeeze": params.squeeze, "verify_hold_seconds": params.verify_hold_seconds}
    metadata = {**postures.metadata, "generator": made, "verified": True, "candidates": len(postures),
                "verified_ratio": float(held.mean()) if len(held) else float("nan"), "verified_by_start": by_start,
                "verify_hold_seconds": params.verify_hold_seconds}
    return PostureSet(kept.postures, kept.hand_poses, kept.start_ids, kept.contacts, kept.start_names, metadata,
                      rows[held, 1], rows[held, 2])


