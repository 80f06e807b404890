"""The tactile grasp task as a Gymnasium environment: one world (`TactileGraspEnv`) or N at once
(`TactileGraspVectorEnv`, over the library's batched worlds).

An episode is one grasp trial, as `evaluate` runs it: the object at a grid pose (drawn from the grid with the
episode's seed, or given: `reset(options={"pose": ...})`) on its support in front of the open hand. Every step is
one control period (`control_period`, 20 ms): the action sets the hand's 22 finger joint targets (rad, the
controller's interface; clipped to the hand's ranges) and says whether the grasp is done (its last element, done
from 0.5); the observation is what a tactile hand senses, the 22 joint angles (rad) and the normal force on each
tactile segment (N, `SEGMENTS` order), and, with `pcp=True`, the Partial Contact Posture's mask (22: 1 for a joint
of a touching segment, Eq. 1). With `palm` (the hand on an arm's flange, `sim.flange`; the lift protocol brings
one), the action has six more elements after the joint targets, the palm's targets from where the episode placed it
(m along the palm's x, y, z, rad about them; reached at the flange's bounded speeds, `Scene.steer_flange`), and the
observation ends with where the flange is (the same six). Once the grasp is done (or after `max_seconds`) the
library's judge runs it through the protocol named (`protocols.PROTOCOLS`: our hold test by default): the episode
terminates, the reward is 1 for a grasp that holds and 0 otherwise (sparse), and `info` carries the judgement (hold,
force closure, epsilon, the displacement, a physics fault). A trial whose physics fails terminates with reward 0 and
the fault in `info`. A step after the episode ended, before `reset`, is refused (`EpisodeEnded`, Gymnasium's
`ResetNeeded`: the grasp was judged and paid once); the vector environment starts the world's next episode instead
(Gymnasium's next-step autoreset). Actions, `reset`'s options and the constructor's arguments are checked before
anything runs.

The done flag ends the episode from 0.5: a random agent (`action_space.sample()`) sets it in half its steps, so its
episodes end after two steps on average, before any finger reaches the object. Explore with the flag held at 0 (or
below 0.5) and let `max_seconds` end the episode, or set it once the hand has closed.

Our controller drives it as the trials do: `BatchController(1, experience)`'s targets and its `done` each step give
the episode `evaluate` reports on the same pose (a test). `render_mode="rgb_array"` draws the scene offscreen.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..base.errors import GraspManifoldError, InvalidInput
from ..base.validation import Bounds, check_choice, check_int, check_number
from ..judging.judge import Judgement
from ..sim.flange import FlangeLimits
from ..sim.grip import CONTROL_PERIOD
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS
from ..sim.objects import GraspObject
from ..sim.posture import pcp_masks
from ..sim.render import THUMB_SIDE
from ..sim.scene import CAMERAS, Scene
from ..sim.worlds import CpuWorlds
from ..trials.grid import check_grid
from ..trials.episode import EpisodeWorlds, trial_scene
from ..trials.setup import TrialSetup

#: s of a grasp after which it is judged as it is, done or not
MAX_SECONDS = 10.0
#: the cameras `render` draws from
RENDER_CAMERAS = (*CAMERAS, THUMB_SIDE)


class EpisodeEnded(GraspManifoldError, gymnasium.error.ResetNeeded):
    """`step` after the episode ended (terminated or truncated) and before `reset`: the grasp was judged and paid
    once; a step more would judge the disturbed grasp again and pay again. Gymnasium leaves such a step undefined;
    ours refuses it (a `gymnasium.error.ResetNeeded`)."""


def _check_options(options: object, known: tuple[str, ...]) -> dict:
    """`reset`'s options as a dict with only the keys known."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise InvalidInput(f"options must be a dict (keys {list(known)}) or None, got {type(options).__name__}")
    unknown = sorted(map(str, set(options) - set(known)))
    if unknown:
        raise InvalidInput(f"unknown reset option(s) {unknown}; the options are {list(known)}")
    return options


