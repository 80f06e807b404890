"""The Shadow Hand models the library knows, behind the one `hand.HandModel` interface: ours (the default)
and the community's, loaded from where their users already have them (no third-party model file is copied
into this repository).

- `"ours"`: our MJCF, written from the published kinematics (`hand.SHADOW_HAND`).
- `"gymnasium-robotics"` (and `"gymnasium-robotics-touch"`, its variant with 92 touch sensors on palm and
  phalanges, which `Scene.touch` reads per segment): the Shadow Hand of Gymnasium-Robotics (MIT code, Apache-2.0 assets), read from the
  installed package (`pip install 'graspmanifold[hands]'`): `robot0:WRJ1, WRJ0, FFJ3 ... FFJ0, ...,
  THJ4 ... THJ0`, 20 position actuators; J0 follows J1 through a stiff fixed tendon instead of a summed
  actuator, so its J1 actuator drives the paper's J2 and the paper's J1 follows. Four of its joints turn
  the other way than ours (`HandModel.flipped`: the first and middle fingers' spread, the thumb's THJ1
  and tip), and its proximal finger joints (J2) and THJ1 have narrower ranges than the kinematics sheet's.

A description maps the model's names onto the paper's: the 22 finger joints in posture order, the wrist,
the segments (the bodies that touch, for the Partial Contact Posture), the fingertip sites and the
actuators. `hand_model(name)` returns one, checked against its MJCF: a model that lacks a named part is
refused with the list of what is missing.
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

import mujoco
import numpy as np

from ..base.errors import InvalidInput
from .hand import FINGERS, SHADOW_HAND, HandModel

#: the names `hand_model` knows; `gymnasium-robotics-touch` is the same hand with its 92 touch sensors
HAND_MODELS = ("ours", "gymnasium-robotics", "gymnasium-robotics-touch")


def _gymnasium_assets() -> Path:
    """The folder of Gymnasium-Robotics' hand assets, found without importing the package (its import
    registers environments and prints notices)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("the Gymnasium-Robotics hand needs the package: pip install 'graspmanifold[hands]'")
    return Path(list(spec.submodule_search_locations)[0]) / "envs" / "assets" / "hand"


def _gymnasium_spec(touch: bool = False) -> mujoco.MjSpec:
    """Gymnasium-Robotics' hand alone (its shared defaults, meshes and robot; with `touch`, its variant with 92
    touch sensors on palm and phalanges), hung on a mocap body `hand_mount` whose frame is the hand's own mount
    frame, with the library's physics options."""
    root = _gymnasium_assets()
    robot, sensors = ("robot_touch_sensors_92.xml", "shared_touch_sensors_92.xml") if touch else ("robot.xml", None)
    xml = f"""<mujoco model="gymnasium_robotics_shadow_hand">
  <compiler angle="radian" meshdir="{root.parent / 'stls' / 'hand'}" texturedir="{root.parent / 'textures'}"/>
  <include file="{root / 'shared.xml'}"/>
  {f'<include file="{root / sensors}"/>' if sensors else ''}
  <asset><include file="{root / 'shared_asset.xml'}"/></asset>
  <worldbody><body name="hand_mount" mocap="true"><include file="{root / robot}"/></body></worldbody>
</mujoco>"""
    spec = mujoco.MjSpec.from_string(xml)
    ours = SHADOW_HAND.spec().option  # the library's physics, whatever the hand: the same step, integrator and cones
    spec.option.timestep, spec.option.integrator = ours.timestep, ours.integrator
    spec.option.cone, spec.option.impratio = ours.cone, ours.impratio
    mount = spec.body("robot0:hand mount")  # placed in its environments' world: bring it to our mount's frame
    mount.pos = [0.0, 0.0, 0.0]
    mount.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    mount.quat = [1.0, 0.0, 0.0, 0.0]
    return spec


