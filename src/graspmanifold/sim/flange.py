"""The palm's flange: the six degrees of freedom a robot arm gives the hand, moved by a controller (issue 66).

A hand grasps on an arm: the arm carries it to where a trial puts it and can move the palm while the fingers close.
`flanged_spec` builds such a hand from any hand model's spec: the arm's base is the mocap body `ARM_BASE` (placing
the hand moves it, as placing the mount did without a flange); the flange body `FLANGE` hangs on it by three slides
along the palm's x, y and z and then three hinges about the palm's x, y and z through the palm's origin (the palm's
axes at rest, the flange at home: the hinges are intrinsic rotations about the palm); the hand hangs on the flange.
Each flange joint is driven by a position servo (critically damped) whose force is bounded by `FlangeLimits.force`
(slides) or `torque` (hinges) and whose set point is bounded by the travel; the set point moves only by
`Scene.steer_flange`, at most `speed` (or `turn_rate`) times the control period each period, and stays where it was
put between commands. Gravity on the hand is compensated (`gravcomp`), as an arm's controller does. A locked mount
(`Scene.lock_flange`) refuses to be steered: its servos hold their set points.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import mujoco
import numpy as np

from ..base.validation import Bounds, check_fields
from ..base.poses import compose, invert

#: the mocap body of a flanged hand: the arm's base, which placing the hand moves
ARM_BASE = "arm_base"
#: the body between the arm's base and the hand, moved by the flange joints
FLANGE = "flange"
#: the flange joints, in order: slides along the palm's x, y, z (m), hinges about them (rad)
FLANGE_JOINTS = ("flange_x", "flange_y", "flange_z", "flange_rx", "flange_ry", "flange_rz")
#: their servos (MuJoCo actuators), in the same order
FLANGE_ACTUATORS = tuple(f"{joint}_servo" for joint in FLANGE_JOINTS)
# MuJoCo warns (at attaching and at every compile) that an empty prefix may keep a model from being saved; the
# flanged hand's names are the hand's own, distinct from the arm's, and its XML round trip holds (tests/test_flange.py)
warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix", category=UserWarning)

#: kg, the flange body's own mass (an arm's last link); its rotational inertia is a 5 cm sphere's
FLANGE_MASS = 0.2


#: the ranges of `FlangeLimits`: an arm that reaches a hand's work space (a travel of 1e6 m, a speed of 1e300 m/s
#: and a stiffness of 1e30 N/m were taken)
FLANGE_BOUNDS = {"speed": Bounds(0.0, 10.0, above_low=True, unit="m/s"),
                 "turn_rate": Bounds(0.0, 50.0, above_low=True, unit="rad/s"),
                 "force": Bounds(0.0, 5000.0, above_low=True, unit="N"),
                 "torque": Bounds(0.0, 500.0, above_low=True, unit="N m"),
                 "travel": Bounds(0.0, 2.0, above_low=True, unit="m"),
                 "turn": Bounds(0.0, 3.1, above_low=True, unit="rad (below pi)"),
                 "stiffness": Bounds(0.0, 1e7, above_low=True, unit="N/m"),
                 "rotational_stiffness": Bounds(0.0, 1e5, above_low=True, unit="N m/rad")}


@dataclass(frozen=True)
class FlangeLimits:
    """What the arm can do at its flange.

    Args:
        speed: m/s, the fastest a slide's set point moves.
        turn_rate: rad/s, the fastest a hinge's set point turns.
        force: N, the most a slide's servo pushes.
        torque: N m, the most a hinge's servo turns.
        travel: m, how far a slide's set point goes from home, each way.
        turn: rad, how far a hinge's set point goes from home, each way.
        stiffness: N/m, a slide servo's gain on the error of its set point (critically damped).
        rotational_stiffness: N m/rad, a hinge servo's.
    """

    speed: float = 0.1
    turn_rate: float = 1.0
    force: float = 50.0
    torque: float = 10.0
    travel: float = 0.25
    turn: float = 1.0
    stiffness: float = 20000.0
    rotational_stiffness: float = 200.0

    def __post_init__(self) -> None:
        check_fields(self, FLANGE_BOUNDS)

    def speeds(self) -> np.ndarray:
        """The fastest each flange joint's set point moves: (6,), m/s for the slides, rad/s for the hinges."""
        return np.array([self.speed] * 3 + [self.turn_rate] * 3)

    def reach(self) -> np.ndarray:
        """How far each flange joint's set point goes from home, each way: (6,), m for the slides, rad for the
        hinges."""
        return np.array([self.travel] * 3 + [self.turn] * 3)


