"""Trial scenes stepped all at once on a GPU with MuJoCo Warp (the optional `gpu` extra).

`WarpWorlds` makes one batched MuJoCo Warp model and data of one scene's model and what differs between the
worlds at their start (`worlds.WorldStarts`: joint positions, controls, the hand mount's pose, as arrays: no scene
is built per world; gravity, the object support and the push are per world too) and steps them together, a control
period per CUDA graph launch. Touch per segment, the deepest contact of each
world and the contacts of a world being judged come from Warp's contact arrays through two small
kernels; epsilon is computed on the host from those contacts, as for CPU trials. Warp computes
in single precision and orders its contacts differently, so its trials agree with the CPU's
trial by trial on most poses, not bit for bit (BENCHMARKS.md measures how often).

    pip install 'graspmanifold[gpu]'   # (from a checkout: '.[gpu]') mujoco-warp and warp-lang; an NVIDIA GPU

A machine without a CUDA device refuses the backend; GRASPMANIFOLD_WARP_DEVICE=cpu runs Warp's
CPU device instead (slow: for developing and testing this module without a GPU).
"""

from __future__ import annotations

import os

import numpy as np

from ..base.errors import BackendUnavailable, InvalidInput, SimulationError
from .hand import SEGMENTS, SHADOW_HAND, segment_of_geoms
from .scene import PENETRATION_LIMIT, Scene
from .tactile import TactileReading
from .worlds import WorldStarts

try:
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING  # no banner, no line per loaded kernel module
    import mujoco_warp as mjw
except ImportError as error:  # pragma: no cover - depends on the installation
    raise ImportError("backend='warp' needs MuJoCo Warp: pip install 'graspmanifold[gpu]' (from a checkout: "
                      f"pip install '.[gpu]'; mujoco-warp and warp-lang; {error})") from error

#: contacts and constraint rows allocated per world: twice the most measured in a world of the benchmark objects
#: with the hand closed hard on them (the quick grid; 19 contacts and 107 rows, on the disc: BENCHMARKS.md), so that
#: MuJoCo Warp's per-world buffers are no larger than a grasp needs (at 8,192 worlds 48 and 320 took put_data 4x as
#: long); a world that needs more stops the trials with `SimulationError` (the overflow check of every step)
CONTACTS_PER_WORLD = 40
CONSTRAINTS_PER_WORLD = 224

#: what a flanged hand (the palm moved by an arm, `sim.flange`) on the GPU answers
_FLANGE_ON_CPU = ("a hand on a flange (TrialSetup(palm=...), the lift protocol) runs on the CPU backend only: "
                  "evaluate(..., backend='cpu')")


@wp.kernel
def _touch(nacon: wp.array(dtype=int), worldid: wp.array(dtype=int), geom: wp.array(dtype=wp.vec2i),
           dist: wp.array(dtype=float), efc_address: wp.array2d(dtype=int), efc_force: wp.array2d(dtype=float),
           segment_of_geom: wp.array(dtype=int), object_geom: wp.array(dtype=int),
           normal_force: wp.array(dtype=float), segment_forces: wp.array2d(dtype=float),
           deepest: wp.array(dtype=float)):
    """Per contact: its normal force; per world: the summed force on each segment and the deepest contact."""
    c = wp.tid()
    if c >= nacon[0]:
        return
    world = worldid[c]
    wp.atomic_max(deepest, world, -dist[c])
    address = efc_address[c, 0]
    force = float(wp.nan)
    if address >= 0:
        force = efc_force[world, address]  # elliptic cones: the first row is the normal force
    normal_force[c] = force
    g1, g2 = geom[c][0], geom[c][1]
    segment = int(-1)
    if segment_of_geom[g1] >= 0 and object_geom[g2] != 0:
        segment = segment_of_geom[g1]
    if segment_of_geom[g2] >= 0 and object_geom[g1] != 0:
        segment = segment_of_geom[g2]
    if segment >= 0 and address >= 0 and force >= 0.0:
        wp.atomic_add(segment_forces, world, segment, force)


@wp.kernel
def _push(xfrc_applied: wp.array2d(dtype=wp.spatial_vector), body: int, forces: wp.array(dtype=wp.vec3)):
    world = wp.tid()
    f = forces[world]
    xfrc_applied[world, body] = wp.spatial_vector(f[0], f[1], f[2], 0.0, 0.0, 0.0)


