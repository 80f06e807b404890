"""Evaluating a grasp controller over a grid of object positions and orientations (paper Section 5).

A trial puts a free object (gravity off) in front of the open hand at one grid pose, runs the
controller until it reports the grasp done, and then judges the grasp (`judge.judge_grasp`: the
hold test in six gravity directions, the disturbance margin, and epsilon for force closure). While
the hand closes, a stiff spring-damper support keeps the object near its place (as a table or a
helper's hand would; without it the first touch would push a weightless object away); it is
released before judging.

The grid is given in the palm frame around a nominal wrap placement (object long axis across the
fingers, centred in front of the palm, see `scene.facing_pose`): shifts across the fingers (x) and
along them (z), the gap between palm and object, and a yaw of the object's axis about the palm
normal. Presets (`grid_preset`): 'quick' and 'paper' cover where the open hand can plausibly close
on the object; 'far' puts the object 3-5 cm out of the palm; 'hard' shifts it up to 3 cm and turns
it up to 0.8 rad. Every preset is a regular grid less the placements where the object would sit
inside (or within 1 mm of) the open hand, which no hand could have reached. Optional noise perturbs
the true object pose around each grid pose (the paper's "vague object position"; a draw that would
start inside the open hand is redrawn) and the joint angles the controller senses.

A trial whose physics failed (`Scene.check`: a MuJoCo warning, a non-finite state, or a contact
deeper than `scene.PENETRATION_LIMIT`) is kept but marked invalid with the reason (`Trial.fault`):
it counts as neither a success nor a failure of the controller; summaries report rates over the
valid trials and the number of invalid ones, and paired comparisons skip a pose invalid for either
method.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import pickle
import warnings
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from .controller import ControllerParams, GraspController
from .experience import Experience, check_experience
from .hand import SEGMENTS, segment_of_geoms
from .io import library_version, load_npz, save_npz
from .objects import GraspObject, get_object
from .posture import N_FINGER_JOINTS, open_posture
from .progress import progress_bar
from .workers import worker_pool
from .quality import QualityError
from .judge import EPSILON_THRESHOLD, SUPPORT_DAMPING, SUPPORT_STIFFNESS, judge_grasp
from .poses import compose, invert, rotate, to_quat
from .scene import Scene, SimulationError, facing_pose
from .stats import rate_text, wilson_interval


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the trial noise: object position (m) and yaw (rad), sensed joints (rad)."""

    position: float = 0.0
    yaw: float = 0.0
    joints: float = 0.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"noise {name} must be a finite standard deviation >= 0, got {value!r}")


GRID_COLUMNS = ("x", "z", "gap", "yaw")
GRID_PRESETS = ("quick", "paper", "far", "hard")
START_CLEARANCE = 0.001  # m: the open hand must be at least this far from the object at a grid pose


def grid_preset(name: str, obj: str | GraspObject, table: bool = False) -> np.ndarray:
    """Grid poses (n, 4): object shift across (x) and along (z) the fingers, palm gap, yaw (m, rad).

    A regular grid less the poses the open hand cannot reach (`reachable`). 'quick': x and z in
    {-1.5, 0, 1.5} cm, gaps 1 and 2.5 cm, yaw in {-0.5, 0, 0.5} (box 37, cylinder 30 poses);
    'paper': x and z in 5 steps over +-2 cm, gaps 1-3 cm, 5 yaws over +-0.5 rad (box 263, cylinder 224).
    A sphere has no yaw, so it gets more gaps instead (quick 36, paper 225 poses, all reachable).
    'far': gaps 3, 4 and 5 cm, x in {-1.5, 0, 1.5} cm, z in {-2, 0, 2} cm, yaw in {-0.5, 0, 0.5};
    'hard': x and z in {-3, -1.5, 0, 1.5, 3} cm, gaps 1 and 2.5 cm, yaw in {-0.8, -0.4, 0, 0.4, 0.8}.
    """
    obj = get_object(obj)
    sphere = obj.shape == "sphere"
    yaws = {"quick": [-0.5, 0.0, 0.5], "paper": np.linspace(-0.5, 0.5, 5), "far": [-0.5, 0.0, 0.5],
            "hard": [-0.8, -0.4, 0.0, 0.4, 0.8]}
    if name not in GRID_PRESETS:
        raise ValueError(f"unknown grid preset {name!r}; expected one of {GRID_PRESETS} or an (n, 4) array")
    yaw = [0.0] if sphere else yaws[name]
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
    poses = np.array(list(itertools.product(*axes)), dtype=float)
    return poses[reachable(obj, poses, table)]


