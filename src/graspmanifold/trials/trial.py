"""Grasp trials: place the object at a grid pose, let the controller close the hand, judge the grasp.

A trial puts a free object (gravity off) in front of the open hand at one grid pose (`grid.py`),
runs the controller until it reports the grasp done, and then judges the grasp (`judge.judge_worlds`:
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
"""

from __future__ import annotations

import builtins
import dataclasses
import functools
import hashlib
import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
from scipy.spatial.transform import Rotation

from ..base.checkpoints import code_identity, result_key
from ..base.errors import InvalidInput
from ..base.io import library_version
from ..base.validation import check_choice, check_data, check_int
from ..control.controller import CONTROLLERS, BatchController, Controller, ControllerFactory, ControllerParams
from ..control.regrasp import LiftProbe, Regrasp, RestartingController
from ..judging.judge import JUDGING, Judgement, judge_worlds, supported_scene
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOLS, JudgingProtocol, get_protocol
from ..judging.replay import OpenLoopGrasp
from ..judging.stages import JudgingRules
from ..manifold.experience import Experience, carried_values, check_experience, check_within_hand
from ..manifold.postureset import PostureSet
from ..sim.flange import FlangeLimits
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, get_object
from ..sim.scene import TOUCH_SOURCES, Scene
from ..sim.worlds import CpuWorlds, Worlds, WorldStarts
from .grid import (START_CLEARANCE, check_grid, clearance, displaced_palm_pose, grid_preset, oracle_correction,
                   palm_pose_for, palm_poses_for, reachable)

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


#: the length of `Trial.first_contact` (time, joints, segment forces) and of `Trial.failure` (joints, forces)
FIRST_CONTACT_FEATURES = 1 + N_FINGER_JOINTS + len(SEGMENTS)
FAILURE_FEATURES = N_FINGER_JOINTS + len(SEGMENTS)

#: s of simulated time after which a world whose controller never reports its grasp done is judged as it is
MAX_GRASP_SECONDS = 600.0
#: the oracle corrections besides the full one (`TrialSetup.oracle=True`): 'translation', the palm moved by the
#: displacement's translation and not turned by its yaw
ORACLES: tuple[str, ...] = ("translation",)
#: s the oracle's correction waits, after its flange's set point has arrived, for the servos to bring the palm there
ORACLE_SETTLE_SECONDS = 0.2

#: the physics engines trials run on: CPU MuJoCo, or MuJoCo Warp on an NVIDIA GPU (`warp_worlds.py`)
BACKENDS = ("cpu", "warp")
#: trials the warp backend runs at once by default (worlds on the GPU)
WARP_BATCH = 16384


def method_name(experience: Experience | None) -> str:
    """The default label of a method: 'none' (the plain tactile controller), 'database' or 'som'.

    Args:
        experience: the experience base.

    Returns:
        The label.
    """
    return "none" if experience is None else type(experience).__name__.replace("PostureDatabase", "database").lower()


def _named(value: object) -> str:
    """A value JSON does not know (a stage class, a callable, a factory object) by its qualified name (an instance by
    its class's), never its address."""
    return f"{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', type(value).__qualname__)}"


def _digest(data: bytes) -> str:
    """A 16-character SHA-256 digest, for a result's record of what made it."""
    return hashlib.sha256(data).hexdigest()[:16]


def _carried_digests(experience: Experience | None) -> dict[str, str]:
    """A digest of each value an experience carries besides its postures (`carried_values`: places, squeezes)."""
    return {name: _digest(np.ascontiguousarray(value).tobytes()) for name, value in carried_values(experience).items()}