def _check_poses(poses: object, count: int, name: str) -> np.ndarray:
    """`count` grid poses (x, z, gap, yaw), as (count, 4) floats; a single pose may be given as (4,)."""
    rows = np.asarray(poses)
    if rows.dtype.kind not in "iuf":
        raise InvalidInput(f"{name} must be real numbers (x, z, gap in m, yaw in rad), got an array of {rows.dtype}")
    if rows.shape not in ((count, 4),) + (((4,),) if count == 1 else ()):
        raise InvalidInput(f"{name} must have shape {'(4,) or ' if count == 1 else ''}({count}, 4): "
                           f"{'a pose' if count == 1 else 'one pose per world'} (x, z, gap in m, yaw in rad), got "
                           f"shape {rows.shape}")
    return rows.astype(float).reshape(count, 4)


#: the `TrialSetup` fields an episode runs (the agent is its controller): what an environment takes by name
EPISODE_FIELDS = ("object", "hand", "protocol", "noise", "table", "touch", "palm")


def episode_setup(setup: str | GraspObject | TrialSetup = "cylinder", **fields: object) -> TrialSetup:
    """What an episode is: a `TrialSetup` given whole, or the object with the fields an episode runs by name
    (`EPISODE_FIELDS`; `palm=True` is the default flange, False none).

    Args:
        setup: a `TrialSetup`, or the object (or its name).
        **fields: `EPISODE_FIELDS` by name (not beside a whole set-up).

    Returns:
        The set-up.

    Raises:
        InvalidInput: a field an episode does not run, a flag that is not True or False, or a set-up whose
            controller is not the agent (an experience, a controller, a regrasp, a plan, another backend).
    """
    unknown = sorted(set(fields) - set(EPISODE_FIELDS))
    if unknown:
        raise InvalidInput(f"unknown argument(s) {unknown}; an episode takes a TrialSetup or {list(EPISODE_FIELDS)}")
    if "object" in fields:
        if not isinstance(setup, str) or setup != "cylinder":
            raise InvalidInput("give the object once: as the set-up (the first argument) or as object=")
        setup = fields.pop("object")  # type: ignore[assignment]
    palm = fields.get("palm", False)
    if not isinstance(palm, (bool, FlangeLimits)):
        raise InvalidInput(f"palm must be True, False or a FlangeLimits, got {palm!r}")
    palm_off = "palm" in fields and palm is False  # said so: a protocol that brings a flange contradicts it
    if "palm" in fields:
        fields["palm"] = FlangeLimits() if palm is True else palm or None
    if not isinstance(fields.get("table", False), (bool, np.bool_)):  # table="no" ran with the table
        raise InvalidInput(f"table must be True or False, got {fields['table']!r}")
    built = TrialSetup.build(setup, None, **fields)  # an agent's episode recalls no experience
    if palm_off and built.palm is not None:
        raise InvalidInput(f"palm=False, but the {built.protocol.name!r} protocol moves the palm on an arm's flange: "
                           "leave palm out (or give palm=True, or a FlangeLimits) to run it")
    agent_only = {"experience": built.experience is None, "controller": built.controller is None,
                  "preshape": built.preshape is None, "regrasp": built.regrasp.attempts == 1,
                  "plan": built.plan is None, "oracle": not built.oracle, "backend": built.backend == "cpu"}
    theirs = sorted(name for name, fine in agent_only.items() if not fine)
    if theirs:
        raise InvalidInput(f"an episode's controller is the agent: the set-up's {theirs} are a trial's, not an "
                           "episode's (leave them at their defaults)")
    return built