def _clearance(scene: Scene, pose: np.ndarray) -> float:
    """Distance (m) between the open hand and the object of `scene` at one grid pose (moves the hand there)."""
    model, data = scene.model, scene.data
    scene.set_hand_pose(*palm_pose_for(scene.object, pose))
    data.qpos[scene.finger_qpos] = open_posture()
    mujoco.mj_kinematics(model, data)
    hand_geoms = np.flatnonzero(segment_of_geoms(model) >= 0)
    fromto = np.zeros(6)
    others = [scene.object_geom] + ([scene.table_geom] if scene.table_geom is not None else [])
    return min(mujoco.mj_geomDistance(model, data, g, other, 0.05, fromto) for g in hand_geoms for other in others)


def open_hand_clearance(obj: str | GraspObject, grid: np.ndarray, table: bool = False) -> np.ndarray:
    """Distance (m) between the open hand and the object (and the table, with one) at each grid pose;
    negative when inside."""
    scene = Scene(get_object(obj), free_object=True, table=table)
    return np.array([_clearance(scene, pose) for pose in np.asarray(grid, dtype=float)])


def reachable(obj: str | GraspObject, grid: np.ndarray, table: bool = False) -> np.ndarray:
    """Which grid poses (bool, (n,)) leave the open hand clear of the object (and the table, with one),
    so a trial can start there."""
    return open_hand_clearance(obj, grid, table) >= START_CLEARANCE