@dataclass(frozen=True, eq=False, kw_only=True)
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
        controller: the controller: one of ours by its registered name (`controller.CONTROLLERS`: 'paper', 'blend',
            'closing-recall'; it becomes `params`, as the CLI's `--controller` names it), or a user's own, a factory:
            `controller(n, hand)` returns a `controller.Controller` for n worlds (a module-level class or function,
            for worker processes); it brings its own experience and parameters (`experience`, `preshape`, `params`
            stay at their defaults), and `method` names it. None: ours with `params`.
        margin: measure the disturbance margin of every grasp that holds (`judge` module doc; up to 1.8 s more
            simulation per held grasp); False: `Trial.margin` is NaN.
        protocol: how the grasps are judged (`protocols.JudgingProtocol`, a registered name is looked up): our hold test
            (`protocols.DEFAULT_PROTOCOL`, `judge.JUDGING`) or DexGraspBench's ('dexgraspbench',
            'dexgraspbench-paper': its physics profile from the start, its external-force test after the grasp).
        regrasp: the controller's attempts, its lift probe and how it chooses the next attempt (`regrasp.Regrasp`;
            the default: one attempt, the paper's). A user's own controller with more attempts needs `attempt` and
            `restart` (as `BatchController` has them).
        batch_size: trials at once on the GPU with the 'warp' backend (not part of the trials' key: it changes
            no outcome).
        touch: where the segment forces the controller senses come from (`scene.TOUCH_SOURCES`): 'contacts' (the
            hand-object contacts' normal forces summed per segment, ours), 'sensors' (MuJoCo's touch sensors, a site
            over each segment) or 'contact-sensors' (MuJoCo's contact sensors between each segment and the object);
            the sensors on the cpu backend.
        plan: a planned grasp (`replay.OpenLoopGrasp`, palm poses in the object's frame) or None. With a
            plan, a trial's pose (x, z, gap, yaw) is the object's displacement from where the plan assumed it (palm
            frame, `grid.displaced_palm_pose`): the hand starts in the plan's pregrasp, its palm where the plan puts
            it for the nominal pose, and the object lies displaced; the controller is not told the displacement (ours
            starts from the pregrasp's posture). The plan's open-loop execution is the controller
            `replay.OpenLoop(plan)`.
        palm: the hand on an arm's flange with these limits (`sim.flange.FlangeLimits`: the palm's six degrees of
            freedom, servoed, lockable; the cpu backend), or None: the palm stays where the trial put it. A protocol
            whose judging moves the palm (the lift: `JudgingRules.needs_flange`) gets the default flange where none
            is given. The flange alone moves nothing: the controller's `ControllerParams.palm` steers it
            (`control.controller.PALM_TOUCH`, `PALM_EXPERIENCE`; the CLI's `--palm-steering`).
        oracle: the oracle correction, a ceiling and not a controller (issue 66): with a plan and a palm, the
            flange first carries the palm by the object's true displacement (the trial's pose, `grid.
            oracle_correction`) to where the plan puts it for the displaced object, the fingers held in their
            starting posture, and only then does the controller start (the palm then moves from there). The only
            trials that read the displacement: their `method` must say 'oracle'. 'translation': the palm moved by the
            displacement's translation alone, not turned by its yaw (`ORACLES`).

    Fields are given by name: `TrialSetup(object="box", experience=som, protocol="dexgraspbench")`; `build` is
    what the keyword conveniences (`evaluate`, `record_trial`, `run_benchmark`) make theirs with.
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
    controller: str | ControllerFactory | None = None
    margin: bool = False
    regrasp: Regrasp = Regrasp()
    protocol: JudgingProtocol = get_protocol(DEFAULT_PROTOCOL)
    batch_size: int = WARP_BATCH
    touch: str = "contacts"
    plan: OpenLoopGrasp | None = None
    palm: FlangeLimits | None = None
    oracle: bool | str = False

    def __post_init__(self) -> None:
        set_field = functools.partial(object.__setattr__, self)
        set_field("object", get_object(self.object))
        set_field("hand", self.hand if isinstance(self.hand, HandModel) else hand_model(self.hand))
        if isinstance(self.experience, PostureSet) and self.experience.hand != self.hand.name:
            raise InvalidInput(f"the experience holds postures of the {self.experience.hand!r} "
                               f"hand; these trials run the {self.hand.name!r} hand")
        if self.backend == "warp" and self.hand.name != SHADOW_HAND.name:
            raise InvalidInput(f"backend='warp' runs our hand model only, not {self.hand.name!r}: use backend='cpu'")
        set_field("experience", check_experience(self.experience))
        if self.experience is not None:
            check_within_hand(self.experience, self.hand.limits(), self.hand.name)
        self._check_controller(set_field)
        check_choice(self.backend, BACKENDS, "backend")
        set_field("regrasp", self.regrasp or Regrasp())
        if not isinstance(self.regrasp, Regrasp):
            raise InvalidInput(f"regrasp must be a Regrasp, got {type(self.regrasp).__name__}")
        self.regrasp.check_trials(self.experience, self.hand, self.table, self.backend)
        set_field("protocol", get_protocol(self.protocol))
        self.protocol.check_trials(self.table, self.backend, self.margin)
        set_field("method", self.method or method_name(self.experience))
        set_field("table", bool(self.table))
        set_field("margin", bool(self.margin))
        set_field("batch_size", check_int(self.batch_size, "batch_size"))
        self._check_plan_and_palm(set_field)
        check_choice(self.touch, TOUCH_SOURCES, "touch")
        if self.touch != "contacts" and self.backend != "cpu":
            raise InvalidInput(f"touch={self.touch!r} reads MuJoCo's sensors on the cpu backend: use backend='cpu'")

    def _check_controller(self, set_field: Callable[[str, builtins.object], None]) -> None:
        """The controller: ours with `params` (a registered name becomes its parameters), or a user's factory that
        brings its own experience and parameters; the noise and the method label."""
        set_field("params", self.params or ControllerParams())
        if isinstance(self.controller, str):  # one of ours by name: its parameters
            if self.params != ControllerParams():
                raise InvalidInput(f"controller={self.controller!r} names one of ours with its parameters: give no "
                                   "params beside it")
            set_field("params", CONTROLLERS[check_choice(self.controller, tuple(CONTROLLERS), "controller",
                                                         also="or a factory controller(n, hand)")])
            set_field("controller", None)
        set_field("noise", self.noise or Noise())
        if not isinstance(self.noise, Noise) or not isinstance(self.params, ControllerParams):
            raise InvalidInput(f"noise must be a Noise and params ControllerParams, got {type(self.noise).__name__} "
                               f"and {type(self.params).__name__}")
        if not isinstance(self.method, str):
            raise InvalidInput(f"method must be a label (a string), got {self.method!r}")
        if self.controller is not None and not (callable(self.controller) and self.method):
            raise InvalidInput(f"controller must be a callable controller(n, hand) that returns a Controller, with "
                               f"a method label (method='...') to name its results; got {self.controller!r}")
        if self.controller is not None and not (self.experience is None and self.preshape is None
                                                and self.params == ControllerParams()):
            raise InvalidInput("a custom controller brings its own experience and parameters: leave experience, "
                               "preshape and params at their defaults")

    def _check_plan_and_palm(self, set_field: Callable[[str, builtins.object], None]) -> None:
        """A plan, the palm's flange (the protocol's where none is given) and the oracle that needs both."""
        if self.plan is not None and not isinstance(self.plan, OpenLoopGrasp):
            raise InvalidInput(f"plan must be an OpenLoopGrasp (replay.open_loop_grasp makes one), got "
                               f"{type(self.plan).__name__}")
        if self.plan is not None and (self.noise.position or self.noise.yaw):
            raise InvalidInput("a planned trial's pose is the object's displacement itself: give no position or yaw "
                               "noise beside a plan")
        if self.palm is None:
            set_field("palm", self.protocol.flange)
        if self.palm is None and self.params.palm.active:  # steering with nothing to steer moved nothing silently
            raise InvalidInput("ControllerParams.palm steers the palm on an arm, but these trials have none: give "
                               "palm=FlangeLimits() (the CLI's --palm)")
        if isinstance(self.palm, FlangeLimits):
            self.protocol.check_arm(self.palm, self.object.mass)
        if self.palm is not None and (not isinstance(self.palm, FlangeLimits) or self.backend != "cpu"):
            raise InvalidInput(f"palm must be a FlangeLimits (the hand on an arm's flange) with the cpu backend, got "
                               f"{self.palm!r} with backend={self.backend!r}")
        if not (isinstance(self.oracle, bool) or self.oracle in ORACLES):
            raise InvalidInput(f"oracle must be True, False or one of {ORACLES}, got {self.oracle!r}")
        if self.oracle and (self.plan is None or self.palm is None or "oracle" not in self.method):
            raise InvalidInput("oracle=True moves the palm by the true displacement of a planned trial: it needs a "
                               "plan, a palm (the flange that carries it) and a method that says 'oracle', got "
                               f"plan={'given' if self.plan is not None else None}, palm={self.palm!r}, "
                               f"method={self.method!r}")

    @classmethod
    def build(cls, obj: str | GraspObject | TrialSetup, experience: Experience | None = None,
              **fields: Any) -> TrialSetup:  # Any: the fields are checked by the set-up, each by its owner
        """The set-up a keyword convenience describes: one given whole, or one of the object, the experience and
        the fields named.

        Args:
            obj: the object, its name, or a whole `TrialSetup` (then nothing else may be given).
            experience: the experience base (None: the plain tactile controller).
            **fields: any other field by name (None for noise, params or regrasp: its default).

        Returns:
            The `TrialSetup`.

        Raises:
            InvalidInput: a field that a set-up does not have, or fields beside a whole set-up.
        """
        if isinstance(obj, TrialSetup):
            if experience is not None or fields:
                raise InvalidInput(f"a TrialSetup is given whole: give no experience or fields beside it (got "
                                   f"{sorted(fields) + (['experience'] if experience is not None else [])}); "
                                   "dataclasses.replace(setup, ...) changes one")
            return obj
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(fields) - set(names))
        if unknown:
            raise InvalidInput(f"unknown trial set-up field(s) {unknown}; a TrialSetup has {names}")
        return cls(object=get_object(obj), experience=experience, **fields)

    @property
    def rules(self) -> JudgingRules:
        """The judging rules of these trials: their protocol's (`JUDGING` for ours), with the margin where it is
        asked for."""
        return replace(self.protocol.rules, margin=self.margin)

    def key(self, poses: np.ndarray, seed: int) -> str:
        """The `checkpoints.result_key` of this set-up's trials at these poses: of the experience, what a
        controller reads of it (its kind, its reference postures and what it carries: places, squeezes), never a
        pickle; of the hand, its content
        (`HandModel.digest`); not the label.

        Args:
            poses: grid poses (n, 4), m and rad.
            seed: the trials' seed.

        Returns:
            A 20-character hexadecimal key.
        """
        experience, custom = self.experience, self.controller
        return result_key({"object": self.object.params(), "seed": int(seed), "noise": asdict(self.noise),
                           "params": self.params.to_table(), "table": self.table, "backend": self.backend,
                           "margin": self.margin,
                           "experience": None if experience is None else type(experience).__name__,
                           "hand": self.hand.digest, "controller": None if custom is None else
                           f"{getattr(custom, '__module__', '')}.{getattr(custom, '__qualname__', repr(custom))}",
                           **({"regrasp": self.regrasp.description()} if self.regrasp.attempts > 1 else {}),
                           **({"touch": self.touch} if self.touch != "contacts" else {}),
                           **({"plan": {"poses": self.plan.poses.tolist(), "postures": self.plan.postures.tolist()}}
                              if self.plan is not None else {}),
                           **({"palm": asdict(self.palm)} if self.palm is not None else {}),
                           **({"oracle": self.oracle} if self.oracle else {}),
                           **({"carried": carried} if (carried := _carried_digests(experience)) else {}),
                           **({"code": code} if (code := self.code()) else {}),
                           **self._protocol_key()},
                          np.asarray(poses, dtype=float),
                          np.empty(0) if experience is None else np.asarray(experience.references, dtype=float),
                          np.empty(0) if self.preshape is None else np.asarray(self.preshape, dtype=float))

    def provenance(self, seed: int) -> dict:
        """What made these trials, as plain values a result file records (`EvaluationResult.made_by`, `evaluate`'s
        trials.npz and summary.json): a reader tells two configurations apart without the command line.

        Args:
            seed: the trials' seed.

        Returns:
            {"library_version", "object" (its parameters; a mesh by its digest), "hand" (name, digest), "protocol"
            (name, whether registered, its judging in a sentence, a digest of its whole value), "touch",
            "controller" (ours by its registered name or 'custom parameters', with every parameter; a user's own by
            its qualified name), "experience" (kind, reference postures, their digest, and the digest of each value it
            carries: `places_digest`, `squeezes_digest`), "seed", "noise", "table",
            "backend", "margin", "method", "regrasp", "preshape", "plan" (a digest), "palm", "oracle", and "code" (one's
            own rule's or controller's, `code`) where there is one}.
        """
        experience, custom, protocol = self.experience, self.controller, self.protocol
        ours = next((name for name, params in CONTROLLERS.items() if params == self.params), "custom parameters")
        references = None if experience is None else np.ascontiguousarray(experience.references, dtype=float)
        whole_protocol = json.dumps(asdict(protocol), sort_keys=True, default=_named).encode()
        return {"library_version": library_version(), "object": self.object.params(),
                "hand": {"name": self.hand.name, "digest": self.hand.digest},
                "protocol": {"name": protocol.name, "registered": PROTOCOLS.get(protocol.name) == protocol,
                             "judging": protocol.summary(), "digest": _digest(whole_protocol)},
                "touch": self.touch,
                "controller": {"name": ours, "params": self.params.to_table()} if custom is None else
                {"name": _named(custom)},
                "experience": {"kind": "none", "references": 0, "digest": ""} if references is None else
                {"kind": type(experience).__name__, "references": len(references),
                 "digest": _digest(references.tobytes()),
                 **{f"{name}_digest": digest for name, digest in _carried_digests(experience).items()}},
                "seed": int(seed), "noise": asdict(self.noise), "table": self.table, "backend": self.backend,
                "margin": self.margin, "method": self.method, "regrasp": self.regrasp.description(),
                "preshape": None if self.preshape is None else np.asarray(self.preshape, dtype=float).tolist(),
                "plan": None if self.plan is None else _digest(self.plan.poses.tobytes() + self.plan.postures.tobytes()),
                "palm": None if self.palm is None else asdict(self.palm), "oracle": self.oracle,
                **({"code": code} if (code := self.code()) else {})}

    def code(self) -> dict[str, str]:
        """The identity of one's own code these trials run (a recall rule, a controller of one's own): its stated
        version or its source's digest (`checkpoints.code_identity`); none for the library's own.

        Returns:
            {"recall" and / or "controller": identity}.
        """
        found = {"recall": code_identity(self.params.recall),
                 "controller": None if self.controller is None else code_identity(self.controller)}
        return {name: identity for name, identity in found.items() if identity is not None}

    def _protocol_key(self) -> dict:
        """The protocol's part of `key`: nothing for the default (keys made before protocols stay valid), the
        name of a registered one, the whole value of one's own."""
        protocol = self.protocol
        if PROTOCOLS.get(protocol.name) == protocol:
            return {} if protocol.name == DEFAULT_PROTOCOL else {"protocol": protocol.name}
        return {"protocol": asdict(protocol)}

    def make_controller(self, n: int) -> Controller:
        """A fresh controller of this set-up.

        Args:
            n: worlds.

        Returns:
            Ours (`BatchController` with the set-up's experience, parameters, preshape and hand), or the user's.
        """
        if self.controller is None:
            return BatchController(n, self.experience, self.params, preshape=self.preshape, hand=self.hand,
                                   regrasp=self.regrasp,
                                   initial_posture=None if self.plan is None else self.plan.postures[0])
        assert not isinstance(self.controller, str)  # __post_init__ made a controller's name its parameters
        controller = self.controller(n, self.hand)
        if not isinstance(controller, Controller):
            raise InvalidInput(f"the controller {type(controller).__name__} lacks a member of the Controller protocol "
                               "(n, control_period, initial, done, reset, step: graspmanifold.control.controller)")
        if self.regrasp.attempts > 1 and not (hasattr(controller, "restart") and hasattr(controller, "attempt")):
            raise InvalidInput(f"the controller {type(controller).__name__} has no `attempt` and `restart` "
                               f"(BatchController's), so it cannot make {self.regrasp.attempts} attempts")
        return controller


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
    margin: float = 0.0  # N of extra disturbance held (JUDGING.margin_force when never dropped; NaN: not measured)
    penetration: float = 0.0  # m, the deepest contact at the end of any control period (Scene.max_penetration)
    fault: str = ""  # why the physics of this trial failed; empty when it did not
    #: the best match of every experience query the controller used (`matches` of them), in order: rows of
    #: `experience.references` (a SOM's flat node indices); None when not recorded (a file of library 0.1.0)
    winners: np.ndarray | None = field(default_factory=lambda: np.zeros(0, dtype=int))
    #: s of the hold test run: 6 x `JUDGING.hold_seconds` for a grasp that held, less for one that dropped its
    #: object (the test ends there), 0 when the physics failed; NaN when not recorded (a file written before
    #: it was kept)
    hold_time: float = float("nan")
    #: grasp attempts the controller made (`TrialSetup.regrasp`), 1 without a regrasp
    attempts: int = 1
    #: what the controller sensed at its first contact: [s since the start, the 22 joints (rad), the segment forces
    #: (N, `SEGMENTS` order)] (`FIRST_CONTACT_FEATURES`); NaN when nothing was touched or not recorded
    first_contact: np.ndarray = field(default_factory=lambda: np.full(FIRST_CONTACT_FEATURES, np.nan))
    #: what it sensed when its first attempt failed the lift probe: [the 22 joints (rad), the segment forces (N)]
    #: (`FAILURE_FEATURES`); NaN when no probe failed
    failure: np.ndarray = field(default_factory=lambda: np.full(FAILURE_FEATURES, np.nan))
    #: m, where the controller's touch first placed the object (`BatchController.object_estimate`), in the palm
    #: frame the trial put the hand in (a planned trial's: the plan's for the nominal object); NaN where it placed
    #: it nowhere (a palm that does not re-centre) or not recorded
    object_estimate: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))

    def __repr__(self) -> str:
        outcome = f"invalid: {self.fault}" if self.fault else (
            f"{'held' if self.hold else 'dropped'}, epsilon {self.epsilon:.3f}, "
            f"{'' if math.isnan(self.margin) else f'margin {self.margin:.1f} N, '}{self.time_to_grasp:.2f} s")
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
    done, then its judging begins (`judge.judge_worlds`) while the other worlds go on grasping. Trial i
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