def _gymnasium_robotics(touch: bool = False) -> HandModel:
    """The description of Gymnasium-Robotics' hand: its names for the paper's joints and segments."""
    ours_to_theirs = {}
    for finger in ("FF", "MF", "RF"):  # J4 (spread) ... J1 (tip) are their J3 ... J0
        ours_to_theirs.update({f"{finger}J{j}": f"robot0:{finger}J{j - 1}" for j in (4, 3, 2, 1)})
    ours_to_theirs.update({f"LFJ{j}": f"robot0:LFJ{j - 1}" for j in (5, 4, 3, 2, 1)})
    ours_to_theirs.update({f"THJ{j}": f"robot0:THJ{j - 1}" for j in (5, 4, 3, 2, 1)})
    finger_joints = tuple(ours_to_theirs[j] for j in SHADOW_HAND.finger_joints)
    segment = {name: f"robot0:{body}" for name, body in SHADOW_HAND.joint_segment.items()}
    theirs = {body: f"robot0:{body}" for body in SHADOW_HAND.segments}
    actuators = ("robot0:A_WRJ1", "robot0:A_WRJ0") + tuple(
        f"robot0:A_{finger}J{j}" for finger, joints in (("FF", (3, 2, 1)), ("MF", (3, 2, 1)), ("RF", (3, 2, 1)),
                                                         ("LF", (4, 3, 2, 1)), ("TH", (4, 3, 2, 1, 0)))
        for j in joints)
    loader = functools.partial(_gymnasium_spec, touch=True) if touch else _gymnasium_spec
    model = loader().compile()
    ranges = {name: tuple(float(v) for v in model.joint(name).range) for name in ("robot0:WRJ1", "robot0:WRJ0",
                                                                                  *finger_joints)}
    return HandModel(
        name="gymnasium-robotics-touch" if touch else "gymnasium-robotics", mjcf=str(_gymnasium_assets() / "robot.xml"),
        finger_joints=finger_joints,
        wrist_joints=("robot0:WRJ1", "robot0:WRJ0"), joint_ranges=ranges,
        finger_segments={f: tuple(theirs[s] for s in SHADOW_HAND.finger_segments[f]) for f in FINGERS},
        base_segments=tuple(theirs[s] for s in SHADOW_HAND.base_segments),
        joint_segment={ours_to_theirs[j]: segment[j] for j in SHADOW_HAND.finger_joints},
        fingertip_sites=tuple(f"robot0:S_{f}tip" for f in FINGERS), actuators=actuators,
        timestep=float(model.opt.timestep), mount="hand_mount", palm="robot0:palm", loader=loader,
        postures={key: tuple(SHADOW_HAND.keyframe_posture(key)) for key in ("open", "closed")},
        # measured (tests/test_hand_models.py): a small turn of each of these moves the fingertip against ours
        flipped=("robot0:FFJ3", "robot0:MFJ3", "robot0:THJ1", "robot0:THJ0"))


@functools.cache
def hand_model(name: str = "ours") -> HandModel:
    """A hand model by name, checked against its MJCF.

    Args:
        name: one of `HAND_MODELS`.

    Returns:
        Its description.

    Raises:
        InvalidInput: an unknown name, or a model that lacks a part its description names (listed).
        ImportError: the model's package is not installed (the message says how to install it).
    """
    if name not in HAND_MODELS:
        raise InvalidInput(f"hand must be one of {HAND_MODELS}, got {name!r}")
    hand = SHADOW_HAND if name == SHADOW_HAND.name else _gymnasium_robotics(touch=name.endswith("-touch"))
    check_hand_model(hand)
    return hand


def check_hand_model(hand: HandModel) -> None:
    """Refuse a description its MJCF does not fit.

    Args:
        hand: the description.

    Raises:
        InvalidInput: naming every joint, body, site or actuator the MJCF lacks, or a wrong count.
    """
    if len(hand.finger_joints) != len(SHADOW_HAND.finger_joints) or len(hand.wrist_joints) != 2:
        raise InvalidInput(f"the hand model {hand.name!r} must name 22 finger joints and 2 wrist joints, it names "
                           f"{len(hand.finger_joints)} and {len(hand.wrist_joints)}")
    absent = hand.missing()
    if absent:
        raise InvalidInput(f"the hand model {hand.name!r} lacks what its description names: {', '.join(absent)}")
    if not np.all(np.abs(hand.coupling()).sum(axis=0) <= 1):
        raise InvalidInput(f"the hand model {hand.name!r} drives a finger joint with more than one actuator")
