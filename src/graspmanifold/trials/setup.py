"""What a trial is, besides its grid pose and its random stream: the set-up (`TrialSetup`, one frozen value that
`evaluate`, the batched trials, `record_trial` and the checkpoint key share), its noise (`Noise`), and the choices its
fields take (`BACKENDS`, `ORACLES`).
"""

from __future__ import annotations

import builtins
import dataclasses
import functools
import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from ..base.checkpoints import code_identity, result_key
from ..base.errors import InvalidInput
from ..base.io import library_version
from ..base.validation import check_choice, check_int
from ..control.controller import (CONTROLLERS, BatchController, Controller, ControllerFactory, ControllerParams,
                                  declared_readouts)
from ..control.regrasp import Regrasp
from ..judging.plans import OpenLoopGrasp
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOLS, JudgingProtocol, get_protocol
from ..judging.stages import JudgingRules
from ..manifold.experience import Experience, carried_values, check_experience, check_within_hand
from ..manifold.postureset import PostureSet
from ..sim.flange import FlangeLimits
from ..sim.hand import SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, get_object
from ..sim.scene import TOUCH_SOURCES


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


#: the oracle corrections besides the full one (`TrialSetup.oracle=True`): 'translation', the palm moved by the
#: displacement's translation and not turned by its yaw
ORACLES: tuple[str, ...] = ("translation",)

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


