"""Grasp trials: place the object at a grid pose, let the controller close the hand, judge the grasp.

A trial puts a free object (gravity off) in front of the open hand at one grid pose (`grid.py`),
runs the controller until it reports the grasp done, and then judges the grasp (`judge.episode_loop`:
the hold test in six gravity directions, epsilon for force closure, and the disturbance margin where
`TrialSetup.margin` asks for it).
`run_trials` is the one trial loop: N grid poses at once, one controller for all (`BatchController`, or
a user's own `Controller`) and one `Worlds` for the physics (`CpuWorlds`, or `WarpWorlds` on a GPU).
While the hand closes, a stiff spring-damper support keeps the object near its place (as a table or
a helper's hand would; without it the first touch would push a weightless object away); it is
released before judging. Optional noise perturbs the true object pose around the grid pose (the
paper's "vague object position"; a draw that would start inside the open hand is redrawn) and the
joint angles the controller senses.

A trial whose physics failed (`Scene.check`: a MuJoCo warning, a non-finite state, or a contact
deeper than `scene.PENETRATION_LIMIT`) is kept but marked invalid with the reason (`Trial.fault`):
it counts as neither a success nor a failure of the controller. `record_trial` runs one trial and
keeps its states for pictures and animations.

The episode's pieces: where a trial starts (`trial_scene`, one scene per trial; `trial_starts`, all of them as
arrays), its worlds on the set-up's backend (`start_worlds`), the loop (`run_trials`; `EpisodeWorlds`, the episodes'
worlds it and the Gymnasium environments share, run by `judge.episode_loop`) and the flange's set points of moved palms (`flange_targets`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import cast

import numpy as np
from scipy.spatial.transform import Rotation

from ..base.errors import InvalidInput
from ..base.moved import moved_attribute
from ..base.validation import check_data
from ..control.controller import BatchController, declared_readouts
from ..control.regrasp import LiftProbe, RestartingController
from ..judging.judge import Judgement, episode_loop, supported_scene
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS
from ..sim.scene import Scene
from ..sim.worlds import CpuWorlds, Worlds, WorldStarts
from .grid import START_CLEARANCE, clearance, displaced_palm_pose, oracle_correction, palm_pose_for, palm_poses_for
from .record import FIRST_CONTACT_FEATURES, Trial
from .setup import Noise, TrialSetup


#: s of simulated time after which a world whose controller never reports its grasp done is judged as it is
MAX_GRASP_SECONDS = 600.0
#: s the oracle's correction waits, after its flange's set point has arrived, for the servos to bring the palm there
ORACLE_SETTLE_SECONDS = 0.2


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


def _setup_scene(setup: TrialSetup) -> Scene:
    """The scene of a set-up before a trial is placed in it: the object on its support (`judge.supported_scene`),
    under the protocol's physics (the grasp is made under it too)."""
    scene = supported_scene(setup.object, setup.table, setup.hand, setup.touch, setup.rules, setup.palm)
    setup.protocol.apply(scene)
    return scene


def _place(scene: Scene, setup: TrialSetup, grid_pose: np.ndarray, rng: np.random.Generator,
           initial: np.ndarray) -> None:
    """A trial's start in the scene: the object at the grid pose (moved by the pose noise), the open hand at rest in
    `initial`; with a plan, the hand in the plan's pregrasp for the nominal object and the object displaced by
    `grid_pose` (`TrialSetup.plan`)."""
    if setup.plan is not None:  # the palm where the plan puts it for the nominal pose; the object displaced
        scene.set_posture(setup.plan.postures[0])
        scene.set_hand_pose(*displaced_palm_pose(setup.plan.poses[0], np.asarray(grid_pose, dtype=float)))
        return
    true_pose = _noisy_pose(scene, np.asarray(grid_pose, dtype=float), setup.noise, rng)
    scene.set_hand_pose(*palm_pose_for(setup.object, true_pose))
    scene.set_posture(initial)