def check_grid(grid: object, obj: GraspObject, table: bool = False) -> tuple[str, np.ndarray]:
    if isinstance(grid, str):
        return grid, grid_preset(grid, obj, table)
    poses = np.asarray(grid, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 4 or len(poses) == 0:
        raise ValueError(f"grid must be one of {GRID_PRESETS} or a non-empty (n, 4) array of {GRID_COLUMNS}, "
                         f"got shape {poses.shape}")
    if not np.all(np.isfinite(poses)):
        raise ValueError("grid poses must be finite")
    inside = np.flatnonzero(~reachable(obj, poses, table))
    if len(inside):
        raise ValueError(f"grid rows {inside.tolist()[:10]}{' ...' if len(inside) > 10 else ''} put the object inside "
                         f"(or within {START_CLEARANCE * 1000:.0f} mm of) the open hand, where no trial can start; "
                         "keep the reachable ones: grid[graspmanifold.reachable(obj, grid)]")
    return "custom", poses


def palm_pose_for(obj: GraspObject, grid_pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Palm pose in the object frame that places the object at a grid pose relative to the palm."""
    x, z, gap, yaw = grid_pose
    object_in_palm = invert(*facing_pose(obj, clearance=gap))
    turn = to_quat(Rotation.from_rotvec([0.0, yaw, 0.0]))  # about the palm normal
    _, quat = compose(np.zeros(3), turn, np.zeros(3), object_in_palm[1])
    return invert(object_in_palm[0] + np.array([x, 0.0, z]), quat)


@dataclass
class Trial:
    """The outcome of one grasp trial."""

    grid_pose: np.ndarray
    posture: np.ndarray
    touching: np.ndarray  # (len(SEGMENTS),) bool
    epsilon: float
    hold: bool
    hold_displacement: float
    time_to_grasp: float
    matches: int
    margin: float = 0.0  # N of extra disturbance held (judge.MARGIN_FORCE when never dropped)
    penetration: float = 0.0  # m, the deepest contact at the end of any control period (Scene.max_penetration)
    fault: str = ""  # why the physics of this trial failed; empty when it did not

    def __repr__(self) -> str:
        outcome = f"invalid: {self.fault}" if self.fault else (
            f"{'held' if self.hold else 'dropped'}, epsilon {self.epsilon:.3f}, margin {self.margin:.1f} N, "
            f"{self.time_to_grasp:.2f} s")
        return f"Trial(pose {np.round(self.grid_pose, 3).tolist()}: {outcome})"

    @property
    def valid(self) -> bool:
        """The physics of this trial worked: its outcome says something about the controller."""
        return not self.fault

    @property
    def force_closure(self) -> bool:
        return self.valid and self.epsilon > EPSILON_THRESHOLD


def _noisy_pose(scene: Scene, grid_pose: np.ndarray, noise: Noise, rng: np.random.Generator,
                tries: int = 20) -> np.ndarray:
    """The grid pose plus position and yaw noise, redrawn while it would put the object inside the open hand."""
    if noise.position == 0.0 and noise.yaw == 0.0:
        return grid_pose
    for _ in range(tries):
        pose = grid_pose + np.array([rng.normal(0, noise.position), rng.normal(0, noise.position), 0.0,
                                     rng.normal(0, noise.yaw)])
        if _clearance(scene, pose) >= START_CLEARANCE:
            return pose
    return grid_pose


def run_trial(obj: GraspObject, experience: Experience | None, grid_pose: np.ndarray,
              rng: np.random.Generator, noise: Noise = Noise(), params: ControllerParams | None = None,
              table: bool = False, preshape: np.ndarray | None = None,
              observer: Callable[[Scene], None] | None = None) -> Trial:
    """Place the object, let the controller grasp it, judge the grasp (epsilon, hold, margin).

    The object is held by a spring support with gravity off, or (`table=True`) stands on a table
    with gravity on while the hand closes. `observer(scene)` is called after the start and after
    every control period, the judging included (`record_trial` keeps the states it sees)."""
    scene = Scene(obj, free_object=True, gravity=table, table=table)
    if not table:
        scene.set_object_support(SUPPORT_STIFFNESS, SUPPORT_DAMPING)
    controller = GraspController(experience, params, preshape=preshape)
    true_pose = _noisy_pose(scene, np.asarray(grid_pose, dtype=float), noise, rng)
    scene.set_hand_pose(*palm_pose_for(obj, true_pose))
    scene.set_posture(controller.initial)
    period = controller.params.control_period
    if observer is not None:
        observer(scene)

    def cycle() -> None:
        sensed = scene.posture() + rng.normal(0.0, noise.joints, N_FINGER_JOINTS) if noise.joints else scene.posture()
        scene.set_target(controller.step(sensed, scene.tactile().segment_forces))
        scene.run(period)
        if observer is not None:
            observer(scene)

    grid_pose = np.asarray(grid_pose, dtype=float)
    try:
        while not controller.done:
            cycle()
        reading = scene.tactile()
        posture = scene.posture()
        judgement = judge_grasp(scene, cycle, period)
    except (SimulationError, QualityError) as error:
        return Trial(grid_pose, scene.posture(), np.zeros(len(SEGMENTS), dtype=bool), 0.0, False, np.inf,
                     float(scene.time), controller.matches, 0.0, scene.max_penetration, str(error))
    return Trial(grid_pose, posture, np.array([reading.touches(s) for s in SEGMENTS]),
                 judgement.epsilon, judgement.hold, judgement.displacement, float(controller.time_to_grasp),
                 controller.matches, judgement.margin, scene.max_penetration)


@dataclass
class EvaluationResult:
    """Trials of one controller (method) on one object, with their summary."""

    object: dict
    method: str
    grid_name: str
    seed: int
    trials: list[Trial]
    noise: Noise = field(default_factory=Noise)

    def __repr__(self) -> str:
        s = self.summary
        return (f"EvaluationResult({s['object']} / {self.method} on the {self.grid_name} grid: "
                f"{trial_count(s)} trials, hold {s['hold_rate']:.0%}, force closure {s['force_closure_rate']:.0%})")

    def _repr_markdown_(self) -> str:
        return self.markdown()

    @property
    def summary(self) -> dict[str, float | int | str]:
        """Rates (with 95 % Wilson intervals) and means over the valid trials; `trials` counts
        them, `invalid_trials` the trials whose physics failed (see the module doc)."""
        valid = [t for t in self.trials if t.valid]
        n, holds, closures = len(valid), sum(t.hold for t in valid), sum(t.force_closure for t in valid)

        def mean(values: list[float]) -> float:
            return float(np.mean(values)) if values else float("nan")

        return {
            "object": self.object["name"], "method": self.method, "grid": self.grid_name, "trials": n,
            "invalid_trials": len(self.trials) - n,
            "hold_rate": holds / n if n else float("nan"), "hold_interval": list(wilson_interval(int(holds), n)),
            "force_closure_rate": closures / n if n else float("nan"),
            "force_closure_interval": list(wilson_interval(int(closures), n)),
            "epsilon_threshold": EPSILON_THRESHOLD,
            "mean_margin": mean([t.margin for t in valid]),
            "mean_epsilon": mean([t.epsilon for t in valid]),
            "mean_time_to_grasp": mean([t.time_to_grasp for t in valid]),
            "mean_touching_segments": mean([t.touching.sum() for t in valid]),
            "max_penetration": max([t.penetration for t in valid], default=0.0),
        }

    def valid(self) -> np.ndarray:
        """Which trials' physics worked (bool, grid order)."""
        return np.array([t.valid for t in self.trials], dtype=bool)

    def outcomes(self, measure: str = "hold") -> np.ndarray:
        """Success per trial (bool, grid order) by 'hold' or 'force_closure'; an invalid trial
        reads False here, so pair it with `valid()` (or use `rate`)."""
        if measure not in ("hold", "force_closure"):
            raise ValueError(f"measure must be 'hold' or 'force_closure', got {measure!r}")
        return np.array([t.valid and bool(getattr(t, measure)) for t in self.trials], dtype=bool)

    def rate(self, measure: str = "hold", rows: np.ndarray | None = None) -> float:
        """The success rate over the valid trials (of `rows`, a bool mask in grid order, if given)."""
        keep = self.valid() if rows is None else self.valid() & np.asarray(rows, dtype=bool)
        return float(self.outcomes(measure)[keep].mean()) if keep.any() else float("nan")

    def successful_postures(self, require_hold: bool = True) -> np.ndarray:
        """Final postures (m, 22) of the trials that held (or, with require_hold=False, reached force
        closure): the grasps that may join the experience."""
        keep = [t.posture for t in self.trials if t.valid and (t.hold if require_hold else t.force_closure)]
        return np.array(keep).reshape(-1, N_FINGER_JOINTS)

    def markdown(self) -> str:
        s = self.summary
        n = s["trials"]
        return ("| object | method | trials | hold [95 % CI] | force closure [95 % CI] | mean margin (N) | mean ε "
                "| mean time to grasp (s) |\n|---|---|---|---|---|---|---|---|\n"
                f"| {s['object']} | {s['method']} | {trial_count(s)} | {rate_text(round(s['hold_rate'] * n), n)} | "
                f"{rate_text(round(s['force_closure_rate'] * n), n)} | {s['mean_margin']:.2f} | "
                f"{s['mean_epsilon']:.4f} | {s['mean_time_to_grasp']:.2f} |\n")

    def save(self, path: str | os.PathLike, *, overwrite: bool = True, extra: dict | None = None) -> Path:
        """Write the trials and the summary (plus `extra` metadata) to an .npz file."""
        t = self.trials
        arrays = {"grid": np.array([x.grid_pose for x in t]).reshape(-1, 4),
                  "postures": np.array([x.posture for x in t]).reshape(-1, N_FINGER_JOINTS),
                  "touching": np.array([x.touching for x in t]).reshape(-1, len(SEGMENTS)),
                  "epsilon": np.array([x.epsilon for x in t]), "hold": np.array([x.hold for x in t]),
                  "hold_displacement": np.array([x.hold_displacement for x in t]),
                  "time_to_grasp": np.array([x.time_to_grasp for x in t]),
                  "matches": np.array([x.matches for x in t]), "margin": np.array([x.margin for x in t]),
                  "penetration": np.array([x.penetration for x in t]),
                  "fault": np.array([x.fault for x in t], dtype=str)}
        meta = {"object": self.object, "method": self.method, "grid_name": self.grid_name, "seed": self.seed,
                "noise": asdict(self.noise), "summary": self.summary, "segments": list(SEGMENTS),
                "units": "m, rad, s, N; epsilon per unit total normal force", **(extra or {})}
        return save_npz(path, "evaluation", arrays, meta, overwrite=overwrite)

    @classmethod
    def load(cls, path: str | os.PathLike) -> EvaluationResult:
        return cls._load_with_metadata(path)[0]

    @classmethod
    def _load_with_metadata(cls, path: str | os.PathLike) -> tuple[EvaluationResult, dict]:
        a, meta = load_npz(path, "evaluation", {"grid": (None, 4), "postures": (None, N_FINGER_JOINTS), "epsilon": (None,),
                                                "margin": (None,), "penetration": (None,), "fault": (None,)})
        trials = [Trial(a["grid"][i], a["postures"][i], a["touching"][i], float(a["epsilon"][i]), bool(a["hold"][i]),
                        float(a["hold_displacement"][i]), float(a["time_to_grasp"][i]), int(a["matches"][i]),
                        float(a["margin"][i]), float(a["penetration"][i]), str(a["fault"][i]))
                  for i in range(len(a["epsilon"]))]
        return cls(meta["object"], meta["method"], meta["grid_name"], meta["seed"], trials, Noise(**meta["noise"])), meta


@dataclass
class Recording:
    """A trial with the scene's state every `period` seconds, for pictures and animations."""

    trial: Trial
    scene: Scene
    states: np.ndarray  # (k, len(Scene.state()))
    period: float

    def frames(self, camera: str = "hand", width: int = 320, height: int = 240) -> np.ndarray:
        """Pictures (k, height, width, 3) uint8 of every recorded state from a named camera."""
        from .render import render_states

        return render_states(self.scene, self.states, camera, width, height)

    def save_gif(self, path: str | os.PathLike, camera: str = "hand", width: int = 320, height: int = 240,
                 speed: float = 1.0) -> Path:
        """An animated GIF of the trial, `speed` times real time."""
        from .render import save_animation

        return save_animation(self.frames(camera, width, height), path, fps=speed / self.period)


def record_trial(obj: str | GraspObject, experience: Experience | None = None,
                 grid_pose: Iterable[float] = (0.0, 0.0, 0.01, 0.0), seed: int = 0, *, every: int = 2,
                 noise: Noise | None = None, params: ControllerParams | None = None, table: bool = False,
                 preshape: np.ndarray | None = None) -> Recording:
    """Run one trial as `evaluate` would at this grid pose (x, z, gap, yaw) and keep the scene's
    state every `every` control periods: `record_trial("box").save_gif("grasp.gif")`, or
    `recording.scene.render()` for its final state."""
    obj = get_object(obj)
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive whole number of control periods, got {every!r}")
    grid_pose = np.asarray(tuple(grid_pose), dtype=float)
    if grid_pose.shape != (4,) or not np.all(np.isfinite(grid_pose)):
        raise ValueError(f"grid_pose must be four finite numbers (x, z, gap, yaw), got {grid_pose!r}")
    states: list[np.ndarray] = []
    seen: dict[str, Scene] = {}

    def observe(scene: Scene) -> None:
        seen["scene"] = scene  # the trial's one scene
        if not states or round(scene.time / period) % every == 0:
            states.append(scene.state())

    period = (params or ControllerParams()).control_period
    trial = run_trial(obj, check_experience(experience), grid_pose, np.random.default_rng([seed, 0]),
                      noise or Noise(), params, table, preshape, observer=observe)
    return Recording(trial, seen["scene"], np.array(states), every * period)


def trial_count(summary: dict) -> str:
    """The valid trials of a summary, and the invalid ones when there are any ("225 (+2 invalid)")."""
    invalid = summary.get("invalid_trials", 0)
    return f"{summary['trials']}" + (f" (+{invalid} invalid)" if invalid else "")


def method_name(experience: Experience | None) -> str:
    return "none" if experience is None else type(experience).__name__.replace("PostureDatabase", "database").lower()


_WORKER: dict = {}


def _init_worker(obj: GraspObject, experience: Experience | None, noise: Noise, params: ControllerParams | None,
                 table: bool, preshape: np.ndarray | None) -> None:
    _WORKER.update(obj=obj, experience=experience, noise=noise, params=params, table=table, preshape=preshape)


#: trials per checkpoint part of an evaluation at most (the unit of parallel work and of resuming)
CHECKPOINT_TRIALS = 16


def _chunk_worker(args: tuple[list[int], np.ndarray, int]) -> list[tuple[int, Trial]]:
    indices, poses, seed = args
    w = _WORKER
    return [(index, run_trial(w["obj"], w["experience"], pose, np.random.default_rng([seed, index]), w["noise"],
                              w["params"], w["table"], w["preshape"]))
            for index, pose in zip(indices, poses)]


def _signature(obj: GraspObject, experience: Experience | None, poses: np.ndarray, seed: int, noise: Noise,
               params: ControllerParams | None, table: bool, preshape: np.ndarray | None) -> str:
    """A digest of everything a trial's outcome depends on: checkpoint parts of another
    configuration are never mixed in."""
    digest = hashlib.sha256(json.dumps({"object": obj.params(), "seed": int(seed), "noise": asdict(noise),
                                        "params": asdict(params or ControllerParams()), "table": bool(table)},
                                       sort_keys=True, default=str).encode())
    digest.update(np.ascontiguousarray(poses, dtype=float).tobytes())
    digest.update(pickle.dumps(experience))
    digest.update(b"" if preshape is None else np.ascontiguousarray(preshape, dtype=float).tobytes())
    return digest.hexdigest()[:20]


def _load_parts(directory: Path, signature: str, chunks: list[list[int]]) -> dict[int, list[Trial]]:
    """Finished chunks from an earlier run with this signature; other or unreadable parts are removed."""
    found, discarded = {}, []
    for path in sorted(directory.glob("part_*.npz")):
        try:
            part, meta = EvaluationResult._load_with_metadata(path)
            trials = part.trials
        except (ValueError, KeyError):  # truncated, or not a part of ours
            meta, trials = {}, []
        first = int(meta.get("first", -1))
        number = next((k for k, chunk in enumerate(chunks) if chunk[0] == first), None)
        if meta.get("signature") == signature and number is not None and len(trials) == len(chunks[number]):
            found[number] = trials
        else:
            discarded.append(path.name)
            path.unlink()
    if discarded:
        warnings.warn(f"discarded {len(discarded)} checkpoint part(s) in {directory} that belong to another "
                      f"configuration or could not be read: {', '.join(discarded[:4])}"
                      f"{' ...' if len(discarded) > 4 else ''}", stacklevel=3)
    return found


def evaluate(obj: str | GraspObject, experience: Experience | None, grid: str | np.ndarray = "quick",
             seed: int = 0, workers: int = 1, *, noise: Noise | None = None, params: ControllerParams | None = None,
             table: bool = False, preshape: np.ndarray | None = None, checkpoint_dir: str | os.PathLike | None = None,
             progress: bool = False) -> EvaluationResult:
    """Run the controller with this experience (None, a PostureDatabase or a SOM) on every grid pose.

    `table=True`: the object stands on a table (gravity on) while the hand closes, instead of being
    held by a spring; grid poses where the open hand would touch the table are left out of presets
    (and refused in a custom grid). `preshape`: a constant phase-B posture (see `GraspController`).
    With `checkpoint_dir`, every CHECKPOINT_TRIALS finished trials are saved there and a rerun with
    the same arguments picks them up (parts of another configuration are discarded with a warning).
    The same seed gives the same trials, whatever the number of workers or interruptions."""
    obj = get_object(obj)
    experience = check_experience(experience)
    noise = noise or Noise()
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    grid_name, poses = check_grid(grid, obj, table)
    size = max(1, min(CHECKPOINT_TRIALS, -(-len(poses) // (4 * workers))))  # at least 4 chunks per worker
    chunks = [list(range(first, min(first + size, len(poses)))) for first in range(0, len(poses), size)]
    directory = Path(checkpoint_dir) if checkpoint_dir is not None else None
    signature = _signature(obj, experience, poses, seed, noise, params, table, preshape)
    done: dict[int, list[Trial]] = {}
    if directory is not None:
        directory.mkdir(parents=True, exist_ok=True)
        done = _load_parts(directory, signature, chunks)
    method = method_name(experience)
    pending = [k for k in range(len(chunks)) if k not in done]
    tasks = [(chunks[k], poses[chunks[k]], seed) for k in pending]
    report = progress_bar(len(poses), f"evaluate {obj.name} / {method}", "trials", enabled=progress)

    def keep(number: int, trials: list[Trial]) -> None:
        done[number] = trials
        if directory is not None:
            EvaluationResult(obj.params(), method, grid_name, seed, trials, noise).save(
                directory / f"part_{chunks[number][0]:05d}.npz", extra={"signature": signature,
                                                                         "first": chunks[number][0]})
        report.update(len(trials))

    initargs = (obj, experience, noise, params, table, preshape)
    with report:
        report.update(sum(len(t) for t in done.values()))
        if workers == 1:
            _init_worker(*initargs)
            for number, task in zip(pending, tasks):
                keep(number, [trial for _, trial in _chunk_worker(task)])
        else:
            with worker_pool(workers, _init_worker, initargs) as pool:
                for number, chunk in zip(pending, pool.map(_chunk_worker, tasks)):
                    keep(number, [trial for _, trial in chunk])
    trials = [trial for k in range(len(chunks)) for trial in done[k]]
    return EvaluationResult(obj.params(), method, grid_name, seed, trials, noise)


def summary_json(results: list[EvaluationResult]) -> str:
    return json.dumps({"library_version": library_version(), "results": [r.summary for r in results]}, indent=2)




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
    poses = np.asarray(hand_poses, dtype=float).reshape(-1, 7)
    if not len(poses):
        raise ValueError("hand_poses must hold at least one experienced palm pose (m, 7)")

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
        nearest = int(np.argmin(distances))
        angle = 0.0 if obj.shape == "sphere" else float(np.arccos(min(1.0, abs(float(axes[nearest] @ axis)))))
        out[i] = distances[nearest], angle
    return out