def _device() -> wp.Device:
    wanted = os.environ.get("GRASPMANIFOLD_WARP_DEVICE")
    if wanted:
        return wp.get_device(wanted)
    if not wp.get_cuda_device_count():
        raise BackendUnavailable("backend='warp' needs an NVIDIA GPU with CUDA, and Warp found none on this machine "
                           "(use backend='cpu'; GRASPMANIFOLD_WARP_DEVICE=cpu runs Warp's slow CPU device)")
    return wp.get_device("cuda")


class WarpWorlds:
    """The `worlds.Worlds` of N trials of one scene's model, stepped together by MuJoCo Warp (see the module doc).

    Args:
        scene: the scene whose model every world runs (its hand, object, support and physics options).
        starts: what differs between the worlds at their start (`episode.trial_starts` makes them for trials).
    """

    def __init__(self, scene: Scene, starts: WorldStarts):
        if starts.n < 1:
            raise InvalidInput("starts must hold at least one world")
        if scene.table_geom is not None:
            raise InvalidInput("backend='warp' does not support table=True (the table is taken away per world)")
        if scene.hand.name != SHADOW_HAND.name:
            raise InvalidInput(f"backend='warp' runs our hand model only, not {scene.hand.name!r}: use backend='cpu'")
        mjm = scene.model
        if starts.qpos.shape[1:] != (mjm.nq,) or starts.ctrl.shape[1:] != (mjm.nu,):
            raise InvalidInput(f"starts must hold (n, {mjm.nq}) joint positions and (n, {mjm.nu}) controls of the "
                               f"scene's model, got {starts.qpos.shape} and {starts.ctrl.shape}")
        self.scene, self.n = scene, starts.n
        self._object_body, self._finger_qpos = scene.object_body, scene.finger_qpos
        self.device = _device()
        n = self.n
        with wp.ScopedDevice(self.device):
            self._m = mjw.put_model(mjm, batch_sizes={"jnt_stiffness": n, "dof_damping": n})
            # one gravity per world: MuJoCo Warp's kernels read a model array at worldid modulo its leading size
            self._m.opt.gravity = wp.array(np.tile(mjm.opt.gravity, (n, 1)), dtype=wp.vec3)
            self._d = mjw.put_data(mjm, scene.data, nworld=n, nconmax=CONTACTS_PER_WORLD,
                                   njmax=CONSTRAINTS_PER_WORLD)
            self._d.qpos.assign(starts.qpos)
            self._ctrl = np.array(starts.ctrl)  # the controls, kept here: a period's targets go one way only
            self._d.ctrl.assign(self._ctrl)
            self._d.mocap_pos.assign(starts.mocap_pos)
            self._d.mocap_quat.assign(starts.mocap_quat)
            self._stiffness = np.tile(mjm.jnt_stiffness, (n, 1))
            self._damping = np.tile(mjm.dof_damping, (n, 1))
            self._gravity = np.tile(mjm.opt.gravity, (n, 1))
            self._push_forces = wp.zeros(n, dtype=wp.vec3)
            self._segment_of_geom: wp.array = wp.array(segment_of_geoms(mjm).astype(np.int32), dtype=int)
            self._object_geom: wp.array = wp.array((mjm.geom_bodyid == scene.object_body).astype(np.int32), dtype=int)
            self._normal_force = wp.zeros(self._d.naconmax, dtype=float)
            self._segment_forces = wp.zeros((n, len(SEGMENTS)), dtype=float)
            self._deepest = wp.zeros(n, dtype=float)
            mjw.forward(self._m, self._d)
        self._graph, self._graph_steps = None, 0
        self._max_penetration = np.zeros(n)
        self._observe()

    @classmethod
    def from_scenes(cls, scenes: list[Scene]) -> WarpWorlds:
        """The worlds of scenes of one model placed one per world (`episode.trial_scene`).

        Args:
            scenes: the scenes (at least one).

        Returns:
            The worlds, the first scene's model with every scene's start.
        """
        if not scenes:
            raise InvalidInput("scenes must hold at least one Scene")
        if any(s.hand.name != scenes[0].hand.name or s.object.name != scenes[0].object.name for s in scenes):
            raise InvalidInput("the scenes of one set of worlds must hold one hand model and one object")
        return cls(scenes[0], WorldStarts.of_scenes(scenes))

    def __repr__(self) -> str:
        return f"WarpWorlds({self.n} worlds of the {self.scene.object.name} scene on {self.device})"

    # -- reading ------------------------------------------------------------------------------------
    def _observe(self) -> None:
        """Read what the trials need of every world after a step (one transfer per array)."""
        d = self._d
        with wp.ScopedDevice(self.device):
            self._segment_forces.zero_()
            self._deepest.fill_(-1.0)
            wp.launch(_touch, dim=d.naconmax, inputs=[d.nacon, d.contact.worldid, d.contact.geom, d.contact.dist,
                                                      d.contact.efc_address, d.efc.force, self._segment_of_geom,
                                                      self._object_geom],
                      outputs=[self._normal_force, self._segment_forces, self._deepest])
        self._qpos = d.qpos.numpy().astype(float)
        self._qvel = d.qvel.numpy()
        self._xpos = d.xpos.numpy()[:, self._object_body].astype(float)
        self._forces = self._segment_forces.numpy().astype(float)
        self._penetration = np.maximum(self._deepest.numpy().astype(float), 0.0)
        self._contacts: dict | None = None

    def joints(self, worlds: np.ndarray) -> np.ndarray:
        return self._qpos[np.ix_(worlds, self._finger_qpos)]

    def segment_forces(self, worlds: np.ndarray) -> np.ndarray:
        return self._forces[worlds]

    def object_positions(self) -> np.ndarray:
        return self._xpos.copy()

    def reading(self, world: int) -> tuple[TactileReading, np.ndarray]:
        if self._contacts is None:
            d = self._d
            count = min(int(d.nacon.numpy()[0]), d.naconmax)
            self._contacts = {"world": d.contact.worldid.numpy()[:count], "geom": d.contact.geom.numpy()[:count],
                              "force": self._normal_force.numpy()[:count].astype(float),
                              "frame": d.contact.frame.numpy()[:count].astype(float),
                              "pos": d.contact.pos.numpy()[:count].astype(float),
                              "dist": d.contact.dist.numpy()[:count].astype(float),
                              "xipos": d.xipos.numpy()[:, self._object_body].astype(float)}
        c = self._contacts
        rows = c["world"] == world
        reading = self.scene.sensor.reading(c["geom"][rows], c["force"][rows], c["frame"][rows][:, 0, :],
                                                c["pos"][rows], c["dist"][rows])
        return reading, c["xipos"][world].copy()

    def posture(self, world: int) -> np.ndarray:
        return self._qpos[world, self._finger_qpos].copy()

    def time(self, world: int) -> float:
        return float(self._d.time.numpy()[world])

    def max_penetration(self, world: int) -> float:
        return float(self._max_penetration[world])

    # -- acting ---------------------------------------------------------------------------------------
    def set_targets(self, worlds: np.ndarray, targets: np.ndarray) -> None:
        self._ctrl[worlds] = targets @ self.scene.hand.ctrl_matrix.T
        self._d.ctrl.assign(self._ctrl)

    def release(self, worlds: np.ndarray) -> None:
        joint = self.scene.model.joint("object_free")
        self._stiffness[worlds, joint.id] = 0.0
        self._damping[np.ix_(worlds, np.arange(joint.dofadr[0], joint.dofadr[0] + 6))] = 0.0
        self._m.jnt_stiffness.assign(self._stiffness)
        self._m.dof_damping.assign(self._damping)

    def soften(self, worlds: np.ndarray, stiffness: np.ndarray, damping: np.ndarray) -> None:
        joint = self.scene.model.joint("object_free")
        self._stiffness[worlds, joint.id] = stiffness
        self._damping[np.ix_(worlds, np.arange(joint.dofadr[0], joint.dofadr[0] + 6))] = np.asarray(damping)[:, None]
        self._m.jnt_stiffness.assign(self._stiffness)
        self._m.dof_damping.assign(self._damping)

    def support(self, worlds: np.ndarray, stiffness: float, damping: float) -> None:
        raise InvalidInput("re-engaging the support where the object lies (a regrasp) runs on the cpu backend only")

    def object_quats(self) -> np.ndarray:
        raise InvalidInput("the objects' orientations (DexGraspBench's angle limit) are read on the cpu backend only")

    def save(self, world: int) -> np.ndarray:
        raise InvalidInput("saving a world's state (DexGraspBench's protocol) runs on the cpu backend only")

    def restore(self, world: int, state: np.ndarray) -> None:
        raise InvalidInput("restoring a world's state (DexGraspBench's protocol) runs on the cpu backend only")

    def set_gravity(self, worlds: np.ndarray, vectors: np.ndarray) -> None:
        if len(worlds):
            self._gravity[worlds] = vectors
            self._m.opt.gravity.assign(self._gravity)

    def push(self, worlds: np.ndarray, forces: np.ndarray) -> None:
        if len(worlds):
            pushes = self._push_forces.numpy()
            pushes[worlds] = forces
            self._push_forces.assign(pushes)
            with wp.ScopedDevice(self.device):
                wp.launch(_push, dim=self.n, inputs=[self._d.xfrc_applied, self._object_body, self._push_forces])

    def shift_hands(self, worlds: np.ndarray, offsets: np.ndarray) -> None:
        raise NotImplementedError("the controller's reach (a recall moving the palm, ControllerParams.reach) runs on "
                                  "the CPU backend only: evaluate(..., backend='cpu')")

    def flanges(self, worlds: np.ndarray) -> np.ndarray:
        raise NotImplementedError(_FLANGE_ON_CPU)

    def flange_axes(self, worlds: np.ndarray) -> np.ndarray:
        raise NotImplementedError(_FLANGE_ON_CPU)

    def steer_flanges(self, worlds: np.ndarray, targets: np.ndarray, period: float) -> None:
        raise NotImplementedError(_FLANGE_ON_CPU)

    def step(self, worlds: np.ndarray, nstep: int) -> dict[int, str]:
        """Step every world (the finished ones too: it costs nothing extra on a GPU); report the
        faults of `worlds`."""
        with wp.ScopedDevice(self.device):
            if self.device.is_cuda:
                graph = self._graph
                if graph is None or self._graph_steps != nstep:
                    self._warm_up()
                    with wp.ScopedCapture() as capture:
                        for _ in range(nstep):
                            mjw.step(self._m, self._d)
                    graph, self._graph_steps = capture.graph, nstep
                    self._graph = graph
                wp.capture_launch(graph)  # a control period's steps in one launch
            else:
                for _ in range(nstep):
                    mjw.step(self._m, self._d)
        overflow = self.overflow()
        if overflow.any():  # a lost contact or constraint row makes every world's physics suspect
            worst = np.flatnonzero(overflow)
            raise SimulationError(f"MuJoCo Warp's buffers overflowed in {len(worst)} of {self.n} worlds (world "
                                  f"{worst[0]}: flags {int(overflow[worst[0]]):#x}): more than {CONTACTS_PER_WORLD} "
                                  f"contacts or {CONSTRAINTS_PER_WORLD} constraint rows in a world")
        self._observe()
        self._max_penetration = np.maximum(self._max_penetration, self._penetration)
        return self._faults(np.asarray(worlds, dtype=int))

    def _faults(self, worlds: np.ndarray) -> dict[int, str]:
        """Why the physics of these worlds failed, for those whose did (found over all of them at once; the
        words are made only for a failed world)."""
        broken = ~(np.isfinite(self._qpos[worlds]).all(axis=1) & np.isfinite(self._qvel[worlds]).all(axis=1))
        deep = self._penetration[worlds] > PENETRATION_LIMIT
        failed = {}
        for world, nan, depth in zip(worlds[broken | deep].tolist(), broken[broken | deep], deep[broken | deep]):
            found = ["non-finite joint positions or velocities"] if nan else []
            if depth:
                found.append(f"a contact penetrates {self._penetration[world] * 1000:.1f} mm "
                             f"(limit {PENETRATION_LIMIT * 1000:.0f} mm)")
            failed[world] = (f"the simulation of the {self.scene.object.name} scene failed at "
                             f"t = {self.time(world):.3f} s: {'; '.join(found)}")
        return failed

    def overflow(self) -> np.ndarray:
        """MuJoCo Warp's overflow flags of every world (n,) int (`mujoco_warp.OverflowType`; 0: none so far)."""
        return np.broadcast_to(self._d.overflow.numpy(), (self.n,)).astype(int)

    def _warm_up(self) -> None:
        """Compile every kernel of a step (a graph capture cannot) on a one-world copy of the data."""
        scene = self.scene
        spare = mjw.put_data(scene.model, scene.data, nworld=1, nconmax=CONTACTS_PER_WORLD,
                             njmax=CONSTRAINTS_PER_WORLD)
        mjw.step(self._m, spare)
        wp.synchronize()
