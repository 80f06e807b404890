"""The spring rig of the posture generator (paper Section 5) and its walk around one starting posture.

The object is held fixed. Each fingertip is pulled towards its closest point on the object surface by a spring force
applied in the simulation, while the finger servos hold the starting posture only softly, so the fingers follow the
springs (`SpringRig`). Around each starting posture the hand takes a random walk through nearby positions and
orientations, in steps small enough for the springs to keep up; after each step the hand settles and the posture is
tested (`walk`): postures in which the design's contact segments touch the object (gap <= 1 mm), nothing penetrates
deeper than 2 mm, every joint is inside its range and the hand is at rest are candidates, kept where the
generator's verifier (`verifier_of`) says they hold. The generator's settings are `GeneratorParams`; the generator
itself (waves, jobs, checkpoints) is `generator`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput, SimulationError
from ..base.moved import current_name
from ..base.poses import to_quat, to_rotation
from ..base.validation import check_choice
from ..judging.judge import VERIFY_HOLD_SECONDS
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOL_NAMES
from ..judging.plans import GRASP_STAGES, VERIFY_STAGES, GraspStages
from ..judging.replay import GraspVerifier
from ..sim.grip import SQUEEZE
from ..sim.hand import DISTAL_SEGMENTS, FINGER_JOINTS, SEGMENTS, SHADOW_HAND, segment_of_geoms
from ..sim.objects import GraspObject
from ..sim.scene import Scene
from .starts import CONTACT_GAP, DESIGN_FAMILIES, MAX_PENETRATION, StartingPosture, verified


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
    #: how the replay's pregrasp and squeeze are made (`plans.GRASP_STAGES`): "contacts" (the touching
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
class WalkJob:
    """One job of the walk: a start (its index), a chunk of it (numbered per start) and its quota of candidates."""

    start_index: int
    chunk: int
    quota: int  # candidates to find


def walk(obj: GraspObject, start: StartingPosture, job: WalkJob, seed: int, params: GeneratorParams,
         hand: str = SHADOW_HAND.name) -> dict[str, np.ndarray]:
    """Walk around one start until `job.quota` candidates are found (or give up after `max_tries_per_posture` steps
    per candidate: `exhausted`); keep the verified ones. Returns the kept "postures", "hand_poses", "contacts",
    "epsilon", "hold_displacement" and the walk's "tries", "candidates", "faults", "first_fault", "exhausted"."""
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
    walked = walk(obj, start, WalkJob(0, 0, NEIGHBOURS), seed=0, params=GeneratorParams(designs="grasp_types"))
    return len(walked["postures"]) > 0 and not bool(walked["exhausted"])


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