def trial_scene(setup: TrialSetup, grid_pose: np.ndarray, rng: np.random.Generator, initial: np.ndarray) -> Scene:
    """The scene of a trial at its start: the object at the grid pose (moved by the pose noise) on its
    support (`judge.supported_scene`), and the open hand at rest in `initial`; with a plan, the hand in the plan's
    pregrasp for the nominal object and the object displaced by `grid_pose` (`TrialSetup.plan`).

    Args:
        setup: what the trial is.
        grid_pose: (4,) x, z, gap in m, yaw in rad.
        rng: the trial's random stream (its pose noise).
        initial: (22,) rad, the hand's posture at the start.

    Returns:
        A scene of its own, placed.
    """
    scene = _setup_scene(setup)
    _place(scene, setup, grid_pose, rng, initial)
    return scene


def trial_starts(setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
                 initial: np.ndarray) -> tuple[Scene, WorldStarts]:
    """The starts of trials at these poses without a scene per trial: one scene, and what differs between the
    trials worked out for all of them at once (the palms' poses and the hand mounts', in array arithmetic; the
    posture at rest is every trial's). The pose noise is drawn from the same streams as `trial_scene` draws it
    (a redraw's clearance is still one query of the scene per noisy pose). Equal to `trial_scene`'s but for the
    last bits of the mounts' poses.

    Args:
        setup: what the trials are (no flange: its palm placement is a scene's).
        poses: (n, 4) grid poses.
        rngs: one random stream per pose.
        initial: (22,) rad, the hand's posture at the start.

    Returns:
        The scene (its model is every world's) and the worlds' starts (`worlds.WorldStarts`).
    """
    if setup.palm is not None:
        raise InvalidInput("trial_starts places hands without a flange: a flanged palm is placed per scene "
                           "(trial_scene)")
    poses = _checked_poses(poses, rngs)
    scene = _setup_scene(setup)
    if setup.plan is not None:  # the plan's pregrasp for the nominal object, the object displaced
        palm = np.array([np.concatenate(displaced_palm_pose(setup.plan.poses[0], pose)) for pose in poses])
        scene.set_posture(setup.plan.postures[0])
    else:
        if setup.noise.position or setup.noise.yaw:  # a redraw's clearance is asked of a scene of its own
            probe = _setup_scene(setup)
            poses = np.array([_noisy_pose(probe, pose, setup.noise, rng) for pose, rng in zip(poses, rngs)])
        palm = np.column_stack(palm_poses_for(setup.object, poses))
    mount_pos, mount_quat = scene.mount_poses_for(palm[:, :3], palm[:, 3:])
    if setup.plan is None:
        scene.set_posture(initial)
    n, data = len(poses), scene.data
    mocap_pos, mocap_quat = np.tile(data.mocap_pos, (n, 1, 1)), np.tile(data.mocap_quat, (n, 1, 1))
    mocap_pos[:, scene.mount_id], mocap_quat[:, scene.mount_id] = mount_pos, mount_quat
    return scene, WorldStarts(np.tile(data.qpos, (n, 1)), np.tile(data.ctrl, (n, 1)), mocap_pos, mocap_quat)


def _checked_poses(poses: object, rngs: Sequence[np.random.Generator]) -> np.ndarray:
    """Grid poses (n, 4) of finite real numbers, with one random stream each."""
    given = np.asarray(poses)
    checked = np.zeros((0, 4)) if given.shape in ((0,), (0, 4)) else check_data(given, 4, "poses")
    if len(rngs) != len(checked):
        raise InvalidInput(f"rngs must be one random stream per pose: {len(checked)} poses, got {len(rngs)} streams")
    return checked


def start_worlds(setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
                 initial: np.ndarray) -> Worlds:
    """The worlds of trials at these poses on the set-up's backend: a scene per trial on the CPU (`CpuWorlds`), one
    model and the trials' starts as arrays on MuJoCo Warp (`WarpWorlds`: the set-up does not grow with the worlds).

    Args:
        setup: what the trials are.
        poses: (n, 4) grid poses.
        rngs: one random stream per pose.
        initial: (22,) rad, the hand's posture at the start.

    Returns:
        The worlds, placed.
    """
    poses = _checked_poses(poses, rngs)
    if setup.backend == "cpu":
        return CpuWorlds([trial_scene(setup, pose, rng, initial) for pose, rng in zip(poses, rngs)])
    from ..sim.warp_worlds import WarpWorlds

    return WarpWorlds(*trial_starts(setup, poses, rngs, initial))


