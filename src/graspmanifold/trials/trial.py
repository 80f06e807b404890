"""One grasp trial: place the object at a grid pose, let the controller close the hand, judge the grasp.

A trial puts a free object (gravity off) in front of the open hand at one grid pose (`grid.py`),
runs the controller until it reports the grasp done, and then judges the grasp (`judge.judge_grasp`:
the hold test in six gravity directions, the disturbance margin, and epsilon for force closure).
While the hand closes, a stiff spring-damper support keeps the object near its place (as a table or
a helper's hand would; without it the first touch would push a weightless object away); it is
released before judging. Optional noise perturbs the true object pose around the grid pose (the
paper's "vague object position"; a draw that would start inside the open hand is redrawn) and the
joint angles the controller senses.

A trial whose physics failed (`Scene.check`: a MuJoCo warning, a non-finite state, or a contact
deeper than `scene.PENETRATION_LIMIT`) is kept but marked invalid with the reason (`Trial.fault`):
it counts as neither a success nor a failure of the controller. `record_trial` runs one trial and
keeps its states for pictures and animations.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..base.checkpoints import result_key
from ..base.errors import InvalidInput, QualityError, SimulationError
from ..base.validation import check_int
from ..control.controller import ControllerParams, GraspController
from ..control.judge import JUDGING, judge_grasp, supported_scene
from ..manifold.experience import Experience, check_experience
from ..manifold.postureset import PostureSet
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, get_object
from ..sim.scene import Scene
from .grid import START_CLEARANCE, check_grid, clearance, palm_pose_for

#: the largest standard deviation of each noise (m, rad, rad): beyond it a trial measures nothing (joint
#: noise of 1e9 rad was accepted)
MAX_NOISE = {"position": 0.05, "yaw": math.pi, "joints": 0.5}


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the trial noise: object position (m) and yaw (rad), sensed joints (rad)."""

    position: float = 0.0
    yaw: float = 0.0
    joints: float = 0.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not np.isfinite(value) or value < 0 or value > MAX_NOISE[name]:
                raise InvalidInput(f"noise {name} must be a standard deviation 0 ... {MAX_NOISE[name]:.3g}, got {value!r}")


#: the physics engines trials run on: CPU MuJoCo, or MuJoCo Warp on an NVIDIA GPU (`warp_worlds.py`)
BACKENDS = ("cpu", "warp")


def method_name(experience: Experience | None) -> str:
    """The default label of a method: 'none' (the plain tactile controller), 'database' or 'som'.

    Args:
        experience: the experience base.

    Returns:
        The label.
    """
    return "none" if experience is None else type(experience).__name__.replace("PostureDatabase", "database").lower()