class Episodes:
    """The one episode loop: trials' worlds on one clock of control periods. The scenes a `TrialSetup` made (on its
    backend), one control period of physics under the targets given, and the judge (`judge.judge_worlds`, the
    set-up's rules and the object's friction) once a grasp is done. `run_trials` drives it with a controller, the
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
        return judge_worlds(self.worlds, self.period, advance or self.physics, friction=self.setup.object.friction,
                            rules=self.setup.rules, ready=ready)


class _TrialLoop:
    """The trials' side of the judging loop (`judge_worlds` runs it): one control period of every live world
    (`advance`: the controller, then the physics; the oracle's correction first where it is asked for), which worlds
    go to the judge (`ready`: the regrasp's probe decides), and what each trial records."""

    def __init__(self, setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
                 observer: Callable[[Worlds], None] | None):
        n = len(poses)
        self.setup, self.poses, self.rngs, self.observer, self.n = setup, poses, rngs, observer, n
        self.controller = controller = setup.make_controller(n)
        self.period = period = controller.control_period
        self.episodes = Episodes(setup, start_worlds(setup, poses, rngs, controller.initial), period)
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
        return (int(getattr(self.controller, "matches", np.zeros(self.n, dtype=int))[world]),
                list(getattr(self.controller, "winners", [[]] * self.n)[world]))

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
        controller, setup = self.controller, self.setup
        moves_palm = getattr(controller, "moves_palm", False)
        palm_offset = getattr(controller, "palm_offset") if moves_palm else None  # (N, 3) m
        if palm_offset is not None and setup.palm is None:  # at once
            self.worlds.shift_hands(live, palm_offset[live])
        elif palm_offset is not None or setup.oracle:  # by its flange, at its bounded speed, while the grasp goes on
            steered = live[self.grasping[live]]
            offsets = palm_offset[steered] if palm_offset is not None else np.zeros((len(steered), 3))
            self.worlds.steer_flanges(steered, flange_targets(self.corrections[steered], offsets), self.period)
        estimate = getattr(controller, "object_estimate", None)
        if estimate is not None:  # where touch first placed the object, made (first) in the palm frame of the start
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
                     attempts=int(getattr(self.controller, "attempt", np.ones(self.n, dtype=int))[world]),
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


#: (x, z, gap, yaw) m and rad: the pose `record_trial` records by default, the object centred 1 cm from the palm
RECORDED_POSE = (0.0, 0.0, 0.01, 0.0)


def _recorded_pose(setup: TrialSetup) -> np.ndarray:
    """`RECORDED_POSE` where a trial can start there, else the nearest pose of the object's quick grid."""
    pose = np.array([RECORDED_POSE])
    if setup.plan is not None or reachable(setup.object, pose, setup.table)[0]:
        return pose[0]
    quick = grid_preset("quick", setup.object, setup.table)
    return quick[int(np.argmin(np.linalg.norm((quick - pose)[:, :3], axis=1)))]


def record_trial(obj: str | GraspObject | TrialSetup, experience: Experience | None = None,
                 grid_pose: Iterable[float] | None = None, seed: int = 0, *, every: int = 2,
                 **fields: object) -> Recording:
    """Run one trial as `evaluate` runs it at a grid pose (any `TrialSetup`: a protocol, a regrasp, one's own
    controller); keep the scene's state along the way.

    `record_trial("box").save_gif("grasp.gif")` animates it; `recording.scene.render()` draws its final state.

    Args:
        obj: the object, or its name; or a whole `TrialSetup`.
        experience: the experience base (None: the plain tactile controller), as `evaluate` takes it.
        grid_pose: (x, z, gap, yaw) in m and rad; refused as `evaluate` refuses it (`why_unreachable` says why).
            None: `RECORDED_POSE` where the open hand can start there, else the nearest pose of the object's quick
            grid (a large object does not fit 1 cm from the palm).
        seed: the trial's seed (trial 0 of `evaluate` with this seed).
        every: keep the state every this many control periods.
        **fields: the `TrialSetup` fields by name, as `evaluate` takes them; `margin` is on unless given (a
            recording shows the whole judging, the pushes included) where the protocol allows it (ours).

    Returns:
        The recording: the trial's outcome, its scene and the kept states.

    Raises:
        ValueError: a bad pose or set-up; the 'warp' backend (a recording runs on the CPU).
    """
    if not isinstance(obj, TrialSetup) and "margin" not in fields:
        protocol = fields.get("protocol", DEFAULT_PROTOCOL)
        if isinstance(protocol, (str, JudgingProtocol)):  # anything else the set-up refuses by name
            fields["margin"] = get_protocol(protocol).physics is None
    setup = TrialSetup.build(obj, experience, **fields)
    if setup.backend != "cpu":
        raise InvalidInput(f"record_trial runs on the cpu backend (it keeps the scene's states), not {setup.backend!r}")
    check_int(every, "every (control periods)")
    grid_pose = _recorded_pose(setup) if grid_pose is None else np.asarray(tuple(grid_pose), dtype=float)
    if grid_pose.shape != (4,) or not np.all(np.isfinite(grid_pose)):
        raise InvalidInput(f"grid_pose must be four finite numbers (x, z, gap, yaw), got {grid_pose!r}")
    check_grid(grid_pose, setup.object, setup.table, setup.plan)  # refused as `evaluate` would refuse it
    states: list[np.ndarray] = []
    seen: dict[str, Scene] = {}

    def observe(worlds: Worlds) -> None:
        scene = seen["scene"] = worlds.scene  # the trial's one scene
        if not states or round(scene.time / period) % every == 0:
            states.append(scene.state())

    period = setup.params.control_period
    trial = run_trial(setup, grid_pose, np.random.default_rng([seed, 0]), observer=observe)
    return Recording(trial, seen["scene"], np.array(states), every * period)