def run_trials(setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
               observer: Callable[[Worlds], None] | None = None) -> list[Trial]:
    """One trial per grid pose (n, 4), all at once: place the objects, let the controller grasp them, judge the grasps.

    Every world runs on its own clock of control periods: its controller acts until it reports the grasp
    done, then its judging begins (`judge.episode_loop`) while the other worlds go on grasping. Trial i
    draws its noise from `rngs[i]`; `observer(worlds)` is called after the start and after every control
    period, the judging included (`record_trial` keeps the states it sees).

    Args:
        setup: what a trial is.
        poses: (n, 4) grid poses (x, z, gap in m, yaw in rad).
        rngs: one random generator per pose.
        observer: called with the worlds after the start and after every control period.

    Returns:
        One `Trial` per pose, in order.
    """
    loop = _TrialLoop(setup, np.asarray(poses, dtype=float), rngs, observer)
    if observer is not None:
        observer(loop.worlds)
    judgements = loop.episodes.judge(loop.advance, loop.ready)
    return [loop.trial(world, judged) for world, judged in enumerate(judgements)]


class EpisodeWorlds:
    """The worlds of trials' episodes on one clock of control periods: the scenes a `TrialSetup` made (on its
    backend), one control period of physics under the targets given, and the episode loop (`judge.episode_loop`: the
    grasp, then the set-up's judging with the object's friction) that runs them to their judgement. `run_trials` drives it with a controller, the
    Gymnasium environments (`envs.tactile_grasp`) with an agent's actions.

    Args:
        setup: what the trials are.
        worlds: their worlds, placed (`start_worlds`).
        period: s of one control period.
    """

    def __init__(self, setup: TrialSetup, worlds: Worlds, period: float):
        self.setup, self.period, self.worlds = setup, period, worlds
        #: physics steps of one control period
        self.nstep = max(1, round(period / worlds.scene.model.opt.timestep))

    def act(self, live: np.ndarray, targets: np.ndarray, palm: np.ndarray | None = None) -> None:
        """Set these worlds' finger targets (and their flanges' set points) for the next control period.

        Args:
            live: (m,) the worlds' indices.
            targets: (m, 22) joint targets, rad.
            palm: (m, 6) flange set points (m, rad), or None: the palms stay.
        """
        self.worlds.set_targets(live, targets)
        if palm is not None:
            self.worlds.steer_flanges(live, palm, self.period)

    def physics(self, live: np.ndarray) -> dict[int, str]:
        """One control period of physics of these worlds.

        Args:
            live: (m,) the worlds' indices.

        Returns:
            {world: why} for the worlds whose physics failed.
        """
        return self.worlds.step(live, self.nstep)

    def judge(self, advance: Callable[[np.ndarray], dict[int, str]] | None = None,
              ready: Callable[[], np.ndarray] | None = None) -> list[Judgement]:
        """Run the worlds to their judgement: `advance(live)` every control period until `ready()` says a world's
        grasp is done (None: every world's is), then its protocol's stages.

        Args:
            advance: one control period of the live worlds (None: their physics alone, the targets kept).
            ready: which worlds' grasps go to the judge now (None: all at once).

        Returns:
            One `Judgement` per world.
        """
        return episode_loop(self.worlds, self.period, advance or self.physics, friction=self.setup.object.friction,
                            rules=self.setup.rules, ready=ready)