@dataclass(frozen=True, eq=False)
class TrialSetup:
    """Everything a trial depends on besides its grid pose and its random stream, in one frozen value:
    what `evaluate`, the batched trials, `record_trial` and the checkpoint key share.

    Attributes:
        object: the object (a name is looked up).
        experience: the experience base (None: the plain tactile controller; a PostureSet becomes its database).
        noise: pose and joint noise.
        params: the controller's parameters.
        table: the object stands on a table with gravity on (False: a spring support with gravity off).
        preshape: a constant phase-B posture (22,), rad, or None.
        backend: the physics engine (`BACKENDS`).
        method: the method's label in results and reports (empty: `method_name` of the experience).
        hand: the hand model, or its name or the path of its MJCF file (`hand_models.hand_model`); experience from another hand's
            postures is refused.
    """

    object: GraspObject
    experience: Experience | None = None
    noise: Noise = Noise()
    params: ControllerParams = field(default_factory=ControllerParams)
    table: bool = False
    preshape: np.ndarray | None = None
    backend: str = "cpu"
    method: str = ""
    hand: HandModel = SHADOW_HAND

    def __post_init__(self) -> None:
        set_field = functools.partial(object.__setattr__, self)
        set_field("object", get_object(self.object))
        set_field("hand", self.hand if isinstance(self.hand, HandModel) else hand_model(self.hand))
        if isinstance(self.experience, PostureSet) and self.experience.metadata.get("hand", "ours") != self.hand.name:
            raise InvalidInput(f"the experience holds postures of the {self.experience.metadata.get('hand', 'ours')!r} "
                               f"hand; these trials run the {self.hand.name!r} hand")
        if self.backend == "warp" and self.hand.name != SHADOW_HAND.name:
            raise InvalidInput(f"backend='warp' runs our hand model only, not {self.hand.name!r}: use backend='cpu'")
        set_field("experience", check_experience(self.experience))
        set_field("params", self.params or ControllerParams())
        set_field("noise", self.noise or Noise())
        if not isinstance(self.noise, Noise) or not isinstance(self.params, ControllerParams):
            raise InvalidInput(f"noise must be a Noise and params ControllerParams, got {type(self.noise).__name__} "
                               f"and {type(self.params).__name__}")
        if self.backend not in BACKENDS:
            raise InvalidInput(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        if not isinstance(self.method, str):
            raise InvalidInput(f"method must be a label (a string), got {self.method!r}")
        set_field("method", self.method or method_name(self.experience))
        set_field("table", bool(self.table))

    def key(self, poses: np.ndarray, seed: int) -> str:
        """The `checkpoints.result_key` of this set-up's trials at these poses: of the experience, what a
        controller reads of it (its kind and its reference postures), never a pickle; not the label.

        Args:
            poses: grid poses (n, 4), m and rad.
            seed: the trials' seed.

        Returns:
            A 20-character hexadecimal key.
        """
        experience = self.experience
        return result_key({"object": self.object.params(), "seed": int(seed), "noise": asdict(self.noise),
                           "params": asdict(self.params), "table": self.table, "backend": self.backend,
                           "experience": None if experience is None else type(experience).__name__,
                           "hand": self.hand.name},
                          np.asarray(poses, dtype=float),
                          np.empty(0) if experience is None else np.asarray(experience.references, dtype=float),
                          np.empty(0) if self.preshape is None else np.asarray(self.preshape, dtype=float))

    def controller(self) -> GraspController:
        """A fresh controller of this set-up."""
        return GraspController(self.experience, self.params, preshape=self.preshape)


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
    margin: float = 0.0  # N of extra disturbance held (JUDGING.margin_force when never dropped)
    penetration: float = 0.0  # m, the deepest contact at the end of any control period (Scene.max_penetration)
    fault: str = ""  # why the physics of this trial failed; empty when it did not
    #: the best match of every experience query the controller used (`matches` of them), in order: rows of
    #: `experience.references` (a SOM's flat node indices); None when not recorded (a file of library 0.1.0)
    winners: np.ndarray | None = field(default_factory=lambda: np.zeros(0, dtype=int))

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
        return self.valid and self.epsilon > JUDGING.epsilon_threshold


def _noisy_pose(scene: Scene, grid_pose: np.ndarray, noise: Noise, rng: np.random.Generator,
                tries: int = 20) -> np.ndarray:
    """The grid pose plus position and yaw noise, redrawn while it would put the object inside the open hand."""
    if noise.position == 0.0 and noise.yaw == 0.0:
        return grid_pose
    for _ in range(tries):
        pose = grid_pose + np.array([rng.normal(0, noise.position), rng.normal(0, noise.position), 0.0,
                                     rng.normal(0, noise.yaw)])
        if clearance(scene, pose) >= START_CLEARANCE:
            return pose
    return grid_pose


def trial_scene(setup: TrialSetup, grid_pose: np.ndarray, rng: np.random.Generator, initial: np.ndarray) -> Scene:
    """The scene of a trial at its start: the object at the grid pose (moved by the pose noise) on its
    support (`judge.supported_scene`), and the open hand at rest in `initial`."""
    scene = supported_scene(setup.object, setup.table, setup.hand)
    true_pose = _noisy_pose(scene, np.asarray(grid_pose, dtype=float), setup.noise, rng)
    scene.set_hand_pose(*palm_pose_for(setup.object, true_pose))
    scene.set_posture(initial)
    return scene


def run_trial(setup: TrialSetup, grid_pose: np.ndarray, rng: np.random.Generator,
              observer: Callable[[Scene], None] | None = None) -> Trial:
    """Place the object, let the controller grasp it, judge the grasp (epsilon, hold, margin).

    The object is held by a spring support with gravity off, or (`setup.table`) stands on a table
    with gravity on while the hand closes. `observer(scene)` is called after the start and after
    every control period, the judging included (`record_trial` keeps the states it sees)."""
    controller = setup.controller()
    noise = setup.noise
    scene = trial_scene(setup, grid_pose, rng, controller.initial)
    period = controller.params.control_period
    if observer is not None:
        observer(scene)

    def cycle() -> None:
        sensed = scene.posture() + rng.normal(0.0, noise.joints, N_FINGER_JOINTS) if noise.joints else scene.posture()
        scene.set_target(controller.step(sensed, scene.sensor.segment_forces(scene.data)))
        if controller.params.reach > 0:  # the arm carries the palm where the recalled grasp wants it
            scene.shift_hand(controller.palm_offset)
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
                     float(scene.time), controller.matches, 0.0, scene.max_penetration, str(error),
                     np.array(controller.winners, dtype=int))
    return Trial(grid_pose, posture, np.array([reading.touches(s) for s in SEGMENTS]),
                 judgement.epsilon, judgement.hold, judgement.displacement, float(controller.time_to_grasp),
                 controller.matches, judgement.margin, scene.max_penetration, winners=np.array(controller.winners, dtype=int))