@dataclass(frozen=True)
class Described:
    """What some fields of a set-up (or the seed) add to its trials' key and to their provenance (`DESCRIPTION`).

    Attributes:
        fields: the `TrialSetup` fields this entry describes (none: the seed, or what two fields make together).
        key: (set-up, seed) -> its part of the key (`TrialSetup.key`; arrays are hashed by content), or None: no part
            (a label, a batch size: they change no outcome).
        provenance: (set-up, seed) -> its part of the provenance (`TrialSetup.provenance`), or None.
    """

    fields: tuple[str, ...]
    key: Callable[[TrialSetup, int], dict[str, Any]] | None
    provenance: Callable[[TrialSetup, int], dict[str, Any]] | None


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
        plan: a planned grasp (`plans.OpenLoopGrasp`, palm poses in the object's frame) or None. With a
            plan, a trial's pose (x, z, gap, yaw) is the object's displacement from where the plan assumed it (palm
            frame, `grid.displaced_palm_pose`): the hand starts in the plan's pregrasp, its palm where the plan puts
            it for the nominal pose, and the object lies displaced; the controller is not told the displacement (ours
            starts from the pregrasp's posture). The plan's open-loop execution is the controller
            `open_loop.OpenLoop(plan)`.
        palm: the hand on an arm's flange with these limits (`sim.flange.FlangeLimits`: the palm's six degrees of
            freedom, servoed, lockable; the cpu backend), or None: the palm stays where the trial put it. A protocol
            whose judging moves the palm (the lift: `JudgingRules.needs_flange`) gets the default flange where none
            is given. The flange alone moves nothing: the controller's `ControllerParams.palm` steers it
            (`control.controller.PALM_TOUCH`, `PALM_EXPERIENCE`; the CLI's `--palm-steering`).
        oracle: the oracle correction, a ceiling and not a controller (issue 66): with a plan and a palm, the
            flange first carries the palm by the object's true displacement (the trial's pose, `grid.
            oracle_correction`) to where the plan puts it for the displaced object, the fingers held in their
            starting posture, and only then does the controller start (the palm then moves from there). The only
            trials that read the displacement: their provenance says so (`oracle`), whatever their label.
            'translation': the palm moved by the displacement's translation alone, not turned by its yaw (`ORACLES`).

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
            raise InvalidInput(f"plan must be an OpenLoopGrasp (plans.open_loop_grasp makes one), got "
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
        if self.oracle and (self.plan is None or self.palm is None):  # a rule on values, not on the label
            raise InvalidInput("oracle=True moves the palm by the true displacement of a planned trial: it needs a "
                               "plan and a palm (the flange that carries it), got "
                               f"plan={'given' if self.plan is not None else None}, palm={self.palm!r}")

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
        """The `checkpoints.result_key` of this set-up's trials at these poses, from its description (`DESCRIPTION`):
        of the experience, what a controller reads of it (its kind, its reference postures and what it carries:
        places, squeezes), never a pickle; of the hand, its content (`HandModel.digest`); not the label.

        Args:
            poses: grid poses (n, 4), m and rad.
            seed: the trials' seed.

        Returns:
            A 20-character hexadecimal key.
        """
        undescribed = sorted({f.name for f in dataclasses.fields(self)} - DESCRIBED_FIELDS)
        if undescribed:  # a subclass's own field would leave the key: two set-ups that differ would share trials
            raise InvalidInput(f"{type(self).__name__} has fields the trials' key does not describe: {undescribed}; "
                               "a subclass that adds fields overrides key and provenance to include them (or keeps its settings in its "
                               "controller, whose code is keyed)")
        described: dict[str, Any] = {}
        for entry in DESCRIPTION:
            if entry.key is not None:
                described.update(entry.key(self, int(seed)))
        arrays = [value for value in described.values() if isinstance(value, np.ndarray)]
        return result_key({name: value for name, value in described.items() if not isinstance(value, np.ndarray)},
                          np.asarray(poses, dtype=float), *arrays)

    def provenance(self, seed: int) -> dict:
        """What made these trials, as plain values a result file records (`EvaluationResult.made_by`, `evaluate`'s
        trials.npz and summary.json), from its description (`DESCRIPTION`): a reader tells two configurations apart
        without the command line.

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
        made: dict = {"library_version": library_version()}
        for entry in DESCRIPTION:
            if entry.provenance is not None:
                made.update(entry.provenance(self, int(seed)))
        return made

    def code(self) -> dict[str, str]:
        """The identity of one's own code these trials run (a recall rule, a controller of one's own): its stated
        version or its source's digest (`checkpoints.code_identity`); none for the library's own.

        Returns:
            {"recall" and / or "controller": identity}.
        """
        found = {"recall": code_identity(self.params.recall),
                 "controller": None if self.controller is None else code_identity(self.controller)}
        return {name: identity for name, identity in found.items() if identity is not None}

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
        if self.regrasp.attempts > 1 and not (hasattr(controller, "restart") and
                                              "attempt" in declared_readouts(controller)):
            raise InvalidInput(f"the controller {type(controller).__name__} has no `restart` and no declared `attempt` "
                               f"read-out (BatchController's), so it cannot make {self.regrasp.attempts} attempts")
        return controller


def _protocol_key(setup: TrialSetup) -> dict:
    """The protocol's part of the key: nothing for the default (keys made before protocols stay valid), the name of a
    registered one, the whole value of one's own."""
    protocol = setup.protocol
    if PROTOCOLS.get(protocol.name) == protocol:
        return {} if protocol.name == DEFAULT_PROTOCOL else {"protocol": protocol.name}
    return {"protocol": asdict(protocol)}


def _protocol_provenance(setup: TrialSetup) -> dict:
    """The protocol as a result file records it: its name, whether registered, its judging, a digest of its value."""
    protocol = setup.protocol
    whole = json.dumps(asdict(protocol), sort_keys=True, default=_named).encode()
    return {"protocol": {"name": protocol.name, "registered": PROTOCOLS.get(protocol.name) == protocol,
                         "judging": protocol.summary(), "digest": _digest(whole)}}


def _controller_provenance(setup: TrialSetup) -> dict:
    """Ours by its registered name (or 'custom parameters') with every parameter; a user's own by its name."""
    if setup.controller is not None:
        return {"controller": {"name": _named(setup.controller)}}
    ours = next((name for name, params in CONTROLLERS.items() if params == setup.params), "custom parameters")
    return {"controller": {"name": ours, "params": setup.params.to_table()}}


def _experience_key(setup: TrialSetup) -> dict:
    """What a controller reads of the experience: its kind, its reference postures (an array) and what it carries."""
    experience = setup.experience
    return {"experience": None if experience is None else type(experience).__name__,
            "references": np.empty(0) if experience is None else np.asarray(experience.references, dtype=float),
            **({"carried": carried} if (carried := _carried_digests(experience)) else {})}


def _experience_provenance(setup: TrialSetup) -> dict:
    """The experience's kind, its reference postures' count and digest, the digest of each value it carries."""
    experience = setup.experience
    if experience is None:
        return {"experience": {"kind": "none", "references": 0, "digest": ""}}
    references = np.ascontiguousarray(experience.references, dtype=float)
    return {"experience": {"kind": type(experience).__name__, "references": len(references),
                           "digest": _digest(references.tobytes()),
                           **{f"{name}_digest": digest for name, digest in _carried_digests(experience).items()}}}


def _plain(value: object) -> object:
    """A field's value as JSON writes it: a dataclass value as its dict."""
    return asdict(value) if dataclasses.is_dataclass(value) and not isinstance(value, type) else value


def _same(name: str) -> Callable[[TrialSetup, int], dict[str, Any]]:
    """A field that enters key and provenance as it is."""
    return lambda setup, seed: {name: _plain(getattr(setup, name))}


def _unless(name: str, default: object) -> Callable[[TrialSetup, int], dict[str, Any]]:
    """A field that enters the key only where it is not its default (a key made before the field existed is the key
    of its default)."""
    return lambda setup, seed: {} if getattr(setup, name) in (default,) else {name: _plain(getattr(setup, name))}


#: the set-up described once, in the order a result file records it: for each field, what it adds to the trials' key
#: (what decides an outcome) and to their provenance (what a reader needs to tell two runs apart). A new field is one
#: entry here; a test holds every field of `TrialSetup` to an entry
DESCRIPTION: tuple[Described, ...] = (
    Described(("object",), lambda s, seed: {"object": s.object.params()}, lambda s, seed: {"object": s.object.params()}),
    Described(("hand",), lambda s, seed: {"hand": s.hand.digest},
              lambda s, seed: {"hand": {"name": s.hand.name, "digest": s.hand.digest}}),
    Described(("protocol",), lambda s, seed: _protocol_key(s), lambda s, seed: _protocol_provenance(s)),
    Described(("touch",), _unless("touch", "contacts"), _same("touch")),
    Described(("params", "controller"), lambda s, seed: {"params": s.params.to_table(), "controller": None
                                                          if s.controller is None else _named(s.controller)},
              lambda s, seed: _controller_provenance(s)),
    Described(("experience",), lambda s, seed: _experience_key(s), lambda s, seed: _experience_provenance(s)),
    Described((), lambda s, seed: {"seed": seed}, lambda s, seed: {"seed": seed}),
    Described(("noise",), _same("noise"), _same("noise")),
    Described(("table",), _same("table"), _same("table")),
    Described(("backend",), _same("backend"), _same("backend")),
    Described(("margin",), _same("margin"), _same("margin")),
    Described(("method",), None, _same("method")),
    Described(("regrasp",), lambda s, seed: {"regrasp": s.regrasp.description()} if s.regrasp.attempts > 1 else {},
              lambda s, seed: {"regrasp": s.regrasp.description()}),
    Described(("preshape",), lambda s, seed: {"preshape": np.empty(0) if s.preshape is None else
                                              np.asarray(s.preshape, dtype=float)},
              lambda s, seed: {"preshape": None if s.preshape is None else
                               np.asarray(s.preshape, dtype=float).tolist()}),
    Described(("plan",), lambda s, seed: {} if s.plan is None else
              {"plan": {"poses": s.plan.poses.tolist(), "postures": s.plan.postures.tolist()}},
              lambda s, seed: {"plan": None if s.plan is None else
                               _digest(s.plan.poses.tobytes() + s.plan.postures.tobytes())}),
    Described(("palm",), _unless("palm", None), lambda s, seed: {"palm": None if s.palm is None else asdict(s.palm)}),
    Described(("oracle",), _unless("oracle", False), _same("oracle")),
    Described((), lambda s, seed: {"code": code} if (code := s.code()) else {},
              lambda s, seed: {"code": code} if (code := s.code()) else {}),
    Described(("batch_size",), None, None),  # changes no outcome: trials at once on the GPU
)
#: the fields `DESCRIPTION` describes
DESCRIBED_FIELDS = frozenset(name for entry in DESCRIPTION for name in entry.fields)
