"""DexGraspBench's execution of an open-loop grasp and its external-force test (the push test).

DexGraspBench (with BODex, ICRA 2025) judges *open-loop* grasps, each a pregrasp, a grasp and a squeeze
(a hand root pose and joint angles): once per direction of +x, -x, +y, -y, +z and -z it resets the scene
to the pregrasp (a hand that starts more than `max_penetration` inside the object fails outright), moves
pregrasp -> grasp and grasp -> squeeze in `approach_targets` interpolated targets of `steps_per_target`
physics steps each (the root by its mocap body, the joints by their servos: `start_at_pregrasp`,
`move_through_stages`, which the replay runs too), pushes the object with an external force of `force_per_kg` x
the direction x its mass (gravity off), and simulates `hold_chunks` x `steps_per_chunk` steps, stopping early once the object has moved more
than `translation_limit` or turned more than `angle_limit` from where it began. A grasp succeeds when it stays within
both in every direction. Its versions and its physics profile are protocols of `protocols` (`DexGraspBenchProtocol`,
`PROTOCOLS`); its Q1 metric is `quality.q1`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from ..base.errors import InvalidInput
from ..sim.scene import Scene
from .judge import reading_epsilon
from .plans import OpenLoopGrasp
from .protocols import DEXGRASPBENCH, DexGraspBenchProtocol

#: the state an approach's end is saved in and restored from (MuJoCo's whole integration state)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


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


def start_at_pregrasp(scene: Scene, grasp: OpenLoopGrasp) -> list[tuple[np.ndarray, np.ndarray]]:
    """The scene reset to the pregrasp (the object free, unsupported, gravity off: a hold test before left it
    on).

    Args:
        scene: a scene of the object, free (`Scene(obj, free_object=True)`); its state changes.
        grasp: the grasp.

    Returns:
        The hand mount's pose (position m, orientation w x y z) of each stage.
    """
    scene.reset()
    scene.set_gravity(False)
    scene.set_object_support(0.0, 0.0)
    scene.set_posture(grasp.postures[0])
    mounts = [scene.mount_pose_for(pose[:3], pose[3:]) for pose in grasp.poses]
    scene.data.mocap_pos[scene.mount_id], scene.data.mocap_quat[scene.mount_id] = mounts[0]
    scene.forward()
    return mounts


def move_through_stages(scene: Scene, grasp: OpenLoopGrasp, mounts: list,
                        protocol: DexGraspBenchProtocol) -> int:
    """Pregrasp -> grasp -> squeeze in the protocol's interpolated targets (after `start_at_pregrasp`).

    Args:
        scene: the scene at the pregrasp.
        grasp: the grasp.
        mounts: the hand mount's pose of each stage (`start_at_pregrasp`'s).
        protocol: the test whose targets and steps per target the approach takes.

    Returns:
        The physics steps taken.
    """
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
    mounts = start_at_pregrasp(scene, grasp)
    depth = scene.penetration()
    if depth > protocol.max_penetration:
        return ForceTest(False, translation, rotation, depth, 0, f"the pregrasp starts {depth * 1000:.1f} mm "
                         f"inside the object (the protocol allows {protocol.max_penetration * 1000:.0f} mm)")
    start_position, start_quat = scene.object_pose()
    steps = move_through_stages(scene, grasp, mounts, protocol)
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