class _TrialLoop:
    """The trials' side of the judging loop (`episode_loop` runs it): one control period of every live world
    (`advance`: the controller, then the physics; the oracle's correction first where it is asked for), which worlds
    go to the judge (`ready`: the regrasp's probe decides), and what each trial records."""

    def __init__(self, setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
                 observer: Callable[[Worlds], None] | None):
        n = len(poses)
        self.setup, self.poses, self.rngs, self.observer, self.n = setup, poses, rngs, observer, n
        self.controller = controller = setup.make_controller(n)
        self.readouts = declared_readouts(controller)  # what the loop reads of it beyond the control step
        self.period = period = controller.control_period
        self.episodes = EpisodeWorlds(setup, start_worlds(setup, poses, rngs, controller.initial), period)
        self.worlds = self.episodes.worlds
        self.grasping = np.ones(n, dtype=bool)  # the worlds whose controller still acts: only their joints are noisy
        self.clock, self.time_to_grasp = 0.0, np.full(n, np.nan)
        self.failed: dict[int, tuple[int, list[int]]] = {}  # a failed world's recalls, as they were when it failed
        self.first_contact = np.full((n, FIRST_CONTACT_FEATURES), np.nan)
        self.object_estimate = np.full((n, 3), np.nan)
        self.corrections = np.zeros((n, 6))  # the flange's set point the controller's palm moves are added to
        self.correcting = 0  # control periods of the oracle's correction still to run, before the controller starts
        if setup.oracle:
            assert setup.plan is not None and setup.palm is not None  # the set-up refuses an oracle without both
            moved = np.array(poses, dtype=float)
            if setup.oracle == "translation":  # the palm moved, not turned
                moved[:, 3] = 0.0
            self.corrections = np.array([oracle_correction(setup.plan.poses[0], pose) for pose in moved])
            seconds = np.max(np.abs(self.corrections) / setup.palm.speeds()) + ORACLE_SETTLE_SECONDS
            self.correcting = math.ceil(seconds / period)
        # a controller that regrasps has `attempt` and `restart` (`make_controller` checks it); others only finish
        self.probe = LiftProbe(setup.regrasp, self.worlds, cast(RestartingController, controller), setup.rules)

    def recalls(self, world: int) -> tuple[int, list[int]]:
        """The best matches a world's controller used (none, for a controller without)."""
        controller, readouts = cast(BatchController, self.controller), self.readouts  # what it declares
        return (int(controller.matches[world]) if "matches" in readouts else 0,
                list(controller.winners[world]) if "winners" in readouts else [])

    def advance(self, live: np.ndarray) -> dict[int, str]:
        """One control period: the controller, then the physics. Worlds not given are not read (a failed
        world's state may not be finite); their controller's targets no longer matter."""
        if self.correcting:  # the oracle's correction: the fingers held, the flange carrying the palm
            self.correcting -= 1
            self.episodes.act(live, np.tile(self.controller.initial, (len(live), 1)), self.corrections[live])
            return self._physics(live, np.zeros(self.n, dtype=bool))
        sensed = self._sense(live)
        targets = self.controller.step(*sensed)
        self.clock += self.period
        newly_done = self.grasping & np.asarray(self.controller.done, dtype=bool)
        self.time_to_grasp[newly_done] = self.clock
        self.worlds.set_targets(live, targets[live])
        self._move_palms(live)
        return self._physics(live, newly_done)

    def _sense(self, live: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What the controller senses: the live worlds' joints (noisy while grasping) and segment forces; the first
        contact of each world recorded."""
        controller, setup, grasping = self.controller, self.setup, self.grasping
        sensed, forces = np.tile(controller.initial, (self.n, 1)), np.zeros((self.n, len(SEGMENTS)))
        sensed[live], forces[live] = self.worlds.joints(live), self.worlds.segment_forces(live)
        if setup.noise.joints:
            for world in np.flatnonzero(grasping).tolist():
                sensed[world] += self.rngs[world].normal(0.0, setup.noise.joints, N_FINGER_JOINTS)
        touched = grasping & np.isnan(self.first_contact[:, 0]) & (forces > 0).any(axis=1)
        self.first_contact[touched] = np.column_stack([np.full(touched.sum(), self.clock), sensed[touched],
                                                       forces[touched]])
        return sensed, forces

    def _move_palms(self, live: np.ndarray) -> None:
        """The arm carries each palm where its grasp wants it: at once without a flange, else by the flange at its
        bounded speed while the grasp goes on; where touch first placed the object is kept."""
        controller, setup = cast(BatchController, self.controller), self.setup  # what it declares is read
        palm_offset = controller.palm_offset if "palm_offset" in self.readouts and controller.moves_palm else None
        if palm_offset is not None and setup.palm is None:  # at once
            self.worlds.shift_hands(live, palm_offset[live])
        elif palm_offset is not None or setup.oracle:  # by its flange, at its bounded speed, while the grasp goes on
            steered = live[self.grasping[live]]
            offsets = palm_offset[steered] if palm_offset is not None else np.zeros((len(steered), 3))
            self.worlds.steer_flanges(steered, flange_targets(self.corrections[steered], offsets), self.period)
        if "object_estimate" in self.readouts:
            estimate = controller.object_estimate  # where touch first placed it, (first) in the start palm frame
            first = np.isnan(self.object_estimate[:, 0]) & ~np.isnan(estimate[:, 0])
            self.object_estimate[first] = flange_targets(self.corrections[first], estimate[first])[:, :3]

    def _physics(self, live: np.ndarray, newly_done: np.ndarray) -> dict[int, str]:
        """The physics of one control period; a failed world keeps its recalls as they were when it failed."""
        failures = self.episodes.physics(live)
        self.failed.update({world: self.recalls(world) for world in failures})
        self.grasping[newly_done] = self.grasping[list(failures)] = False
        if self.observer is not None:
            self.observer(self.worlds)
        return failures

    def ready(self) -> np.ndarray:
        """The worlds whose grasp goes to the judge (all after MAX_GRASP_SECONDS: a controller that never
        finishes); with attempts left, the regrasp's probe decides (`regrasp.LiftProbe`)."""
        if self.clock >= MAX_GRASP_SECONDS:
            self.time_to_grasp[np.isnan(self.time_to_grasp)] = self.clock
            return np.ones(self.n, dtype=bool)
        judged, again = self.probe.ready(self.clock)
        self.grasping[again] = True
        return judged

    def trial(self, world: int, judged: Judgement) -> Trial:
        """What trial `world` records, its judgement with what its controller did."""
        matches, winners = self.failed.get(world) or self.recalls(world)
        assert judged.posture is not None and judged.touching is not None  # a trial's judge records both
        return Trial(grid_pose=self.poses[world], posture=judged.posture, touching=judged.touching,
                     epsilon=judged.epsilon, hold=judged.hold, hold_displacement=judged.displacement,
                     time_to_grasp=judged.time if judged.fault else float(self.time_to_grasp[world]), matches=matches,
                     margin=judged.margin, penetration=judged.penetration, fault=judged.fault,
                     winners=np.array(winners, dtype=int), hold_time=judged.hold_time,
                     attempts=int(cast(BatchController, self.controller).attempt[world])
                     if "attempt" in self.readouts else 1,
                     first_contact=self.first_contact[world], failure=self.probe.failure[world],
                     object_estimate=self.object_estimate[world])


def flange_targets(corrections: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """The flange's set points of palms moved by `offsets` (palm frame) from where corrections put them.

    Args:
        corrections: (m, 6) set points from home, m and rad about the palm's x, y, z (the oracle's: a turn about
            the palm normal, y, only; zeros otherwise).
        offsets: (m, 3) m, palm moves in the frame of the palm as the correction turned it.

    Returns:
        (m, 6) set points from home.
    """
    turned = np.array([Rotation.from_rotvec([0.0, yaw, 0.0]).apply(offset)
                       for yaw, offset in zip(corrections[:, 4], offsets)]).reshape(-1, 3)
    return np.column_stack([corrections[:, :3] + turned, corrections[:, 3:]])


def run_trial(setup: TrialSetup, grid_pose: np.ndarray, rng: np.random.Generator,
              observer: Callable[[Worlds], None] | None = None) -> Trial:
    """One trial: `run_trials` for one grid pose (4,), m and rad, with its random generator."""
    return run_trials(setup, np.asarray(grid_pose, dtype=float)[None], [rng], observer)[0]


def __getattr__(name: str) -> object:
    """`Episodes`, `EpisodeWorlds`' name before 0.3, with a warning (`base.moved.MOVED_NAMES`)."""
    return moved_attribute(__name__, name)