@dataclass
class Recording:
    """A trial with the scene's state every `period` seconds, for pictures and animations."""

    trial: Trial
    scene: Scene
    states: np.ndarray  # (k, len(Scene.state()))
    period: float

    def frames(self, camera: str = "hand", width: int = 320, height: int = 240) -> np.ndarray:
        """Pictures of every recorded state from a named camera.

        Args:
            camera: one of `scene.CAMERAS`, or `render.THUMB_SIDE`.
            width: pixels.
            height: pixels.

        Returns:
            (k, height, width, 3) uint8.
        """
        from ..sim.render import render_states

        return render_states(self.scene, self.states, camera, width, height)

    def save_gif(self, path: str | os.PathLike, camera: str = "hand", width: int = 320, height: int = 240,
                 speed: float = 1.0) -> Path:
        """An animated GIF of the trial.

        Args:
            path: the file, ending in .gif.
            camera: one of `scene.CAMERAS`, or `render.THUMB_SIDE`.
            width: pixels.
            height: pixels.
            speed: times real time.

        Returns:
            The path written.
        """
        from ..sim.render import save_animation

        return save_animation(self.frames(camera, width, height), path, fps=speed / self.period)


def record_trial(obj: str | GraspObject, experience: Experience | None = None,
                 grid_pose: Iterable[float] = (0.0, 0.0, 0.01, 0.0), seed: int = 0, *, every: int = 2,
                 noise: Noise | None = None, params: ControllerParams | None = None, table: bool = False,
                 preshape: np.ndarray | None = None, hand: str | HandModel = "ours") -> Recording:
    """Run one trial as `evaluate` would at a grid pose and keep the scene's state along the way.

    `record_trial("box").save_gif("grasp.gif")` animates it; `recording.scene.render()` draws its final state.

    Args:
        obj: the object, or its name.
        experience: the experience base (None: the plain tactile controller), as `evaluate` takes it.
        grid_pose: (x, z, gap, yaw) in m and rad; refused as `evaluate` refuses it (`why_unreachable` says why).
        seed: the trial's seed (trial 0 of `evaluate` with this seed).
        every: keep the state every this many control periods.
        noise: pose and joint noise (`Noise`).
        params: controller parameters.
        table: the object stands on a table with gravity on.
        preshape: a constant phase-B posture (22,), rad.
        hand: the hand model, or its name.

    Returns:
        The recording: the trial's outcome, its scene and the kept states.
    """
    obj = get_object(obj)
    check_int(every, "every (control periods)")
    grid_pose = np.asarray(tuple(grid_pose), dtype=float)
    if grid_pose.shape != (4,) or not np.all(np.isfinite(grid_pose)):
        raise InvalidInput(f"grid_pose must be four finite numbers (x, z, gap, yaw), got {grid_pose!r}")
    check_grid(grid_pose, obj, table)  # the poses `evaluate` would refuse are refused here too
    states: list[np.ndarray] = []
    seen: dict[str, Scene] = {}

    def observe(scene: Scene) -> None:
        seen["scene"] = scene  # the trial's one scene
        if not states or round(scene.time / period) % every == 0:
            states.append(scene.state())

    setup = TrialSetup(obj, experience, noise or Noise(), params or ControllerParams(), table, preshape, hand=hand)
    period = setup.params.control_period
    trial = run_trial(setup, grid_pose, np.random.default_rng([seed, 0]), observer=observe)
    return Recording(trial, seen["scene"], np.array(states), every * period)


