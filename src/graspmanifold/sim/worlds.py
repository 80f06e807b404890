"""Many grasp scenes stepped together: the physics behind the trials (`episode.run_trials`).

A `Worlds` object holds N copies of one object's scene, each already placed and posed by the
trial setup (`Scene` on the host), and offers what a batched trial needs of the physics: read the
joints, the tactile segment forces and the object's position of every world at once, command
targets, step chosen worlds by a control period, change a world's gravity, support and push, and
read one world's full tactile reading when its grasp is judged. `CpuWorlds` steps the scenes' own
MuJoCo data, one after the other; `warp_worlds.WarpWorlds` steps all of
them at once on a GPU with MuJoCo Warp, from one scene's model and what differs between the worlds at their start
(`WorldStarts`: arrays, not a scene per world).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

from ..base.errors import InvalidInput, SimulationError
from .hand import N_FINGER_JOINTS, SEGMENTS
from .scene import Scene
from .tactile import TactileReading


class Worlds(Protocol):
    """The physics of N trial scenes (see the module doc); `worlds` arguments are index arrays."""

    n: int

    @property
    def scene(self) -> Scene:
        """A scene of the worlds' model (its hand, object, sensor): the first world's on the CPU."""

    def joints(self, worlds: np.ndarray) -> np.ndarray: ...  # (len(worlds), 22)

    def segment_forces(self, worlds: np.ndarray) -> np.ndarray: ...  # (len(worlds), len(SEGMENTS))

    def object_positions(self) -> np.ndarray: ...  # (n, 3)

    def object_quats(self) -> np.ndarray: ...  # (n, 4), w x y z

    def save(self, world: int) -> np.ndarray: ...  # the world's whole simulation state

    def restore(self, world: int, state: np.ndarray) -> None: ...  # back to a saved state

    def set_targets(self, worlds: np.ndarray, targets: np.ndarray) -> None: ...

    # advance `worlds` by nstep timesteps (others may advance too); {world: why its physics failed}
    def step(self, worlds: np.ndarray, nstep: int) -> dict[int, str]: ...

    def release(self, worlds: np.ndarray) -> None: ...  # support off (and table away)

    def support(self, worlds: np.ndarray, stiffness: float, damping: float) -> None: ...  # caught where it lies

    def soften(self, worlds: np.ndarray, stiffness: np.ndarray, damping: np.ndarray) -> None: ...  # where anchored

    def set_gravity(self, worlds: np.ndarray, vectors: np.ndarray) -> None: ...

    def push(self, worlds: np.ndarray, forces: np.ndarray) -> None: ...  # extra force on the object (N)

    def shift_hands(self, worlds: np.ndarray, offsets: np.ndarray) -> None: ...  # palm offsets (m, palm frame)

    def flanges(self, worlds: np.ndarray) -> np.ndarray: ...  # (len(worlds), 6) m and rad (`Scene.flange`)

    def flange_axes(self, worlds: np.ndarray) -> np.ndarray: ...  # (len(worlds), 3, 3) the slides' world directions

    def steer_flanges(self, worlds: np.ndarray, targets: np.ndarray, period: float) -> None: ...  # (len(worlds), 6)

    def reading(self, world: int) -> tuple[TactileReading, np.ndarray]: ...  # and the object's centre of mass

    def posture(self, world: int) -> np.ndarray: ...

    def time(self, world: int) -> float: ...

    def max_penetration(self, world: int) -> float: ...


#: what `CpuWorlds.save` keeps: everything the next step depends on (positions, velocities, controls, pushes, mocap)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclass(frozen=True)
class WorldStarts:
    """What differs between N worlds of one scene's model at their start, as arrays over the worlds: the joint
    positions (N, nq), the actuators' controls (N, nu) and the mocap bodies' poses (N, nmocap, 3) m and
    (N, nmocap, 4) w x y z (the hand's mount: where the trial placed the palm). Everything else of a world's start is
    the scene's (its velocities at rest, its physics options)."""

    qpos: np.ndarray
    ctrl: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray

    @property
    def n(self) -> int:
        """The worlds."""
        return len(self.qpos)

    @classmethod
    def of_scenes(cls, scenes: list[Scene]) -> WorldStarts:
        """The starts of scenes of one model placed one per world (`episode.trial_scene`).

        Args:
            scenes: the scenes.

        Returns:
            Their starts.
        """
        return cls(*(np.array([getattr(s.data, name) for s in scenes]) for name in ("qpos", "ctrl", "mocap_pos",
                                                                                    "mocap_quat")))


class CpuWorlds:
    """Worlds stepped one after the other by CPU MuJoCo, in the scenes' own data."""

    def __init__(self, scenes: list[Scene]):
        if not scenes:
            raise InvalidInput("scenes must hold at least one Scene")
        self.scenes = scenes
        self.n = len(scenes)
        self.hand = scenes[0].hand
        if any(scene.hand.name != self.hand.name for scene in scenes):
            raise InvalidInput("the scenes of one set of worlds must hold one hand model")

    @property
    def scene(self) -> Scene:
        """The first world's scene (`Worlds.scene`)."""
        return self.scenes[0]

    def joints(self, worlds: np.ndarray) -> np.ndarray:
        return self.hand.from_model(np.array([self.scenes[w].data.qpos[self.scenes[w].finger_qpos] for w in worlds]
                                             ).reshape(-1, N_FINGER_JOINTS))

    def segment_forces(self, worlds: np.ndarray) -> np.ndarray:
        return np.array([self.scenes[w].segment_forces() for w in worlds]).reshape(-1, len(SEGMENTS))

    def object_positions(self) -> np.ndarray:
        return np.array([scene.data.xpos[scene.object_body] for scene in self.scenes])

    def object_quats(self) -> np.ndarray:
        return np.array([scene.data.xquat[scene.object_body] for scene in self.scenes])

    def save(self, world: int) -> np.ndarray:
        scene = self.scenes[world]
        state = np.empty(mujoco.mj_stateSize(scene.model, _STATE))
        mujoco.mj_getState(scene.model, scene.data, state, _STATE)
        return state

    def restore(self, world: int, state: np.ndarray) -> None:
        scene = self.scenes[world]
        mujoco.mj_setState(scene.model, scene.data, state, _STATE)
        mujoco.mj_forward(scene.model, scene.data)

    def set_targets(self, worlds: np.ndarray, targets: np.ndarray) -> None:
        ctrl = targets @ self.hand.ctrl_matrix.T  # wrist rows stay 0: the hand's wrist is held straight
        for world, row in zip(worlds, ctrl):
            self.scenes[world].data.ctrl[self.scenes[world].actuator_ids] = row

    def step(self, worlds: np.ndarray, nstep: int) -> dict[int, str]:
        failed = {}
        for world in worlds:
            scene = self.scenes[world]
            for _ in range(nstep):
                mujoco.mj_step(scene.model, scene.data)
            try:
                scene.check()
            except SimulationError as error:
                failed[int(world)] = str(error)
        return failed

    def release(self, worlds: np.ndarray) -> None:
        for world in worlds:
            scene = self.scenes[world]
            scene.set_object_support(0.0, 0.0)
            if scene.table_geom is not None:
                scene.set_table(False)

    def support(self, worlds: np.ndarray, stiffness: float, damping: float) -> None:
        for world in worlds:
            self.scenes[world].anchor_object_support()
            self.scenes[world].set_object_support(stiffness, damping)

    def soften(self, worlds: np.ndarray, stiffness: np.ndarray, damping: np.ndarray) -> None:
        for world, k, d in zip(worlds, stiffness, damping):
            if self.scenes[world].table_geom is None:  # a table has no spring to soften
                self.scenes[world].set_object_support(float(k), float(d))

    def set_gravity(self, worlds: np.ndarray, vectors: np.ndarray) -> None:
        for world, vector in zip(worlds, vectors):
            self.scenes[world].model.opt.gravity[:] = vector

    def push(self, worlds: np.ndarray, forces: np.ndarray) -> None:
        for world, force in zip(worlds, forces):
            scene = self.scenes[world]
            scene.data.xfrc_applied[scene.object_body, :3] = force

    def shift_hands(self, worlds: np.ndarray, offsets: np.ndarray) -> None:
        for world, offset in zip(worlds, offsets):
            self.scenes[world].shift_hand(offset)

    def flanges(self, worlds: np.ndarray) -> np.ndarray:
        return np.array([self.scenes[w].flange() for w in worlds]).reshape(-1, 6)

    def flange_axes(self, worlds: np.ndarray) -> np.ndarray:
        return np.array([self.scenes[w].flange_axes() for w in worlds]).reshape(-1, 3, 3)

    def steer_flanges(self, worlds: np.ndarray, targets: np.ndarray, period: float) -> None:
        for world, target in zip(worlds, targets):
            self.scenes[world].steer_flange(target, period)

    def reading(self, world: int) -> tuple[TactileReading, np.ndarray]:
        scene = self.scenes[world]
        return scene.tactile(), scene.data.xipos[scene.object_body].copy()

    def posture(self, world: int) -> np.ndarray:
        return self.scenes[world].posture()

    def time(self, world: int) -> float:
        return self.scenes[world].time

    def max_penetration(self, world: int) -> float:
        return self.scenes[world].max_penetration