class _GraspWorlds:
    """The task over N worlds (the one mechanism both environments run): their scenes, their clocks, one control
    period of all, the judging of those done."""

    def __init__(self, n: int, setup: TrialSetup, grid: object, pcp: bool, max_seconds: float):
        if not isinstance(pcp, (bool, np.bool_)):
            raise InvalidInput(f"pcp must be True or False, got {pcp!r}")
        max_seconds = check_number(max_seconds, "max_seconds", Bounds(0.0, 600.0, above_low=True, unit="s"))
        self.setup = setup
        self.palm = self.setup.palm  # the flange's limits, or None
        self.hand = self.setup.hand
        self.poses = check_grid(grid, self.setup.object, self.setup.table)[1]
        self.n, self.pcp, self.max_seconds = n, pcp, float(max_seconds)
        self.period = CONTROL_PERIOD
        self.initial = self.hand.keyframe_posture("open")
        self.limits = self.hand.limits()
        self.scenes: list[Scene | None] = [None] * n
        self.clock = np.zeros(n)
        self.pose = np.zeros((n, 4))  # each episode's grid pose
        self.ended = np.ones(n, dtype=bool)  # each world's episode is over (judged), or not begun
        self.rngs = [seeding.np_random(None)[0] for _ in range(n)]

    @property
    def observation_space(self) -> spaces.Box:
        size = N_FINGER_JOINTS + len(SEGMENTS) + (N_FINGER_JOINTS if self.pcp else 0)
        low = np.concatenate([np.full(N_FINGER_JOINTS, -math.pi), np.zeros(size - N_FINGER_JOINTS)])
        high = np.concatenate([np.full(N_FINGER_JOINTS, math.pi), np.full(len(SEGMENTS), np.inf),
                               np.ones(size - N_FINGER_JOINTS - len(SEGMENTS))])
        if self.palm is not None:  # where the flange is: anywhere its servos can be pushed
            low, high = np.append(low, np.full(6, -np.inf)), np.append(high, np.full(6, np.inf))
        return spaces.Box(low, high, dtype=np.float64)

    @property
    def palm_reach(self) -> np.ndarray:
        """(6,) the largest palm target each way: the flange's travel (m) and turn (rad); empty without a palm."""
        if self.palm is None:
            return np.zeros(0)
        return np.array([self.palm.travel] * 3 + [self.palm.turn] * 3)

    @property
    def action_space(self) -> spaces.Box:
        reach = self.palm_reach
        return spaces.Box(np.concatenate([self.limits[:, 0], -reach, [0.0]]),
                          np.concatenate([self.limits[:, 1], reach, [1.0]]), dtype=np.float64)

    def reset(self, worlds: list[int], seeds: list[int | None], poses: list[np.ndarray | None]) -> None:
        """New episodes in these worlds: each its random stream (reseeded where a seed is given), its pose (drawn
        from the grid where none is given), its scene."""
        for world, seed, pose in zip(worlds, seeds, poses):
            if seed is not None:
                self.rngs[world] = seeding.np_random(seed)[0]
            rng = self.rngs[world]
            pose = self.poses[rng.integers(len(self.poses))] if pose is None else \
                check_grid(np.asarray(pose, dtype=float), self.setup.object, self.setup.table)[1][0]
            self.pose[world] = pose
            self.scenes[world] = trial_scene(self.setup, pose, rng, self.initial)
            self.clock[world] = 0.0
            self.ended[world] = False

    def observe(self, worlds: np.ndarray) -> np.ndarray:
        """(len(worlds), observation size): joints, segment forces, the PCP's mask."""
        cpu = CpuWorlds([self.scenes[w] for w in worlds])
        index = np.arange(len(worlds))
        joints, forces = cpu.joints(index), cpu.segment_forces(index)
        parts = [joints, forces] + ([pcp_masks(forces > 0).astype(float)] if self.pcp else []) + \
            ([cpu.flanges(index)] if self.palm is not None else [])
        return np.concatenate(parts, axis=1)

    def check_actions(self, actions: np.ndarray) -> np.ndarray:
        """Actions of m worlds as (m, action size) finite floats; a clear error otherwise.

        Args:
            actions: (m, action size).

        Returns:
            The actions as floats.
        """
        actions = np.asarray(actions)
        size = N_FINGER_JOINTS + len(self.palm_reach) + 1
        what = ("the 22 joint targets (rad), " + ("the palm's 6 targets (m, rad), " if len(self.palm_reach) else "")
                + "the done flag (done from 0.5)")
        if actions.dtype.kind not in "iuf" or actions.ndim != 2 or actions.shape[1] != size:
            # a complex action lost its imaginary part with a warning; 22 numbers ended in NumPy's reshape error
            shape = actions.shape[1:] if actions.ndim == 2 and len(actions) == 1 else actions.shape
            raise InvalidInput(f"an action must be {size} real numbers: {what}; got an array of {actions.dtype} of "
                               f"shape {shape}")
        actions = actions.astype(float)
        if not np.all(np.isfinite(actions)):
            raise InvalidInput(f"actions must be finite: {what}")
        return actions

    def act(self, worlds: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, list[dict]]:
        """One control period of these worlds under their actions, then the judging of those whose grasp is done
        (their episodes end: `ended`).

        Args:
            worlds: (m,) the worlds' indices.
            actions: (m, action size), as `check_actions` takes them.

        Returns:
            (len(worlds),) rewards and one info dict per world (a judged one's holds its judgement; `judged` says
            which were).
        """
        palm = len(self.palm_reach)
        actions = self.check_actions(actions)
        acting = EpisodeWorlds(self.setup, CpuWorlds([self.scenes[w] for w in worlds]), self.period)
        index = np.arange(len(worlds))
        acting.act(index, np.clip(actions[:, :N_FINGER_JOINTS], self.limits[:, 0], self.limits[:, 1]),
                   actions[:, N_FINGER_JOINTS:N_FINGER_JOINTS + palm] if palm else None)
        failed = acting.physics(index)
        self.clock[worlds] += self.period
        done = (actions[:, -1] >= 0.5) | (self.clock[worlds] >= self.max_seconds - 1e-9)
        rewards = np.zeros(len(worlds))
        infos: list[dict[str, object]] = [{"time": float(self.clock[w]), "judged": False} for w in worlds]
        for k, why in failed.items():
            infos[k].update(judged=True, hold=False, force_closure=False, fault=why)
        self.ended[worlds[list(failed)]] = True
        judging = np.flatnonzero(done & ~np.isin(index, list(failed)))
        self.ended[worlds[judging]] = True
        if len(judging):
            judged = EpisodeWorlds(self.setup, CpuWorlds([self.scenes[worlds[k]] for k in judging]), self.period)
            for k, judgement in zip(judging.tolist(), judged.judge()):
                rewards[k] = float(judgement.hold and not judgement.fault)
                infos[k].update(self._judged(judgement))
        return rewards, infos

    def _judged(self, judgement: Judgement) -> dict:
        return {"judged": True, "hold": bool(judgement.hold and not judgement.fault),
                "force_closure": bool(not judgement.fault and judgement.epsilon > self.setup.rules.epsilon_threshold),
                "epsilon": float(judgement.epsilon), "displacement": float(judgement.displacement),
                "fault": judgement.fault}

    def render(self, world: int, camera: str, width: int, height: int) -> np.ndarray:
        from ..sim.render import render_states

        scene = self.scenes[world]
        if scene is None:
            raise InvalidInput(f"world {world} has no episode to draw yet: reset it first")
        return render_states(scene, scene.state()[None], camera, width, height)[0]


