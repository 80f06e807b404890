"""How a grasp is judged, one value per protocol (`JudgingProtocol`), and the registry of them by name (`PROTOCOLS`).

A protocol is the physics the scene runs under (`PhysicsProfile`; ours: the scene's own), the judging of a
closed-loop grasp (the rules of the one judging loop, `judge.episode_loop`) and the judging of an open-loop replay
(`replay.replay_grasp`: our hold test by the same rules, or DexGraspBench's external-force test,
`DexGraspBenchProtocol`). Registered: our hold test (`DEFAULT_PROTOCOL`, `judge.JUDGING`; `ours-faded` after a
fading support), the lift of the field's closed-loop protocol (`lift`: the arm raises the palm 0.2 m, the object
held when it rises at least 0.1 m; `stages.LiftStage`, a hand on a flange) and DexGraspBench's two versions, `main` (0.1
kg, 0.05 m, 15 degrees) and `paper` (the BODex paper's: 0.03 kg, 0.10 m, 180 degrees). The physics DexGraspBench
needs is a named profile: a 4 ms step, implicitfast, elliptic cones with impratio 10, condim 4, two noslip
iterations, friction 0.6 sliding and 0.02 torsional, gravity off, the object's mass set by rescaling its density.
Our hand keeps its own servos (DexGraspBench's Menagerie hand has kp 5 on main): the protocol judges the grasp, the
hand is the one under test.

A protocol of one's own is a `JudgingProtocol` value: `TrialSetup(protocol=...)`, `replay_grasp` and the generator's
verifier take one as they take a registered name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco

from ..base.errors import InvalidInput
from ..base.moved import current_name, moved_attribute
from ..base.validation import Bounds, check_choice, check_directions, check_fields, check_number
from ..sim.flange import FlangeLimits
from ..sim.scene import GRAVITY, Scene
from .judge import JUDGING
from .stages import SIX_DIRECTIONS, JudgingRules, LiftStage

#: MuJoCo's integrators by the names a `PhysicsProfile` takes
INTEGRATORS = tuple(name.removeprefix("mjINT_").lower() for name in mujoco.mjtIntegrator.__members__)
#: the ranges of a `PhysicsProfile`'s numbers (a 0 s step ended in a ZeroDivisionError deep in a trial)
PHYSICS_BOUNDS = {"timestep": Bounds(0.0, 0.1, above_low=True, unit="s"),
                  "impratio": Bounds(0.0, 1e4, above_low=True),
                  "noslip_iterations": Bounds(0, 1000, whole=True),
                  "object_mass": Bounds(0.0, 100.0, above_low=True, unit="kg")}
#: the ranges of a `DexGraspBenchProtocol`'s numbers (a push of zero chunks passed every grasp untested)
PUSH_TEST_BOUNDS = {"translation_limit": Bounds(0.0, 1.0, above_low=True, unit="m"),
                    "angle_limit": Bounds(0.0, 2 * math.pi, above_low=True, unit="rad"),
                    "force_per_kg": Bounds(0.0, 1000.0, above_low=True, unit="N/kg"),
                    "max_penetration": Bounds(0.0, 0.1, unit="m"),
                    "approach_targets": Bounds(1, 1000, whole=True),
                    "steps_per_target": Bounds(1, 10000, whole=True),
                    "hold_chunks": Bounds(1, 1000, whole=True),
                    "steps_per_chunk": Bounds(1, 10000, whole=True)}


@dataclass(frozen=True)
class PhysicsProfile:
    """The physics options a protocol needs of a scene (`apply` sets them on a compiled scene).

    Attributes:
        name: the profile's name.
        timestep: s per physics step.
        integrator: MuJoCo's integrator, by name ('implicitfast').
        cone: the friction cone ('elliptic').
        impratio: the ratio of frictional to normal constraint impedance.
        condim: contact dimensionality of every geom (4: sliding and torsional friction).
        noslip_iterations: MuJoCo's noslip solver iterations.
        friction: (sliding, torsional) coefficients of every geom.
        gravity: gravity on (False: off, as during DexGraspBench's test).
        object_mass: kg, the object's mass, set by rescaling its density (its inertia scales alike).
    """

    name: str
    timestep: float
    integrator: str
    cone: str
    impratio: float
    condim: int
    noslip_iterations: int
    friction: tuple[float, float]
    gravity: bool
    object_mass: float

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidInput(f"PhysicsProfile.name must be a non-empty string, got {self.name!r}")
        check_fields(self, PHYSICS_BOUNDS, flags=("gravity",))
        check_choice(self.integrator, INTEGRATORS, "PhysicsProfile.integrator")
        check_choice(self.cone, ("pyramidal", "elliptic"), "PhysicsProfile.cone")
        check_choice(self.condim, (1, 3, 4, 6), "PhysicsProfile.condim")
        try:
            sliding, torsional = self.friction
        except (TypeError, ValueError):
            raise InvalidInput(f"PhysicsProfile.friction must be (sliding, torsional), got {self.friction!r}") from None
        friction = (check_number(sliding, "PhysicsProfile.friction[0] (sliding)", Bounds(0.0, 10.0, above_low=True)),
                    check_number(torsional, "PhysicsProfile.friction[1] (torsional)", Bounds(0.0, 1.0)))
        object.__setattr__(self, "friction", tuple(map(float, friction)))

    def apply(self, scene: Scene) -> None:
        """Set these options on a scene's compiled model (its data keeps its state; call before simulating).

        Args:
            scene: a scene (`Scene`), its object free or welded.
        """
        model = scene.model
        model.opt.timestep = self.timestep
        model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{self.integrator.upper()}")
        model.opt.cone = getattr(mujoco.mjtCone, f"mjCONE_{self.cone.upper()}")
        model.opt.impratio = self.impratio
        model.opt.noslip_iterations = self.noslip_iterations
        model.geom_condim[:] = self.condim
        model.geom_friction[:, 0], model.geom_friction[:, 1] = self.friction
        scene.set_gravity(self.gravity)
        body = scene.object_body
        scale = self.object_mass / float(model.body_mass[body])
        model.body_mass[body] *= scale
        model.body_inertia[body] *= scale
        mujoco.mj_setConst(model, scene.data)


def _profile(mass: float) -> PhysicsProfile:
    return PhysicsProfile(name=f"dexgraspbench-{mass * 1000:.0f}g", timestep=0.004, integrator="implicitfast",
                          cone="elliptic", impratio=10.0, condim=4, noslip_iterations=2, friction=(0.6, 0.02),
                          gravity=False, object_mass=mass)


@dataclass(frozen=True)
class DexGraspBenchProtocol:
    """DexGraspBench's external-force test, one version of it (see the module doc).

    Attributes:
        version: 'main' or 'paper'.
        physics: the scene's physics profile.
        translation_limit: m the object may move and still be held.
        angle_limit: rad it may turn.
        force_per_kg: N of external force per kg of object (10: about its weight, along each direction).
        max_penetration: m, a pregrasp deeper than this inside the object fails outright.
        approach_targets: interpolated targets of each move (pregrasp -> grasp, grasp -> squeeze).
        steps_per_target: physics steps per target.
        hold_chunks: chunks of the push, checked after each (the early stop).
        steps_per_chunk: physics steps per chunk.
        directions: the external force's unit directions, in turn.
    """

    version: str
    physics: PhysicsProfile
    translation_limit: float
    angle_limit: float
    force_per_kg: float = 10.0
    max_penetration: float = 0.01
    approach_targets: int = 10
    steps_per_target: int = 10
    hold_chunks: int = 10
    steps_per_chunk: int = 50
    directions: tuple[tuple[float, float, float], ...] = SIX_DIRECTIONS

    def __post_init__(self) -> None:
        if not isinstance(self.version, str) or not self.version:
            raise InvalidInput(f"DexGraspBenchProtocol.version must be a non-empty string, got {self.version!r}")
        if not isinstance(self.physics, PhysicsProfile):
            raise InvalidInput(f"DexGraspBenchProtocol.physics must be a PhysicsProfile, got {self.physics!r}")
        check_fields(self, PUSH_TEST_BOUNDS)
        object.__setattr__(self, "directions", check_directions(self.directions, "DexGraspBenchProtocol.directions"))

    @property
    def name(self) -> str:
        """The name of its `JudgingProtocol` in `PROTOCOLS`."""
        return "dexgraspbench" if self.version == "main" else f"dexgraspbench-{self.version}"

    @property
    def push(self) -> float:
        """N, the external force on the object."""
        return self.force_per_kg * self.physics.object_mass


DEXGRASPBENCH = DexGraspBenchProtocol("main", _profile(0.1), translation_limit=0.05, angle_limit=math.radians(15))
"""DexGraspBench's main branch: 0.1 kg, the object within 5 cm and 15 degrees."""
DEXGRASPBENCH_PAPER = DexGraspBenchProtocol("paper", _profile(0.03), translation_limit=0.10,
                                            angle_limit=math.radians(180))
"""The BODex paper's version: 0.03 kg, within 10 cm and 180 degrees."""


@dataclass(frozen=True)
class JudgingProtocol:
    """How a grasp is judged: the physics, the judging after a closed-loop grasp, the judging of a replay.

    Attributes:
        name: its name (the registry's key for a registered one; part of a trial's key otherwise).
        rules: the rules of the judging loop after a trial's grasp (`judge.episode_loop`), and of our hold test
            after an open-loop replay.
        push_test: DexGraspBench's external-force test (one version), which judges an open-loop replay in place of
            `rules` and brings its physics profile; None: the scene's own physics, a replay judged by `rules`.
    """

    name: str
    rules: JudgingRules = JUDGING
    push_test: DexGraspBenchProtocol | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidInput(f"JudgingProtocol.name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.rules, JudgingRules):
            raise InvalidInput(f"JudgingProtocol.rules must be a JudgingRules, got {type(self.rules).__name__}")
        if self.push_test is not None and not isinstance(self.push_test, DexGraspBenchProtocol):
            raise InvalidInput(f"JudgingProtocol.push_test must be a DexGraspBenchProtocol or None, got "
                               f"{type(self.push_test).__name__}")

    @property
    def physics(self) -> PhysicsProfile | None:
        """The physics profile the scene runs under from the start (None: the scene's own)."""
        return None if self.push_test is None else self.push_test.physics

    @property
    def flange(self) -> FlangeLimits | None:
        """The arm a scene judged by this protocol needs: the default flange where its judging moves the palm (the
        lift: `JudgingRules.needs_flange`), else None."""
        return FlangeLimits() if self.rules.needs_flange else None

    def check_trials(self, table: bool, backend: str, margin: bool) -> None:
        """Refuse trials this protocol cannot judge.

        Args:
            table: whether the object stands on a table.
            backend: the trials' physics backend.
            margin: whether our disturbance margin is measured too.

        Raises:
            InvalidInput: a protocol with its own physics on a table, off the cpu backend or with the margin.
        """
        if self.physics is not None and (table or backend != "cpu" or margin):
            raise InvalidInput(f"protocol {self.name!r} (its own physics) judges on the spring support with "
                               "the cpu backend and without our disturbance margin (table=False, backend='cpu', "
                               "margin=False)")

    def apply(self, scene: Scene) -> None:
        """Set the protocol's physics on a scene (nothing for one that keeps the scene's own).

        Args:
            scene: the scene; its model changes for good.
        """
        if self.physics is not None:
            self.physics.apply(scene)

    def check_arm(self, palm: FlangeLimits | None, object_mass: float) -> None:
        """Refuse an arm that cannot perform this protocol's lift (an arm that rose 1 cm of a 0.2 m lift, or pulled
        0.01 N, reported the grasp held).

        Args:
            palm: the arm's flange the trials run on (None: no arm).
            object_mass: kg, the object's mass.

        Raises:
            InvalidInput: the lift is higher than the arm's travel, or the object's weight more than half the arm's
                force (the hand's own weight is the arm's gravity compensation's).
        """
        rules = self.rules
        if palm is not None and not isinstance(palm, FlangeLimits):
            raise InvalidInput(f"palm must be a FlangeLimits or None, got {type(palm).__name__}")
        check_number(object_mass, "object_mass", Bounds(0.0, 100.0, above_low=True, unit="kg"))
        lift = rules.lift
        if not rules.needs_flange or palm is None or lift is None:
            return
        if palm.travel < lift.height:
            raise InvalidInput(f"protocol {self.name!r} raises the palm {lift.height:g} m, but the arm travels "
                               f"FlangeLimits.travel={palm.travel:g} m: give the arm at least the lift's travel")
        needed = 2.0 * object_mass * GRAVITY
        if palm.force < needed:
            raise InvalidInput(f"protocol {self.name!r} lifts the {object_mass:g} kg object, but the arm pushes "
                               f"FlangeLimits.force={palm.force:g} N, less than twice its weight ({needed:.3g} N)")

    def summary(self) -> str:
        """How it judges a trial's grasp, in a sentence (the reproduction report's)."""
        rules = self.rules
        epsilon = f"force closure: ε > {rules.epsilon_threshold}"
        if rules.lift is not None:
            return (f"lift: gravity on, the arm raises the palm {rules.lift.height:g} m at {rules.lift.speed:g} m/s "
                    f"and holds it {rules.hold_seconds:g} s, the object within {100 * rules.hold_limit:.0f} cm of the "
                    f"palm's rise; {epsilon}")
        if self.push_test is None:
            return (f"hold: gravity along ±x, ±y, ±z for {rules.hold_seconds} s each, the object within "
                    f"{100 * rules.hold_limit:.0f} cm; {epsilon}")
        p = self.push_test
        return (f"DexGraspBench's external-force test ({p.version} version, its physics profile): a push of {p.push:g} N "
                f"along ±x, ±y, ±z, each from the state at the grasp's end, the object within "
                f"{100 * p.translation_limit:.0f} cm and {math.degrees(p.angle_limit):.0f}°; {epsilon}")


def pushed(test: DexGraspBenchProtocol, name: str | None = None) -> JudgingProtocol:
    """The protocol of a DexGraspBench external-force test: its physics, its push test for a replay, and for a
    trial's grasp the rules of the one judging loop that do the same (a push of `push` N per direction, gravity
    off, each direction from the state at the grasp's end, `hold_chunks` x `steps_per_chunk` steps, the
    translation and angle limits; checked every control period, not every chunk: an early stop is found sooner).

    Args:
        test: the test (a registered version, or one changed for an ablation).
        name: the protocol's name (None: the test's).

    Returns:
        The `JudgingProtocol`.
    """
    rules = replace(JUDGING, hold_seconds=test.hold_chunks * test.steps_per_chunk * test.physics.timestep,
                    hold_limit=test.translation_limit, push=test.push, angle_limit=test.angle_limit, from_grasp=True,
                    physics=test.physics.name)
    return JudgingProtocol(name or test.name, rules, test)


#: our hold test (`judge.JUDGING`): the default everywhere
HOLD_TEST = JudgingProtocol("hold-test")
#: our hold test after a support that fades over 0.3 s once the grasp is ready (`JudgingRules.release_seconds`),
#: the hand acting on: a load the spring carried is handed to the grasp gradually (the planned-grasp benchmark's)
HOLD_TEST_FADED = JudgingProtocol("hold-test-faded", replace(JUDGING, release_seconds=0.3))
#: the lift of the field's closed-loop protocol (issue 66): the support released, gravity on, the arm raises the palm
#: 0.2 m at 0.1 m/s and holds it 0.5 s; held when the object kept within 0.1 m of the palm's rise (it rose >= 0.1 m)
LIFT = JudgingProtocol("lift", replace(JUDGING, hold_limit=0.1, stages=(LiftStage(),)))
#: every registered protocol by name: our hold test (at once, or after a fading support), the lift, and
#: DexGraspBench's versions
PROTOCOLS: dict[str, JudgingProtocol] = {p.name: p for p in (HOLD_TEST, HOLD_TEST_FADED, LIFT, pushed(DEXGRASPBENCH),
                                                      pushed(DEXGRASPBENCH_PAPER))}
#: the registered protocols' names
PROTOCOL_NAMES: tuple[str, ...] = tuple(PROTOCOLS)
#: the name of the protocol used where none is named
DEFAULT_PROTOCOL: str = HOLD_TEST.name


def get_protocol(protocol: str | JudgingProtocol, argument: str = "protocol") -> JudgingProtocol:
    """A protocol by name, or one given as a value (returned as it is).

    Args:
        protocol: a name in `PROTOCOLS`, or a `JudgingProtocol`.
        argument: the argument's name, for the error.

    Returns:
        The `JudgingProtocol`.

    Raises:
        InvalidInput: an unknown name or another type.
    """
    if isinstance(protocol, JudgingProtocol):
        return protocol
    return PROTOCOLS[check_choice(current_name("protocol", protocol), PROTOCOL_NAMES, argument, also="or a JudgingProtocol")]


def __getattr__(name: str) -> object:
    """The names before 0.2 (`Protocol`, `OURS`, `OURS_FADED`), with a warning (`base.moved.MOVED_NAMES`)."""
    return moved_attribute(__name__, name)