def palm_in_mount(model: mujoco.MjModel, mount: str, palm: str) -> tuple[np.ndarray, np.ndarray]:
    """Where the palm sits in its mount's frame, the joints at rest.

    Args:
        model: the hand model (compiled).
        mount: its mount body; palm: its palm body.

    Returns:
        The palm's position (3,), m, and orientation (4,), w x y z, in the mount's frame.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    m, p = model.body(mount).id, model.body(palm).id
    return compose(*invert(data.xpos[m], data.xquat[m]), data.xpos[p], data.xquat[p])


def flanged_spec(hand_spec: mujoco.MjSpec, mount: str, palm_pose: tuple[np.ndarray, np.ndarray],
                 limits: FlangeLimits) -> mujoco.MjSpec:
    """A hand's spec on an arm's flange (the module's docstring).

    Args:
        hand_spec: the hand's spec, its root body the mocap `mount` (`HandModel.spec`); it is changed (the mount
            becomes an ordinary body) and attached whole, its names kept.
        mount: the name of its mount body.
        palm_pose: the palm's pose in the mount's frame at rest (`palm_in_mount`): the flange's axes.
        limits: what the arm can do.

    Returns:
        The new spec: the arm's base `ARM_BASE` (mocap), the flange `FLANGE`, the hand; the hand's options, sizes
        and asset folders.
    """
    spec = mujoco.MjSpec()
    spec.modelname = hand_spec.modelname
    for name in ("timestep", "integrator", "cone", "impratio", "solver", "iterations", "tolerance", "ls_iterations",
                 "noslip_iterations", "jacobian", "gravity", "disableflags", "enableflags", "o_solref", "o_solimp",
                 "o_margin", "o_friction"):
        setattr(spec.option, name, getattr(hand_spec.option, name))
    for name in ("njmax", "nconmax", "nstack", "nuserdata", "nuser_body", "nuser_jnt", "nuser_geom", "nuser_site",
                 "nuser_cam", "nuser_tendon", "nuser_actuator", "nuser_sensor", "meshdir", "texturedir"):
        setattr(spec, name, getattr(hand_spec, name))
    spec.compiler.degree = False
    hand_spec.body(mount).mocap = False
    base = spec.worldbody.add_body(name=ARM_BASE, mocap=True)
    flange = base.add_body(name=FLANGE)
    flange.mass, flange.inertia, flange.explicitinertial = FLANGE_MASS, [FLANGE_MASS * 0.001] * 3, True
    position, quat = palm_pose
    matrix = np.zeros(9)
    mujoco.mju_quat2Mat(matrix, np.asarray(quat, dtype=float))
    axes = matrix.reshape(3, 3).T  # rows: the palm's x, y, z in the mount's frame
    for index, joint in enumerate(FLANGE_JOINTS):
        slide = index < 3
        flange.add_joint(name=joint, type=mujoco.mjtJoint.mjJNT_SLIDE if slide else mujoco.mjtJoint.mjJNT_HINGE,
                         axis=axes[index % 3], pos=[0.0, 0.0, 0.0] if slide else position)
        servo = spec.add_actuator(name=FLANGE_ACTUATORS[index], target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        servo.set_to_position(kp=limits.stiffness if slide else limits.rotational_stiffness, dampratio=1.0)
        reach, push = (limits.travel, limits.force) if slide else (limits.turn, limits.torque)
        servo.ctrllimited, servo.ctrlrange = True, [-reach, reach]
        servo.forcelimited, servo.forcerange = True, [-push, push]
    with without_empty_prefix_warning():
        spec.attach(hand_spec, prefix="", frame=flange.add_frame())
    for body in spec.bodies:  # the arm carries the hand's weight
        if body.name not in ("world", ARM_BASE):
            body.gravcomp = 1.0
    return spec



#: what MuJoCo says when a spec attached without a prefix is compiled: a flanged scene's hand keeps its own names on
#: purpose (every other module finds its joints and geoms by them), so the warning says nothing to a user
_EMPTY_PREFIX = "Attaching a spec with an empty prefix"


@contextmanager
def without_empty_prefix_warning() -> Iterator[None]:
    """MuJoCo's warning about the hand attached to the flange without a prefix left unsaid (printed, and raised as a
    UserWarning, when the spec is attached and compiled: 50 times a run); any other warning is said as MuJoCo says it.
    """
    previous = mujoco.get_mju_user_warning()

    def say(message: str) -> None:
        if not message.startswith(_EMPTY_PREFIX):
            previous(message) if previous is not None else print(f"WARNING: {message}\n", flush=True)

    mujoco.set_mju_user_warning(say)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=_EMPTY_PREFIX)
            yield
    finally:
        mujoco.set_mju_user_warning(previous)