class TactileGraspEnv(gymnasium.Env):
    """The tactile grasp task in one world (see the module doc).

    Args:
        setup: what an episode is: a `TrialSetup` (its object, hand, protocol, noise, table, touch and palm; the agent
            is the controller), or the object or its name, the other fields by name (`**fields`).
        grid: the grid poses episodes draw from (a preset name or an (n, 4) array, m and rad).
        pcp: add the Partial Contact Posture's mask to the observation.
        max_seconds: s after which a grasp is judged as it is.
        render_mode: None or 'rgb_array'.
        camera: the camera `render` draws from (`scene.CAMERAS`).
        **fields: `EPISODE_FIELDS` by name beside an object: hand (a model or its name), protocol (how a grasp is
            judged: a `protocols.PROTOCOLS` name or a `JudgingProtocol`), noise (the object's pose noise, `Noise`;
            joint noise is the agent's own business), table (the object on a table with gravity on; False: a
            spring support, gravity off), touch (where the observed segment forces come from, `scene.TOUCH_SOURCES`),
            palm (the hand on an arm's flange, True: `FlangeLimits()`, or the limits: the action's six palm targets
            and the observation's six flange positions; False: the palm stays where it was placed).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, setup: str | GraspObject | TrialSetup = "cylinder", grid: object = "quick", pcp: bool = False,
                 max_seconds: float = MAX_SECONDS, render_mode: str | None = None, camera: str = "hand",
                 **fields: object):
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InvalidInput(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        check_choice(camera, RENDER_CAMERAS, "camera")  # 'bogus' was refused only at render()
        self.task = _GraspWorlds(1, episode_setup(setup, **fields), grid, pcp, max_seconds)
        self.observation_space = self.task.observation_space
        self.action_space = self.task.action_space
        self.render_mode, self.camera = render_mode, camera
        self.control_period = self.task.period

    @property
    def scene(self) -> Scene | None:
        """The episode's scene (None before the first reset)."""
        return self.task.scenes[0]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """A new grasp: the object at a grid pose (`options["pose"]`, or drawn with the episode's seed).

        Args:
            seed: the episode's seed (None: the stream goes on).
            options: {"pose": (x, z, gap, yaw)} in m and rad, or None.

        Returns:
            (the first observation, {"pose": the grid pose}).
        """
        super().reset(seed=seed)
        pose = _check_options(options, ("pose",)).get("pose")
        self.task.reset([0], [seed], [None if pose is None else _check_poses(pose, 1, 'options["pose"]')[0]])
        return self.task.observe(np.array([0]))[0], {"pose": self.task.pose[0].copy()}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """One control period.

        Args:
            action: (23,): the 22 finger joint targets (rad) and the done flag (the grasp is judged from 0.5); with
                a palm (29,): the six palm targets between them (m, rad from where the episode placed it).

        Returns:
            (observation, reward, terminated, truncated, info): reward 1 for a grasp judged to hold.
        """
        if self.scene is None:
            raise EpisodeEnded("call reset() before step()")
        if self.task.ended[0]:
            raise EpisodeEnded("the episode ended (its grasp was judged): call reset() before step()")
        rewards, infos = self.task.act(np.array([0]), np.asarray(action)[None])
        return self.task.observe(np.array([0]))[0], float(rewards[0]), infos[0]["judged"], False, infos[0]

    def render(self) -> np.ndarray | None:
        """The scene now from `camera`, (240, 320, 3) uint8 (None without render_mode='rgb_array')."""
        if self.render_mode != "rgb_array" or self.scene is None:
            return None
        return self.task.render(0, self.camera, 320, 240)


