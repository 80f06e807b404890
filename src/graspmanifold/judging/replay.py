"""DexGraspBench's way of judging grasps: open-loop grasps replayed (`replay_grasp`, the one replay, which the
generator's verifier runs too) and its external-force test (`external_force_test`); its Q1 metric.

DexGraspBench (with BODex, ICRA 2025) judges *open-loop* grasps, each a pregrasp, a grasp and a squeeze
(a hand root pose and joint angles): once per direction of +x, -x, +y, -y, +z and -z it resets the scene
to the pregrasp (a hand that starts more than `max_penetration` inside the object fails outright), moves
pregrasp -> grasp and grasp -> squeeze in `approach_targets` interpolated targets of `steps_per_target`
physics steps each (the root by its mocap body, the joints by their servos), pushes the object with an
external force of `force_per_kg` x the direction x its mass (gravity off), and simulates `hold_chunks` x
`steps_per_chunk` steps, stopping early once the object has moved more than `translation_limit` or turned
more than `angle_limit` from where it began. A grasp succeeds when it stays within both in every direction.
Its versions and its physics profile are protocols of `protocols` (`DexGraspBenchProtocol`, `PROTOCOLS`).

`q1` is its analytic force-closure metric in its convention (fingertip contacts within 5 mm, one point per
link, an 8-edge pyramid at half the friction, torques about the contacts' centroid scaled by their mean
radius), beside our `quality.epsilon_l1` (the L1 epsilon about the object's centre of mass at the
simulation's friction, 8 edges, torques scaled by the largest lever): two metrics, each named for what it is.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from ..base.errors import InvalidInput, SimulationError
from ..base.poses import invert, rotate
from ..base.validation import check_choice
from ..manifold.postureset import PostureSet
from ..sim.grip import CONTROL_PERIOD, SQUEEZE, squeezed
from ..sim.hand import SHADOW_HAND, HandModel
from ..sim.normal_offsets import offset_along_normals
from ..sim.objects import GraspObject, object_from_params
from ..sim.posture import open_posture
from ..sim.scene import Scene
from .judge import VERIFY_HOLD_SECONDS, Judgement, judge_scene, reading_epsilon
from .protocols import DEFAULT_PROTOCOL, DEXGRASPBENCH, DexGraspBenchProtocol, JudgingProtocol, get_protocol
from .quality import epsilon_l1

#: m: contacts farther from the object than this do not count for `q1`
Q1_CONTACT_DISTANCE = 0.005


def q1(points: np.ndarray, normals: np.ndarray, links: np.ndarray, distances: np.ndarray | None = None,
       friction: float = 0.6) -> float:
    """DexGraspBench's Q1 (Ferrari-Canny) of a grasp's contacts, in its convention: contacts within 5 mm of the
    object (the caller keeps the fingertip links' only), every link's contacts averaged into one point and
    normal, an 8-edge friction pyramid at half the friction, torques about the contacts' centroid divided by
    their mean distance from it. DexGraspBench reports 2 - q1 (2 without contacts); this returns q1.

    Args:
        points: (k, 3) m, contact points.
        normals: (k, 3) contact normals into the object (need not be unit).
        links: (k,) the link (body) each contact is on.
        distances: (k,) m, each contact's distance to the object (negative: penetrating); None: all count.
        friction: the sliding friction of the simulation (DexGraspBench: 0.6); the metric takes half.

    Returns:
        q1 (0: not force closure, or fewer than two links touch).
    """
    points, normals = np.asarray(points, dtype=float), np.asarray(normals, dtype=float)
    links = np.asarray(links)
    if points.ndim != 2 or points.shape[1:] != (3,) or normals.shape != points.shape or links.shape != (len(points),):
        raise InvalidInput(f"points and normals must be (k, 3) and links (k,), got {points.shape}, {normals.shape} "
                           f"and {links.shape}")
    near = np.ones(len(points), dtype=bool) if distances is None else np.asarray(distances) <= Q1_CONTACT_DISTANCE
    points, normals, links = points[near], normals[near], links[near]
    unit = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    merged = [(points[links == link].mean(axis=0), unit[links == link].mean(axis=0)) for link in np.unique(links)]
    if len(merged) < 2:
        return 0.0
    where, towards = (np.array(x) for x in zip(*merged))
    centroid = where.mean(axis=0)
    radius = float(np.linalg.norm(where - centroid, axis=1).mean())
    return epsilon_l1(where, towards, centroid, mu=friction / 2, num_edges=8, torque_scale=radius or None)


#: the state an approach's end is saved in and restored from (MuJoCo's whole integration state)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
#: the stages of an open-loop grasp, in order
STAGE_NAMES: tuple[str, ...] = ("pregrasp", "grasp", "squeeze")
#: the farthest a stage's palm may lie from the object's centre (m): farther is no grasp of it (a stage moved a
#: million metres away replayed as held: the free object waited, weightless, for the hand to come back)
MAX_REACH = 1.0


@dataclass(frozen=True)
class OpenLoopGrasp:
    """A grasp as DexGraspBench replays it: the pregrasp, the grasp and the squeeze, each a palm pose in the
    object frame and a posture.

    Attributes:
        poses: (3, 7) the palm's position (m) and orientation (w x y z) in the object frame, per stage.
        postures: (3, 22) rad, the finger joints per stage (the paper's joint order and senses).
    """

    poses: np.ndarray
    postures: np.ndarray

    def __post_init__(self) -> None:
        for name, width in (("poses", 7), ("postures", 22)):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3, width):
                raise InvalidInput(f"OpenLoopGrasp.{name} must be (3, {width}) values (pregrasp, grasp, squeeze), got "
                                   f"shape {value.shape}")
            if not np.all(np.isfinite(value)):
                raise InvalidInput(f"OpenLoopGrasp.{name} must be finite, got NaN or infinite values in the "
                                   f"{', '.join(STAGE_NAMES[i] for i in np.flatnonzero(~np.isfinite(value).all(axis=1)))}")
            object.__setattr__(self, name, value)
        reach = np.linalg.norm(self.poses[:, :3], axis=1)
        if np.any(reach > MAX_REACH):
            stage = int(np.argmax(reach))
            raise InvalidInput(f"OpenLoopGrasp.poses: the {STAGE_NAMES[stage]}'s palm lies {reach[stage]:.3g} m from the "
                               f"object's centre; a grasp's palm is within {MAX_REACH:g} m of it")
        length = np.linalg.norm(self.poses[:, 3:], axis=1)
        if np.any(np.abs(length - 1.0) > 1e-6):
            raise InvalidInput(f"OpenLoopGrasp.poses: each orientation must be a unit quaternion (w x y z), got lengths "
                               f"{np.round(length, 6).tolist()}")

    @property
    def squeeze_offset(self) -> np.ndarray:
        """(22,) rad, the squeeze's posture less the grasp's: how hard the grasp presses, joint by joint (what an
        experience carries as a grasp's `squeezes`, `manifold.experience`)."""
        return self.postures[2] - self.postures[1]


@dataclass(frozen=True)
class ForceTest:
    """The outcome of DexGraspBench's external-force test (`external_force_test`).

    Attributes:
        success: held within both limits in every direction.
        translation: (6,) m, the largest displacement per direction (NaN: not run, an earlier one failed).
        rotation: (6,) rad, the largest turn per direction (NaN: not run).
        penetration: m, how deep the hand was inside the object at the pregrasp.
        steps: physics steps simulated.
        fault: why the test could not judge ('' when it could): a penetrating pregrasp, or failed physics.
        epsilon: `quality.epsilon_l1` of the contacts at the squeeze's end, about the object's centre of mass, at
            the simulation's friction (NaN: the test did not get that far).
    """

    success: bool
    translation: np.ndarray
    rotation: np.ndarray
    penetration: float
    steps: int
    fault: str = ""
    epsilon: float = float("nan")


def _turned(a: np.ndarray, b: np.ndarray) -> float:
    """rad between two orientations (w x y z)."""
    return 2.0 * math.acos(min(1.0, abs(float(np.dot(a, b)))))


def _slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    if np.dot(a, b) < 0:
        b = -b
    angle = math.acos(min(1.0, float(np.dot(a, b))))
    if angle < 1e-9:
        return a.copy()
    return (math.sin((1 - t) * angle) * a + math.sin(t * angle) * b) / math.sin(angle)


def _start(scene: Scene, grasp: OpenLoopGrasp) -> list[tuple[np.ndarray, np.ndarray]]:
    """The scene reset to the pregrasp (the object free, unsupported, gravity off: a hold test before left it
    on); the hand mount's pose of each stage."""
    scene.reset()
    scene.set_gravity(False)
    scene.set_object_support(0.0, 0.0)
    scene.set_posture(grasp.postures[0])
    mounts = [scene.mount_pose_for(pose[:3], pose[3:]) for pose in grasp.poses]
    scene.data.mocap_pos[scene.mount_id], scene.data.mocap_quat[scene.mount_id] = mounts[0]
    scene.forward()
    return mounts


def _approach(scene: Scene, grasp: OpenLoopGrasp, mounts: list, protocol: DexGraspBenchProtocol) -> int:
    """Pregrasp -> grasp -> squeeze in the protocol's interpolated targets; the physics steps taken."""
    data, steps = scene.data, 0
    for stage in (0, 1):
        for target in range(1, protocol.approach_targets + 1):
            t = target / protocol.approach_targets
            data.mocap_pos[scene.mount_id] = (1 - t) * mounts[stage][0] + t * mounts[stage + 1][0]
            data.mocap_quat[scene.mount_id] = _slerp(mounts[stage][1], mounts[stage + 1][1], t)
            scene.set_target((1 - t) * grasp.postures[stage] + t * grasp.postures[stage + 1])
            mujoco.mj_step(scene.model, data, nstep=protocol.steps_per_target)
            steps += protocol.steps_per_target
    return steps


def external_force_test(scene: Scene, grasp: OpenLoopGrasp, protocol: DexGraspBenchProtocol = DEXGRASPBENCH,
                        observe: Callable[[Scene], None] | None = None) -> ForceTest:
    """Judge an open-loop grasp as DexGraspBench does (see the module doc); the directions run in turn and the
    test ends at the first that fails (no later one can change the outcome). DexGraspBench replays the approach
    for every direction; the physics being deterministic, the approach runs once here and every direction
    starts from its saved end state (MuJoCo's whole integration state: the same steps as a replay).

    Args:
        scene: a scene with a free object (`Scene(obj, free_object=True)`); the protocol's physics profile is
            applied to it (its model changes for good).
        grasp: the pregrasp, grasp and squeeze.
        protocol: the test, one version of it (`protocols.DEXGRASPBENCH`, `protocols.DEXGRASPBENCH_PAPER`).
        observe: called with the scene at the squeeze's end, before the first push (a study's look at the grasp
            it judges; it must not change the scene's state).

    Returns:
        The `ForceTest`.
    """
    if not scene.free_object:
        raise InvalidInput("external_force_test needs a scene with free_object=True")
    protocol.physics.apply(scene)
    model, data = scene.model, scene.data
    translation, rotation = np.full(len(protocol.directions), np.nan), np.full(len(protocol.directions), np.nan)
    mounts = _start(scene, grasp)
    depth = scene.penetration()
    if depth > protocol.max_penetration:
        return ForceTest(False, translation, rotation, depth, 0, f"the pregrasp starts {depth * 1000:.1f} mm "
                         f"inside the object (the protocol allows {protocol.max_penetration * 1000:.0f} mm)")
    start_position, start_quat = scene.object_pose()
    steps = _approach(scene, grasp, mounts, protocol)
    if observe is not None:
        observe(scene)
    epsilon = reading_epsilon(scene.tactile(), scene.data.xipos[scene.object_body],
                              float(model.geom_friction[scene.object_geoms[0], 0]))
    squeezed_state = np.empty(mujoco.mj_stateSize(model, _STATE))
    mujoco.mj_getState(model, data, squeezed_state, _STATE)
    for k, direction in enumerate(protocol.directions):
        mujoco.mj_setState(model, data, squeezed_state, _STATE)
        data.xfrc_applied[scene.object_body, :3] = protocol.push * np.asarray(direction)
        moved = turned = 0.0
        for _ in range(protocol.hold_chunks):
            mujoco.mj_step(model, data, nstep=protocol.steps_per_chunk)
            steps += protocol.steps_per_chunk
            if data.warning.number.any() or not np.all(np.isfinite(data.qpos)):
                return ForceTest(False, translation, rotation, depth, steps, "the physics failed (a MuJoCo warning or "
                                 "a non-finite state)", epsilon)
            position, quat = scene.object_pose()
            moved = max(moved, float(np.linalg.norm(position - start_position)))
            turned = max(turned, _turned(quat, start_quat))
            if moved > protocol.translation_limit or turned > protocol.angle_limit:
                break  # the early stop: this direction has failed
        data.xfrc_applied[scene.object_body, :3] = 0.0
        translation[k], rotation[k] = moved, turned
        if moved > protocol.translation_limit or turned > protocol.angle_limit:
            return ForceTest(False, translation, rotation, depth, steps, epsilon=epsilon)
    return ForceTest(True, translation, rotation, depth, steps, epsilon=epsilon)


#: m the pregrasp's palm stands back from the grasp's, away from the object's centre
PREGRASP_BACK_OFF = 0.02


@dataclass(frozen=True)
class GraspStages:
    """How a posture at its palm pose becomes an open-loop grasp (`open_loop_grasp`): its pregrasp and squeeze.

    Attributes:
        pregrasp: 'open' (the open hand with its palm `back_off` further from the object's centre) or 'contacts'
            (the grasp with every touching finger segment `back_off` out along the object's normal, the palm at
            the grasp's pose: an approach along the normals that does not sweep the object;
            `normal_offsets.offset_along_normals`).
        squeeze: 'flexion' (the flexion joints `squeeze_angle` further towards the closed hand, as the
            controller squeezes: `sim.grip.squeezed`) or 'contacts' (every touching segment `squeeze_depth` into
            the object along its normal, so that each servo presses its contact inwards).
        back_off: m.
        squeeze_angle: rad.
        squeeze_depth: m.
    """

    pregrasp: str = "open"
    squeeze: str = "flexion"
    back_off: float = PREGRASP_BACK_OFF
    squeeze_angle: float = SQUEEZE
    squeeze_depth: float = 0.01

    def __post_init__(self) -> None:
        for name, choices in (("pregrasp", ("open", "contacts")), ("squeeze", ("flexion", "contacts"))):
            check_choice(getattr(self, name), choices, f"GraspStages.{name}")
        for name in ("back_off", "squeeze_angle", "squeeze_depth"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 0.5:
                raise InvalidInput(f"GraspStages.{name} must be a number in [0, 0.5), got {value!r}")

    @property
    def from_contacts(self) -> bool:
        """Whether a stage is made from the grasp's contacts (it then needs a scene of the object)."""
        return "contacts" in (self.pregrasp, self.squeeze)


#: the stages of open-loop grasps by name: the open hand and the controller's squeeze ('open'), and those made from
#: the contacts ('contacts', the generator's default: more of its candidates hold when replayed, docs/studies/protocols.md)
GRASP_STAGES: dict[str, GraspStages] = {"open": GraspStages(),
                                        "contacts": GraspStages(pregrasp="contacts", squeeze="contacts")}
#: the stages the generator verifies with unless told otherwise (`GeneratorParams.stages`)
VERIFY_STAGES = "contacts"


def open_loop_grasp(hand_pose: np.ndarray, posture: np.ndarray, stages: GraspStages = GRASP_STAGES["open"],
                    scene: Scene | None = None) -> OpenLoopGrasp:
    """One posture at its palm pose as an open-loop grasp: the pregrasp, the grasp (the posture at its palm pose)
    and the squeeze, as `stages` says.

    Args:
        hand_pose: (7,) the palm's position (m) and orientation (w x y z) in the object frame.
        posture: (22,) rad, the grasp's finger joints.
        stages: how the pregrasp and the squeeze are made (`GRASP_STAGES`).
        scene: a scene of the object and the hand: its hand's open and closed postures; needed for stages made
            from the contacts (its state is changed). None: our hand, flexion stages only.

    Returns:
        The `OpenLoopGrasp`.
    """
    pose, posture = np.asarray(hand_pose, dtype=float), np.asarray(posture, dtype=float)
    if stages.from_contacts and scene is None:
        raise InvalidInput("open_loop_grasp: stages made from the contacts need the object's scene (scene=)")
    hand = SHADOW_HAND if scene is None else scene.hand
    if stages.pregrasp == "open":
        away = pose[:3] / max(float(np.linalg.norm(pose[:3])), 1e-9)
        pregrasp = np.r_[pose[:3] + stages.back_off * away, pose[3:]], open_posture(hand)
    else:
        assert scene is not None  # refused above
        pregrasp = pose, offset_along_normals(scene, pose, posture, -stages.back_off)
    if stages.squeeze == "flexion":
        squeeze = squeezed(posture, stages.squeeze_angle, hand)
    else:
        assert scene is not None  # refused above
        squeeze = offset_along_normals(scene, pose, posture, stages.squeeze_depth)
    return OpenLoopGrasp(np.array([pregrasp[0], pose, pose]), np.array([pregrasp[1], posture, squeeze]))


def open_loop_grasps(postures: PostureSet, stages: GraspStages | None = None,
                     obj: str | GraspObject | None = None) -> list[OpenLoopGrasp]:
    """Our postures as open-loop grasps (`open_loop_grasp` of each at its palm pose).

    Args:
        postures: a posture set (palm poses in the object frame and postures).
        stages: how the pregrasp and the squeeze are made (`GRASP_STAGES`); None: those the set was verified with
            (its metadata's `generator.stages` and `squeeze`; 'open' for a set made without them).
        obj: the set's object, or its name (for stages made from the contacts; None: the object its metadata
            names); the set's hand is its metadata's.

    Returns:
        One `OpenLoopGrasp` per posture.
    """
    if stages is None:
        made = postures.metadata.get("generator", {})
        stages = replace(GRASP_STAGES[made.get("stages", "open")], squeeze_angle=made.get("squeeze", GraspStages.squeeze_angle))
    if obj is None and stages.from_contacts:
        if "object" not in postures.metadata:
            raise InvalidInput("open_loop_grasps: stages made from the contacts need the set's object (obj=): its "
                               "metadata names none")
        obj = object_from_params(postures.metadata["object"])
        if obj.shape == "mesh" and obj.mesh is None:  # a file keeps a mesh's digest, not the mesh
            raise InvalidInput(f"open_loop_grasps: the set's object {obj.name!r} is a mesh its file does not hold: "
                               "give it, open_loop_grasps(postures, obj=the_mesh_object)")
    scene = None if obj is None else Scene(obj, hand=postures.hand)
    return [open_loop_grasp(pose, posture, stages, scene)
            for pose, posture in zip(postures.hand_poses, postures.postures)]


@dataclass(frozen=True)
class Replay:
    """One open-loop grasp replayed and judged (`replay_grasp`).

    Attributes:
        judgement: the judging's `Judgement` (for DexGraspBench's test: hold = its success, displacement its
            largest translation, epsilon at the squeeze's end); its `fault` says why the physics failed.
        refused: why the grasp was refused before it ran ('' when it ran): a pregrasp inside the object.
    """

    judgement: Judgement
    refused: str = ""

    @property
    def held(self) -> bool:
        """Held, judged without a fault, not refused."""
        return self.judgement.hold and not self.judgement.fault and not self.refused

    @property
    def fault(self) -> str:
        """Why the grasp could not be judged ('' when it could)."""
        return self.refused or self.judgement.fault


def replay_grasp(scene: Scene, grasp: OpenLoopGrasp, protocol: str | JudgingProtocol = DEFAULT_PROTOCOL,
                 hold_seconds: float | None = None, observe: Callable[[Scene], None] | None = None) -> Replay:
    """The one replay of an open-loop grasp: the scene reset to the pregrasp (the object free and unsupported,
    gravity off; a pregrasp deeper than DexGraspBench's `max_penetration` inside the object is refused, whatever
    judges), pregrasp -> grasp -> squeeze in DexGraspBench's interpolated targets, then the protocol's judging:
    its external-force test (`external_force_test`, its physics) where it has one, else its rules' hold test
    (the scene's own physics, the same targets over the same seconds, then `judge.judge_scene`).
    `replay` runs it over many grasps; the generator's verifier (`GraspVerifier`) runs it on each candidate.

    Args:
        scene: a scene of the object, free (`Scene(obj, free_object=True)`); a protocol with its own physics
            applies it to the scene for good; one that moves the palm (the lift) needs the hand on a flange
            (`Scene(..., flange=FlangeLimits())`).
        grasp: the grasp.
        protocol: a name in `protocols.PROTOCOLS`, or a `JudgingProtocol` (one changed for an ablation, or one's own).
        hold_seconds: s per direction of a hold test by rules (None: the protocol's rules'); an external-force
            test has its own.
        observe: called with the scene at the squeeze's end, before the judging (a study's look at what is
            judged, e.g. `studies.spring_holds`; it must not change the scene's state); not called for a refused
            pregrasp.

    Returns:
        The `Replay`.
    """
    protocol = get_protocol(protocol)
    if protocol.push_test is not None:
        test = external_force_test(scene, grasp, protocol.push_test, observe)
        if test.fault and test.steps == 0:
            return Replay(Judgement(0.0, False, np.inf, np.nan, penetration=test.penetration), test.fault)
        return Replay(Judgement(test.epsilon, test.success, float(np.nanmax(test.translation, initial=0.0)), np.nan,
                                penetration=test.penetration, fault=test.fault))
    timed = replace(DEXGRASPBENCH, steps_per_target=round(
        DEXGRASPBENCH.steps_per_target * DEXGRASPBENCH.physics.timestep / scene.model.opt.timestep))
    mounts = _start(scene, grasp)
    depth = scene.penetration()
    if depth > DEXGRASPBENCH.max_penetration:  # its rule for a pregrasp, whatever judges the grasp
        return Replay(Judgement(0.0, False, np.inf, np.nan, penetration=depth),
                      f"the pregrasp starts {depth * 1000:.1f} mm inside the object")
    _approach(scene, grasp, mounts, timed)  # its targets and their seconds, the scene's physics
    if observe is not None:
        observe(scene)
    rules = protocol.rules if hold_seconds is None else replace(protocol.rules, hold_seconds=hold_seconds)
    return Replay(judge_scene(scene, rules))


def replay(obj: str | GraspObject, grasps: list[OpenLoopGrasp], protocol: str | JudgingProtocol = DEFAULT_PROTOCOL,
           hand: str = SHADOW_HAND.name) -> tuple[np.ndarray, list[str]]:
    """Open-loop grasps executed as DexGraspBench executes them and judged by the protocol named
    (`replay_grasp` of each).

    Args:
        obj: the object, or its name.
        grasps: the grasps.
        protocol: a name in `protocols.PROTOCOLS`, or a `JudgingProtocol`.
        hand: the hand model's name.

    Returns:
        (held (n,) bool, faults: why a grasp could not be judged, '' where it could).
    """
    protocol = get_protocol(protocol)  # refused by name before anything runs
    scene = Scene(obj, free_object=True, hand=hand, flange=protocol.flange)
    replays = [replay_grasp(scene, grasp, protocol) for grasp in grasps]
    return np.array([r.held for r in replays], dtype=bool), [r.fault for r in replays]


#: s each interpolated target of an approach lasts (DexGraspBench's steps per target at its own time step)
APPROACH_TARGET_SECONDS = DEXGRASPBENCH.steps_per_target * DEXGRASPBENCH.physics.timestep


class OpenLoopController:
    """An open-loop grasp executed as a trial's controller, N worlds at once; it senses nothing. From the pregrasp
    (where a planned trial starts every arm, `TrialSetup.plan`) it moves to the grasp and then the squeeze, each move
    in the replay's `approach_targets` interpolated targets of `APPROACH_TARGET_SECONDS` each (`replay_grasp`'s
    approach), the palm carried by the arm where the stages put it; then it is done and keeps the squeeze. It is the
    open-loop arm of a planned trial (`TrialSetup(controller=OpenLoop(grasp), plan=grasp)`): every arm then starts
    from the same state and faces the same support, release and judge. Given more attempts
    (`TrialSetup(regrasp=Regrasp(attempts=2))`), a world whose grasp fails the lift probe executes the plan again
    from its pregrasp (`restart`): the open loop with as many attempts as the arm it is compared with.

    Attributes:
        n: worlds; control_period: s; initial: (22,) rad, the pregrasp's posture; done: (N,) bool.
        offsets: (3, 3) m, the palm at each stage relative to the pregrasp's palm pose, in its frame.
        moves_palm: whether the stages move the palm; palm_offset: (N, 3) m, where the arm has carried each palm.
        cycle: (N,) control periods each world's attempt has run; attempt: (N,) each world's attempt, 1 the first.
    """

    def __init__(self, n: int, grasp: OpenLoopGrasp, control_period: float = CONTROL_PERIOD,
                 approach_targets: int = DEXGRASPBENCH.approach_targets):
        """An open-loop controller ready for its grasp in every world.

        Args:
            n: worlds.
            grasp: the pregrasp, grasp and squeeze (palm poses in the object frame).
            control_period: s between two `step` calls; a target lasts a whole number of them.
            approach_targets: interpolated targets per move (DexGraspBench's 10).

        Raises:
            InvalidInput: stages that turn the palm (the arm here only carries it), or a period that does not
                divide a target's seconds.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidInput(f"n (worlds) must be a positive integer, got {n!r}")
        if not isinstance(grasp, OpenLoopGrasp):
            raise InvalidInput(f"grasp must be an OpenLoopGrasp, got {type(grasp).__name__}")
        if np.any(np.abs(np.abs(grasp.poses[:, 3:] @ grasp.poses[0, 3:]) - 1.0) > 1e-9):
            raise InvalidInput("OpenLoopController: the stages turn the palm; the arm here carries it without turning")
        per_target = APPROACH_TARGET_SECONDS / control_period
        if round(per_target) < 1 or abs(per_target - round(per_target)) > 1e-6:
            raise InvalidInput(f"control_period must divide an approach target's {APPROACH_TARGET_SECONDS:g} s, got "
                               f"{control_period!r}")
        self.n, self.grasp, self.control_period = int(n), grasp, float(control_period)
        self.targets, self.periods_per_target = int(approach_targets), int(round(per_target))
        self.initial = grasp.postures[0].copy()
        to_palm = invert(np.zeros(3), grasp.poses[0, 3:])[1]
        self.offsets = np.array([rotate(pose[:3] - grasp.poses[0, :3], to_palm) for pose in grasp.poses])
        self.moves_palm = bool(np.any(self.offsets != 0.0))
        self.reset()

    def reset(self) -> None:
        """Start the grasp again in every world."""
        self.cycle = np.zeros(self.n, dtype=int)
        self.attempt = np.ones(self.n, dtype=int)
        self.done = np.zeros(self.n, dtype=bool)
        self.palm_offset = np.zeros((self.n, 3))

    def restart(self, worlds: np.ndarray, joints: np.ndarray, segment_forces: np.ndarray) -> None:
        """The next attempt in these worlds, whose grasp failed the lift probe: the plan executed again from its
        pregrasp (nothing sensed is read: it is the open loop).

        Args:
            worlds: the worlds' indices (m,).
            joints: (m, 22) rad (not read).
            segment_forces: (m, segments) N (not read).
        """
        worlds = np.asarray(worlds, dtype=int)
        self.cycle[worlds], self.done[worlds] = 0, False
        self.attempt[worlds] += 1

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control period: the approach's target for it (what is sensed is not read).

        Args:
            joints: (N, 22) rad (not read).
            segment_forces: (N, segments) N (not read).

        Returns:
            (N, 22) rad, the targets.
        """
        moves = len(self.grasp.postures) - 1
        target = np.minimum(self.cycle // self.periods_per_target, moves * self.targets - 1)  # 0-based, every move
        move, k = np.divmod(target, self.targets)
        t = ((k + 1) / self.targets)[:, None]
        posture = (1 - t) * self.grasp.postures[move] + t * self.grasp.postures[move + 1]
        self.palm_offset[:] = (1 - t) * self.offsets[move] + t * self.offsets[move + 1]
        self.cycle += 1
        self.done[:] = self.cycle >= moves * self.targets * self.periods_per_target
        return posture


@dataclass(frozen=True, eq=False)
class OpenLoop:
    """The factory of `OpenLoopController`s of one grasp, for `TrialSetup(controller=...)` (picklable).

    Attributes:
        grasp: the open-loop grasp.
    """

    grasp: OpenLoopGrasp

    def __post_init__(self) -> None:
        if not isinstance(self.grasp, OpenLoopGrasp):  # was met only when the trials made their controllers
            raise InvalidInput(f"OpenLoop.grasp must be an OpenLoopGrasp (open_loop_grasp makes one), got "
                               f"{type(self.grasp).__name__}")

    def __call__(self, n: int, hand: HandModel) -> OpenLoopController:
        """A controller of the grasp for n worlds.

        Args:
            n: worlds.
            hand: the hand model.

        Returns:
            The controller.
        """
        return OpenLoopController(n, self.grasp)


class GraspVerifier:
    """The generator's verifier: a grasp at its palm pose replayed open loop (`replay_grasp`: from its pregrasp,
    the object free) and judged by the protocol named. The generator verifies its candidates with it, and the
    starting-posture search keeps a design's start only when the start itself passes it.

    Args:
        obj: the object (palm poses are in its frame).
        stages: how the pregrasp and squeeze are made (`GRASP_STAGES`).
        hold_seconds: s per direction of our hold test.
        hand: the hand model, or its name.
        protocol: a name in `protocols.PROTOCOLS`, or a `JudgingProtocol`.
    """

    def __init__(self, obj: GraspObject, stages: GraspStages = GRASP_STAGES[VERIFY_STAGES],
                 hold_seconds: float = VERIFY_HOLD_SECONDS, hand: str | HandModel = SHADOW_HAND.name,
                 protocol: str | JudgingProtocol = DEFAULT_PROTOCOL):
        self.protocol = get_protocol(protocol)
        self.scene = Scene(obj, free_object=True, hand=hand, flange=self.protocol.flange)
        self._shaping = Scene(obj, hand=hand) if stages.from_contacts else None
        self.stages, self.hold_seconds = stages, hold_seconds

    def grasp(self, posture: np.ndarray, hand_pos: np.ndarray, hand_quat: np.ndarray) -> OpenLoopGrasp:
        """The open-loop grasp the verifier replays for a posture at a palm pose (see `__call__`)."""
        return open_loop_grasp(np.r_[hand_pos, hand_quat], posture, self.stages, self._shaping)

    def __call__(self, posture: np.ndarray, hand_pos: np.ndarray, hand_quat: np.ndarray,
                 observe: Callable[[Scene], None] | None = None) -> Judgement:
        """Judge one grasp.

        Args:
            posture: (22,) rad, the grasp's finger joints.
            hand_pos: (3,) m, the palm's position in the object frame.
            hand_quat: (4,) the palm's orientation (w x y z) in the object frame.
            observe: called with the scene at the squeeze's end, before the judging (`replay_grasp`).

        Returns:
            The replay's `Judgement` (a refused pregrasp: not held).

        Raises:
            SimulationError: the replay's physics failed.
        """
        replayed = replay_grasp(self.scene, self.grasp(posture, hand_pos, hand_quat), self.protocol,
                                self.hold_seconds, observe)
        if replayed.judgement.fault:
            raise SimulationError(replayed.judgement.fault)
        return replayed.judgement
