"""Spring-based grasp posture generation (paper Section 5).

The object is held fixed. Each fingertip is pulled towards its closest point on the object surface
by a spring force applied in the simulation, while the finger servos hold the starting posture
only softly, so the fingers follow the springs. Around each starting posture the hand takes a
random walk through nearby positions and orientations, in steps small enough for the springs to
keep up; after each step the hand settles and the posture is tested. Postures in which all five
distal segments touch the object (gap <= 1 mm), nothing penetrates deeper than 2 mm, every joint is
inside its range and the hand is at rest are candidates. Because the walk stays near its starting
posture, the data clusters around the starting postures, as the paper's did.

The paper's experience is made of "hand postures which previously led to successful grasps", so
every candidate is then verified as a grasp (`GeneratorParams.verify`, on by default): the hand is
put at the candidate's palm pose in front of the free object, the fingers press with the
controller's squeeze, the support is released and the hold test runs (`judge.judge_grasp`, six
gravity directions of `verify_hold_seconds` each); only candidates that hold are kept, with their
epsilon (at the object's friction) and largest displacement recorded in the set.

Work is cut into jobs (a starting posture and a chunk of its quota) with their own random streams,
so the set depends on the seed alone (not on the number of workers), jobs run in parallel
processes, and a run with a checkpoint directory resumes after an interruption without redoing
finished jobs.
"""

from __future__ import annotations

import json
import os
import shutil
import warnings
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import asdict, dataclass
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from .controller import ControllerParams, squeezed
from .hand import (
    DISTAL_SEGMENTS,
    FINGER_JOINTS,
    FINGERTIP_SITES,
    SEGMENTS,
    finger_limits,
    segment_of_geoms,
)
from .io import library_version, load_npz, save_npz
from .judge import SUPPORT_DAMPING, SUPPORT_STIFFNESS, Judgement, judge_grasp
from .objects import GraspObject, get_object
from .poses import to_quat, to_rotation
from .posture import posture_to_ctrl
from .postureset import PostureSet
from .progress import progress_bar
from .scene import Scene, SimulationError
from .starts import CONTACT_GAP, MAX_PENETRATION, StartingPosture, starting_postures
from .validation import check_int
from .workers import parallel_map