class TactileGraspVectorEnv(VectorEnv):
    """The tactile grasp task in N worlds at once (see the module doc), Gymnasium's vector interface: actions (N, 23),
    observations (N, size); a world whose episode ended starts a new one at the next step (Gymnasium's next-step
    autoreset). World i of `reset(seed=s)` runs the episode of `TactileGraspEnv().reset(seed=s + i)`.

    Args:
        num_envs: worlds.
        **kwargs: as `TactileGraspEnv` takes them (render_mode and camera aside): setup, grid, pcp, max_seconds and
            `EPISODE_FIELDS`.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 4, **kwargs: Any):
        self.num_envs = check_int(num_envs, "num_envs")
        if kwargs.pop("render_mode", None) is not None or kwargs.pop("camera", None) is not None:
            raise InvalidInput("TactileGraspVectorEnv does not render: give no render_mode or camera (render one world "
                               "with TactileGraspEnv)")
        task = {name: kwargs.pop(name) for name in ("grid", "pcp", "max_seconds") if name in kwargs}
        setup = episode_setup(kwargs.pop("setup", "cylinder"), **kwargs)
        self.task = _GraspWorlds(self.num_envs, setup, task.get("grid", "quick"), task.get("pcp", False),
                                 task.get("max_seconds", MAX_SECONDS))
        self.single_observation_space = self.task.observation_space
        self.single_action_space = self.task.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.control_period = self.task.period

    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """New grasps in every world: world i seeded `seed + i` (or `seed[i]`), its pose `options["poses"][i]` or drawn.

        Args:
            seed: an int, one per world, or None.
            options: {"poses": (N, 4)} in m and rad, or None.

        Returns:
            (observations (N, size), {"pose": (N, 4) the grid poses}).
        """
        seeds: list[int | None] = [None] * self.num_envs if seed is None else \
            list(seed) if isinstance(seed, (list, tuple)) else [int(seed) + i for i in range(self.num_envs)]
        poses = _check_options(options, ("poses",)).get("poses")
        given: list[np.ndarray | None] = [None] * self.num_envs if poses is None else \
            list(_check_poses(poses, self.num_envs, 'options["poses"]'))
        if len(seeds) != self.num_envs or len(given) != self.num_envs:
            raise InvalidInput(f"reset takes one seed and one pose per world ({self.num_envs})")
        worlds = list(range(self.num_envs))
        self.task.reset(worlds, seeds, given)
        return self.task.observe(np.arange(self.num_envs)), {"pose": self.task.pose.copy()}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        """One control period of every world (a world whose episode ended starts its next one instead).

        Args:
            actions: (N, 23): each world's 22 finger joint targets (rad) and done flag; with a palm (N, 29), its
                six palm targets between them.

        Returns:
            (observations, rewards, terminated, truncated, infos), each over the N worlds; infos as Gymnasium's
            vector environments give them ({key: (N,) values, "_key": where set}).
        """
        actions = np.asarray(actions)
        if self.task.scenes[0] is None:
            raise EpisodeEnded("call reset() before step()")
        restarting = np.flatnonzero(self.task.ended)
        acting = np.flatnonzero(~self.task.ended)
        if actions.shape != self.action_space.shape:  # a (4, 2) array of a (2, 4) environment is refused
            raise InvalidInput(f"actions must have shape {self.action_space.shape}, got {actions.shape}")
        actions = self.task.check_actions(actions[acting]) if len(acting) else actions  # before any restart
        if len(restarting):
            self.task.reset(list(restarting), [None] * len(restarting), [None] * len(restarting))
        rewards, terminated = np.zeros(self.num_envs), np.zeros(self.num_envs, dtype=bool)
        infos: dict = {}
        if len(acting):
            rewarded, per_world = self.task.act(acting, actions)
            rewards[acting] = rewarded
            terminated[acting] = [info["judged"] for info in per_world]
            infos = vector_infos(per_world, acting, self.num_envs)
        return (self.task.observe(np.arange(self.num_envs)), rewards, terminated,
                np.zeros(self.num_envs, dtype=bool), infos)


def vector_infos(infos: list[dict], worlds: np.ndarray, n: int) -> dict:
    """Gymnasium's layout of a vector environment's infos: each key an (n,) array over the worlds, and `_key` a
    mask of the worlds whose info holds it.

    Args:
        infos: one flat info dict per world that acted.
        worlds: (len(infos),) the indices of those worlds.
        n: how many worlds the vector environment has.

    Returns:
        The batched infos.
    """
    batched: dict = {}
    for info, world in zip(infos, worlds):
        for key, value in info.items():
            if key not in batched:
                numeric = isinstance(value, (bool, int, float, np.number))
                batched[key] = np.zeros(n, dtype=type(value)) if numeric else np.full(n, None, dtype=object)
                batched[f"_{key}"] = np.zeros(n, dtype=bool)
            batched[key][world] = value
            batched[f"_{key}"][world] = True
    return batched
