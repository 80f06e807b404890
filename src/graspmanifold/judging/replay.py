"""The one replay of an open-loop grasp (`replay_grasp`: DexGraspBench's approach, then the protocol's judging), over
many grasps (`replay`), and the generator's verifier that runs it on each candidate (`GraspVerifier`).

The plan value is `plans.OpenLoopGrasp`; DexGraspBench's approach and push test are `push_test`; its Q1 metric is
`quality.q1`. A planned trial's open-loop controller is `trials.open_loop` (a trial's controller, not a judge).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..base.errors import SimulationError
from ..base.moved import moved_attribute
from ..sim.hand import SHADOW_HAND, HandModel
from ..sim.objects import GraspObject
from ..sim.scene import Scene
from .judge import VERIFY_HOLD_SECONDS, Judgement, judge_scene
from .plans import GRASP_STAGES, VERIFY_STAGES, GraspStages, OpenLoopGrasp, open_loop_grasp
from .protocols import DEFAULT_PROTOCOL, DEXGRASPBENCH, JudgingProtocol, get_protocol
from .push_test import external_force_test, move_through_stages, start_at_pregrasp


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
    mounts = start_at_pregrasp(scene, grasp)
    depth = scene.penetration()
    if depth > DEXGRASPBENCH.max_penetration:  # its rule for a pregrasp, whatever judges the grasp
        return Replay(Judgement(0.0, False, np.inf, np.nan, penetration=depth),
                      f"the pregrasp starts {depth * 1000:.1f} mm inside the object")
    move_through_stages(scene, grasp, mounts, timed)  # its targets and their seconds, the scene's physics
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


def __getattr__(name: str) -> object:
    """The names that left this module in 0.3 (the plan value, the push test, Q1, the open-loop controller), with
    a warning (`base.moved.MOVED_NAMES`)."""
    return moved_attribute(__name__, name)