#: The paper's dataset sizes (Section 5), and a small set for tests and demos.
PRESETS: dict[str, dict[str, int]] = {
    "paper": {"box": 4069, "cylinder": 4220, "sphere": 1885},
    "quick": {"box": 240, "cylinder": 240, "sphere": 160},
}


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
    max_tries_per_posture: int = 40  # give up a job after this many walk steps per posture of its quota
    verify: bool = True  # keep only candidates that hold when replayed with the controller's squeeze
    verify_hold_seconds: float = 0.25  # s per gravity direction of the verifying hold test
    squeeze: float = ControllerParams.squeeze  # rad, as the controller presses

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"GeneratorParams.mode must be one of {MODES}, got {self.mode!r}")
        for name, value in asdict(self).items():
            if name in ("verify", "mode"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
                raise ValueError(f"GeneratorParams.{name} must be a finite number >= 0, got {value!r}")
        for name in ("job_size", "move_steps", "settle_steps", "max_tries_per_posture", "record_every"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise ValueError(f"GeneratorParams.{name} must be a positive integer, got {getattr(self, name)!r}")


#: The generator settings of each preset. The quick preset takes one settled posture per walk step (small
#: and fast, for tests and demos); the paper preset records along the hand's motion as the paper did,
#: which brings the data's density closest to what the paper's maps imply (docs/data_character.md).
PRESET_PARAMS: dict[str, GeneratorParams] = {
    "quick": GeneratorParams(),
    "paper": GeneratorParams(mode="recording", record_every=5),
}


class _Verifier:
    """Replays a candidate at its palm pose on the free object and runs the hold test."""

    PERIOD = 0.02  # s between checks of the object's displacement

    def __init__(self, obj: GraspObject, params: GeneratorParams):
        self.scene = Scene(obj, free_object=True)
        self.params = params

    def __call__(self, posture: np.ndarray, hand_pos: np.ndarray, hand_quat: np.ndarray) -> Judgement:
        scene = self.scene
        mujoco.mj_resetData(scene.model, scene.data)
        scene.set_object_support(SUPPORT_STIFFNESS, SUPPORT_DAMPING)
        scene.set_hand_pose(hand_pos, hand_quat)
        scene.set_posture(posture)
        scene.set_target(squeezed(posture, self.params.squeeze))
        scene.run(0.2)  # the fingers press (SimulationError if the physics fails)
        return judge_grasp(scene, lambda: scene.run(self.PERIOD), self.PERIOD, hold_seconds=self.params.verify_hold_seconds, margin=False)


class _SpringRig:
    """A scene with fingertip springs and compliant finger servos, for one object."""

    def __init__(self, obj: GraspObject, params: GeneratorParams):
        self.scene = Scene(obj)
        self.params = params
        model = self.scene.model
        fingers = slice(2, None)  # actuators after the two wrist servos
        model.actuator_gainprm[fingers, 0] *= params.servo_stiffness_scale
        model.actuator_biasprm[fingers, 1] *= params.servo_stiffness_scale
        self.tip_sites = [model.site(s).id for s in FINGERTIP_SITES]
        self.tip_bodies = [int(model.site_bodyid[s]) for s in self.tip_sites]
        segment_of = segment_of_geoms(model)
        self.segment_geoms = [[int(g) for g in np.flatnonzero(segment_of == i)] for i in range(len(SEGMENTS))]
        self.distal_geoms = [model.geom(s).id for s in DISTAL_SEGMENTS]
        self.finger_dofs = self.scene.hand_dofs[2:]
        self.limits = finger_limits()
        self._torque = np.zeros(3)

    def apply_springs(self) -> None:
        data = self.scene.data
        data.qfrc_applied[:] = 0.0
        tips = data.site_xpos[self.tip_sites]  # the object sits at the world origin, unrotated
        pull = self.params.spring_stiffness * (self.scene.object.closest_point(tips) - tips)
        norm = np.linalg.norm(pull, axis=1, keepdims=True)
        pull *= np.minimum(1.0, self.params.spring_max_force / np.maximum(norm, 1e-12))
        for force, point, body in zip(pull, tips, self.tip_bodies):
            mujoco.mj_applyFT(self.scene.model, data, force, self._torque, point, body, data.qfrc_applied)

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
        data.qpos[scene.finger_qpos] = clipped  # judge exactly what is stored
        mujoco.mj_kinematics(model, data)
        gap = scene.distance_to_object
        try:
            if any(gap(g) > CONTACT_GAP for g in self.distal_geoms):
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
    quota: int


def _run_job(obj: GraspObject, start: StartingPosture, job: _Job, seed: int, params: GeneratorParams
             ) -> dict[str, np.ndarray]:
    """Walk around one starting posture until `job.quota` candidates are found; keep the verified ones."""
    rng = np.random.default_rng([seed, job.start_index, job.chunk])
    rig = _SpringRig(obj, params)
    verifier = _Verifier(obj, params) if params.verify else None
    rig.reset_to(start)
    rig.scene.data.ctrl[:] = posture_to_ctrl(start.posture)
    base = to_rotation(start.hand_quat)
    offset, turn = np.zeros(3), np.zeros(3)
    postures, poses, contacts, epsilons, displacements = [], [], [], [], []
    tries, walks, misses, candidates, faults, steps = 0, 0, 0, 0, 0, 0
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
            raise RuntimeError(f"the generator accepted only {candidates} of {tries} postures in {walks} walk steps "
                               f"around starting posture {start.name!r}; check the object and GeneratorParams")
        offset = _bounded(offset + rng.normal(0.0, params.step_size, 3), params.walk_radius)
        turn = _bounded(turn + rng.normal(0.0, params.step_angle, 3), params.walk_angle)
        frames.clear()
        rig.move_to(start.hand_pos + offset, to_quat(Rotation.from_rotvec(turn) * base), record if recording else None)
        settled = rig.settle(record if recording else None)
        if not rig.scene.healthy():  # the physics failed: nothing of this walk can be trusted
            faults += 1
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
            except SimulationError:  # the replay's physics failed: not a verified grasp
                faults += 1
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
            "tries": np.array(tries), "candidates": np.array(candidates), "faults": np.array(faults)}


def _bounded(v: np.ndarray, radius: float) -> np.ndarray:
    norm = np.linalg.norm(v)
    return v if norm <= radius else v * (radius / norm)


def _plan(n: int, starts: int, job_size: int) -> list[_Job]:
    """Split n postures evenly over the starting postures, and each share into jobs."""
    jobs = []
    for s in range(starts):
        share = n // starts + (1 if s < n % starts else 0)
        for chunk, first in enumerate(range(0, share, job_size)):
            jobs.append(_Job(s, chunk, min(job_size, share - first)))
    return jobs


def _job_file(directory: Path, job: _Job) -> Path:
    return directory / f"job_{job.start_index:03d}_{job.chunk:04d}.npz"


def _job_worker(args: tuple) -> tuple[int, dict[str, np.ndarray]]:
    index, obj, start, job, seed, params, directory, signature = args
    result = _run_job(obj, start, job, seed, params)
    if directory is not None:
        save_npz(_job_file(directory, job), "generator_job", result, {"signature": signature, "job": asdict(job)})
    return index, result


def generate_postures(obj: str | GraspObject, n: int, seed: int = 0, workers: int = 1, *,
                      params: GeneratorParams | None = None, checkpoint_dir: str | os.PathLike | None = None,
                      progress: bool = False, executor: Executor | None = None) -> PostureSet:
    """Generate grasp postures for an object (a name or a made object) from n candidates.

    Without verification (`params.verify=False`) every candidate is kept, so the set holds exactly
    n postures; with it (the default) only the candidates that hold the object are kept, and the
    metadata says how many were (`verified_ratio`, also per starting posture in `verified_by_start`).

    The same seed gives the same set, whatever the number of workers or the `executor` (e.g. a Dask
    cluster's, `workers.cluster_executor`) the jobs run on. With `checkpoint_dir`,
    every finished job is saved there, and a rerun with the same arguments picks them up.
    """
    obj = get_object(obj)
    n, workers = check_int(n, "n"), check_int(workers, "workers")
    params = params or GeneratorParams()
    starts = starting_postures(obj)
    if not starts:
        raise RuntimeError(f"no starting posture could be found for {obj.name}")
    jobs = _plan(int(n), len(starts), params.job_size)
    signature = json.dumps({"object": obj.params(), "seed": seed, "n": int(n), "params": asdict(params),
                            "starts": [s.name for s in starts]}, sort_keys=True)
    directory = Path(checkpoint_dir) if checkpoint_dir is not None else None
    results: dict[int, dict[str, np.ndarray]] = {}
    if directory is not None:
        directory.mkdir(parents=True, exist_ok=True)
        wanted = {_job_file(directory, job): index for index, job in enumerate(jobs)}
        discarded = []
        for path in sorted(directory.glob("job_*.npz")):
            try:
                arrays, meta = load_npz(path, "generator_job", {"postures": (None, len(FINGER_JOINTS))})
            except ValueError:
                meta = {}
            if path in wanted and meta.get("signature") == signature:
                results[wanted[path]] = arrays
            else:
                discarded.append(path.name)
                path.unlink()
        if discarded:
            warnings.warn(f"discarded {len(discarded)} checkpoint part(s) in {directory} that belong to another "
                          "configuration (object, seed, n or parameters) or could not be read: "
                          f"{', '.join(discarded[:4])}{' ...' if len(discarded) > 4 else ''}", stacklevel=2)
    pending = [(i, obj, starts[job.start_index], job, seed, params, directory, signature)
               for i, job in enumerate(jobs) if i not in results]
    with progress_bar(n, f"generate {obj.name}", "candidates", enabled=progress) as report:
        report.update(sum(jobs[i].quota for i in results))

        def keep(_: int, finished: tuple[int, dict[str, np.ndarray]]) -> None:
            index, result = finished
            results[index] = result
            report.update(jobs[index].quota)

        parallel_map(_job_worker, pending, workers, keep, executor)
    ordered = [results[i] for i in range(len(jobs))]
    tries = int(sum(int(r["tries"]) for r in ordered))
    faults = int(sum(int(r.get("faults", 0)) for r in ordered))
    kept = int(sum(len(r["postures"]) for r in ordered))
    by_start = {s.name: [0, 0] for s in starts}
    for r, job in zip(ordered, jobs):
        by_start[starts[job.start_index].name][0] += len(r["postures"])
        by_start[starts[job.start_index].name][1] += job.quota
    posture_set = PostureSet(
        postures=np.concatenate([r["postures"] for r in ordered]),
        hand_poses=np.concatenate([r["hand_poses"] for r in ordered]),
        start_ids=np.concatenate([np.full(len(r["postures"]), job.start_index) for r, job in zip(ordered, jobs)]
                                 ).astype(np.int64),
        contacts=np.concatenate([r["contacts"] for r in ordered]).astype(bool),
        epsilon=np.concatenate([r["epsilon"] for r in ordered]),
        hold_displacement=np.concatenate([r["hold_displacement"] for r in ordered]),
        start_names=tuple(f"{obj.name}:{s.name}" for s in starts),
        metadata={"object": obj.params(), "seed": seed, "generator": asdict(params), "n": int(n),
                  "acceptance_ratio": n / tries, "simulation_faults": faults, "verified": params.verify, "candidates": int(n),
                  "verified_ratio": kept / n, "verified_by_start": {k: v[0] / v[1] for k, v in by_start.items() if v[1]},
                  "library_version": library_version(),
                  "starting_postures": {s.name: {"hand_pos": s.hand_pos.tolist(), "hand_quat": s.hand_quat.tolist(),
                                                 "posture": s.posture.tolist()} for s in starts}},
    )
    return posture_set


def remove_checkpoints(directory: str | os.PathLike) -> None:
    """Delete a checkpoint directory once its run has been saved."""
    shutil.rmtree(directory, ignore_errors=True)
