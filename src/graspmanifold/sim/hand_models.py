"""The Shadow Hand models the library knows, behind the one `hand.HandModel` interface: ours (the default)
and the community's, loaded from where their users already have them (no third-party model file is copied
into this repository).

- `"shadow-primitives"`: our MJCF of primitive collision geometry, written from the published kinematics
  (`hand.SHADOW_HAND`; called "ours" before 0.2, a name files and flags may still give).
- `"gymnasium-robotics"` (and `"gymnasium-robotics-touch"`, its variant with 92 touch sensors on palm and
  phalanges, which `Scene.touch` reads per segment): the Shadow Hand of Gymnasium-Robotics (MIT code, Apache-2.0
  assets), read from the installed package (`pip install 'graspmanifold[hands]'`): `robot0:WRJ1, WRJ0, FFJ3 ...
  FFJ0, ..., THJ4 ... THJ0`, 20 position actuators; J0 follows J1 through a stiff fixed tendon instead of a
  summed actuator, so its J1 actuator drives the paper's J2 and the paper's J1 follows. Four of its joints turn
  the other way than ours (the first and middle fingers' spread, the thumb's THJ1 and tip), and its proximal
  finger joints (J2) and THJ1 have narrower ranges than the kinematics sheet's.
- `"menagerie"`: MuJoCo Menagerie's `shadow_hand/right_hand.xml` (Apache-2.0) in the checkout `MENAGERIE_ROOT`
  names (`rh_WRJ2 ... rh_THJ1`, 20 position actuators, J1 + J2 coupled by fixed tendons, no sensors).
- the path of any MJCF file of a right Shadow Hand alone (`mjcf_hand`).

Every model but ours is described from its MJCF by one procedure (`describe_shadow_hand`): the names of the
paper's 22 finger joints, the wrist, the segments (the bodies that touch, for the Partial Contact Posture) and
the actuators are read from the file; which joints turn the other way than the paper's is measured (their axes
in the palm frame); the description is then checked by measurement against ours (`joint_agreement`, where the
phalanges sit). `hand_model(name or path)` returns one, checked against its MJCF: a model that lacks a named
part is refused with the list of what is missing.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import itertools
import os
import re
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from ..base.errors import InvalidInput
from ..base.moved import current_name
from ..base.validation import check_input_file
from .hand import DISTAL_SEGMENTS, FINGERS, HAND_JOINTS, SHADOW_HAND, WRIST_JOINTS, HandModel, finger_of

#: the names `hand_model` knows; `gymnasium-robotics-touch` is the same hand with its 92 touch sensors; `menagerie`
#: is read from the checkout `MENAGERIE_ROOT` names (any other model: the path of its MJCF file)
HAND_MODELS = (SHADOW_HAND.name, "gymnasium-robotics", "gymnasium-robotics-touch", "menagerie")


def _gymnasium_assets() -> Path:
    """The folder of Gymnasium-Robotics' hand assets, found without importing the package (its import
    registers environments and prints notices)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("the Gymnasium-Robotics hand needs the package: pip install 'graspmanifold[hands]' (from a "
                          "checkout: pip install '.[hands]')")
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
    _with_our_physics(spec)
    mount = spec.body("robot0:hand mount")  # placed in its environments' world: bring it to our mount's frame
    mount.pos = [0.0, 0.0, 0.0]
    mount.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    mount.quat = [1.0, 0.0, 0.0, 0.0]
    return spec


def _gymnasium_robotics(touch: bool = False) -> HandModel:
    """The description of Gymnasium-Robotics' hand, read from its MJCF like any other (`describe_shadow_hand`)."""
    loader = functools.partial(_gymnasium_spec, touch=True) if touch else _gymnasium_spec
    return describe_shadow_hand(loader, "gymnasium-robotics-touch" if touch else "gymnasium-robotics",
                                str(_gymnasium_assets() / "robot.xml"), mount="hand_mount")


def _menagerie_file() -> Path:
    """Menagerie's right hand: in the checkout `MENAGERIE_ROOT` names, or fetched by the `mujoco-menagerie`
    package where it is installed (it downloads the model once into its cache)."""
    root = os.environ.get("MENAGERIE_ROOT")
    if root:
        return Path(root) / "shadow_hand" / "right_hand.xml"
    if importlib.util.find_spec("mujoco_menagerie") is None:
        raise InvalidInput("hand 'menagerie' needs MuJoCo Menagerie: set MENAGERIE_ROOT to a checkout of it, or "
                           "pip install mujoco-menagerie (it downloads the hand once), or pass the path of its "
                           "shadow_hand/right_hand.xml as the hand")
    import mujoco_menagerie

    try:
        return Path(mujoco_menagerie.get("shadow_hand").xml("right_hand"))
    except Exception as error:  # noqa: BLE001 - its download failed: say so, with the way round it
        raise InvalidInput(f"hand 'menagerie': mujoco-menagerie could not fetch the hand ({error}); set "
                           "MENAGERIE_ROOT to a checkout of MuJoCo Menagerie instead") from None


def hand_file_spec(path: str | Path) -> mujoco.MjSpec:
    """A hand's MJCF file as the library reads it: an editable spec, its root body made the mocap mount (Scene
    moves the hand by moving it), its mesh and texture folders made absolute, with the library's physics options.

    Args:
        path: the MJCF file of the hand alone.

    Returns:
        The spec (`describe_shadow_hand` takes a function that makes one).

    Raises:
        InvalidInput: an unreadable file, more than the hand in its world, or a root body with joints.
    """
    path = Path(path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as error:  # MuJoCo's parser says what is wrong; keep its words
        raise InvalidInput(f"hand: cannot read the MJCF file {path}: {error}") from None
    roots, others = list(spec.worldbody.bodies), [g.name or "unnamed" for g in spec.worldbody.geoms]
    if len(roots) != 1 or others:
        raise InvalidInput(f"hand: {path} must hold the hand alone under its world (one body, no geoms), it has "
                           f"bodies {[b.name for b in roots]} and geoms {others}: pass the file of the hand alone "
                           "(Menagerie's shadow_hand/right_hand.xml, not its scene)")
    root = roots[0]
    if root.joints:
        raise InvalidInput(f"hand: the root body {root.name!r} of {path} has joints {[j.name for j in root.joints]}; "
                           "the hand must hang from a fixed root (its forearm), which the library moves")
    root.mocap = True
    for folder in ("meshdir", "texturedir"):  # absolute, so that the scene's XML (spec.to_xml) finds them anywhere
        setattr(spec, folder, str((path.parent / getattr(spec, folder)).resolve()))
    _with_our_physics(spec)
    return spec


def _with_our_physics(spec: mujoco.MjSpec) -> None:
    """The library's physics, whatever the hand: the same step, integrator, friction cone and impedance ratio."""
    ours = SHADOW_HAND.spec().option
    spec.option.timestep, spec.option.integrator = ours.timestep, ours.integrator
    spec.option.cone, spec.option.impratio = ours.cone, ours.impratio


def mjcf_hand(path: str | Path, name: str | None = None) -> HandModel:
    """A Shadow Hand model from the path of its MJCF file (the hand alone, hanging from a fixed root body:
    Menagerie's `shadow_hand/right_hand.xml`, Gymnasium-Robotics' hand written out whole, a model of your own).

    Args:
        path: the MJCF file; its meshes where the file says.
        name: what to call it (default: the file's absolute path, which worker processes load it from).

    Returns:
        Its description (`describe_shadow_hand`).

    Raises:
        InvalidInput: an unreadable file, more than the hand in its world, or a model that is not a right
            Shadow Hand in the paper's sense (the message says what differs).
    """
    path = check_input_file(path, "hand")
    return describe_shadow_hand(functools.partial(hand_file_spec, path), name or str(path), str(path))


def describe_shadow_hand(loader: Callable[[], mujoco.MjSpec], name: str, mjcf: str,
                         mount: str | None = None) -> HandModel:
    """Describe a Shadow Hand model from its MJCF alone: its joints named as Shadow names them (`FFJ4` ...
    `THJ1`, or numbered from 0 as Gymnasium-Robotics does, `FFJ3` ... `THJ0`, behind any one prefix), its
    bodies as ours are (`ffproximal` ... behind the same prefix); which of its joints turn the other way than
    the paper's is measured, not assumed.

    The measurement: a joint whose axis, in the palm frame of the straight hand, points against ours turns
    the other way (`HandModel.flipped`). The model is then checked from the half-closed hand, with the senses
    applied: a 0.1 rad turn of each joint must move a point 2 cm along its finger's distal phalanx as ours
    does (`joint_agreement` above `JOINT_AGREEMENT`), and each finger's proximal phalanx must sit within
    `PALM_TOLERANCE` of ours in the palm frame (a left hand, or another palm frame, fails here).
    A distal phalanx without a fingertip site gets one at its far end.

    Args:
        loader: builds the hand's MjSpec, the hand hanging from a mocap body, with the library's physics options
            (`hand_file_spec` reads a file so).
        name: what the model is called.
        mjcf: where its MJCF is (for the record).
        mount: the mocap body (default: the root body of the hand).

    Returns:
        The description.

    Raises:
        InvalidInput: joint names of no or of several hands, or a model whose joints or palm differ from
            the paper's (each named with its measure).
    """
    model = _compile(loader, name)
    prefix, shift = _naming(model, name)
    rename = {ours: f"{prefix}{ours[:2]}J{int(ours[3]) - shift}" for ours in HAND_JOINTS}
    finger_joints = tuple(rename[j] for j in SHADOW_HAND.finger_joints)
    body = {ours: f"{prefix}{ours}" for ours in SHADOW_HAND.segments}
    absent = [f"joint {j}" for j in rename.values() if _lookup(model.joint, j) is None]
    absent += [f"body {b}" for b in body.values() if _lookup(model.body, b) is None]
    if absent:
        raise InvalidInput(f"the hand model {name!r} lacks what a Shadow Hand has: {', '.join(absent)}")
    mount = mount or model.body(model.body(body["palm"]).rootid[0]).name
    distal = tuple(body[s] for s in DISTAL_SEGMENTS)
    found = [_tip_site(model, b) for b in distal]
    if any(site is None for site in found):
        ends = {b: _far_end(model, b) for b, site in zip(distal, found) if site is None}
        loader = functools.partial(_with_tip_sites, loader, ends)
    tips = [site or f"{b}_tip" for b, site in zip(distal, found)]
    flipped = _flipped(model, finger_joints, body["palm"])
    hand_joint_ids = {model.joint(rename[j]).id for j in HAND_JOINTS}
    actuators = tuple(model.actuator(a).name for a in range(model.nu) if _drives(model, a) & hand_joint_ids)
    hand = HandModel(
        name=name, mjcf=mjcf, finger_joints=finger_joints, wrist_joints=tuple(rename[j] for j in WRIST_JOINTS),
        finger_segments={f: tuple(body[s] for s in SHADOW_HAND.finger_segments[f]) for f in FINGERS},
        base_segments=tuple(body[s] for s in SHADOW_HAND.base_segments),
        joint_segment={rename[j]: body[s] for j, s in SHADOW_HAND.joint_segment.items()},
        fingertip_sites=tuple(tips), actuators=actuators, timestep=float(model.opt.timestep), mount=mount,
        palm=body["palm"], loader=loader,
        postures={key: tuple(SHADOW_HAND.keyframe_posture(key)) for key in ("open", "closed")}, flipped=flipped)
    _check_like_ours(hand)
    return hand


#: the least cosine between a model's fingertip motion and ours for a small turn of the same joint
JOINT_AGREEMENT = 0.9
#: m, how far a model's proximal phalanges may lie from ours in the palm frame
PALM_TOLERANCE = 0.01
_TURN = 0.1  # rad, the small turn of a joint
_ALONG_DISTAL = 0.02  # m, the point on the distal phalanx whose motion is compared


def _compile(loader: Callable[[], mujoco.MjSpec], name: str) -> mujoco.MjModel:
    try:
        return loader().compile()
    except ValueError as error:  # MuJoCo's compiler: a missing mesh file, a bad attribute
        raise InvalidInput(f"the hand model {name!r} does not compile: {error}") from None


def _lookup(find: Callable[[str], object], name: str) -> object | None:
    try:
        return find(name)
    except KeyError:
        return None


_JOINT_NAME = re.compile(r"^(?P<prefix>.*?)(?P<finger>FF|MF|RF|LF|TH|WR)J(?P<index>\d)$")


def _naming(model: mujoco.MjModel, name: str) -> tuple[str, int]:
    """The prefix of the hand's joint names, and 1 when they count from 0 (Gymnasium-Robotics' THJ0)."""
    found = [m for m in (_JOINT_NAME.match(model.joint(j).name) for j in range(model.njnt)) if m]
    prefixes = sorted({m["prefix"] for m in found})
    if len(prefixes) != 1:
        raise InvalidInput(f"the hand model {name!r} must name its joints as Shadow does (FFJ4 ... THJ1 or FFJ3 ... "
                           f"THJ0 behind one prefix); found {'no such joint' if not found else f'prefixes {prefixes}'}")
    zero_based = any(m["finger"] == "TH" and m["index"] == "0" for m in found)
    return prefixes[0], int(zero_based)


def _tip_site(model: mujoco.MjModel, body: str) -> str | None:
    """A site on the body named like a fingertip, if there is one."""
    sites = [model.site(s).name for s in range(model.nsite) if model.site_bodyid[s] == model.body(body).id]
    return next((s for s in sites if "tip" in s.lower()), None)


def _far_end(model: mujoco.MjModel, body: str) -> float:
    """m, how far along its z axis (the finger's) a body's colliding geometry reaches."""
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body(body).id
             and (model.geom_contype[g] or model.geom_conaffinity[g])]
    if not geoms:
        raise InvalidInput(f"the fingertip {body!r} has no colliding geometry to place a fingertip site on")
    reach = []
    for g in geoms:
        center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        corners = center + half * np.array(list(itertools.product((-1, 1), repeat=3)))
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.geom_quat[g])
        reach.append(float((model.geom_pos[g] + corners @ rotation.reshape(3, 3).T)[:, 2].max()))
    return max(reach)


def _with_tip_sites(loader: Callable[[], mujoco.MjSpec], ends: dict[str, float]) -> mujoco.MjSpec:
    spec = loader()
    for body, end in ends.items():
        spec.body(body).add_site(name=f"{body}_tip", pos=[0.0, 0.0, end], size=[0.003, 0.0, 0.0], group=3)
    return spec


def _drives(model: mujoco.MjModel, actuator: int) -> set[int]:
    """The joints an actuator moves: its joint, or those of its fixed tendon."""
    target = int(model.actuator_trnid[actuator, 0])
    if model.actuator_trntype[actuator] == mujoco.mjtTrn.mjTRN_JOINT:
        return {target}
    if model.actuator_trntype[actuator] == mujoco.mjtTrn.mjTRN_TENDON:
        first, count = model.tendon_adr[target], model.tendon_num[target]
        return {int(model.wrap_objid[w]) for w in range(first, first + count)}
    return set()


def _tip_motion(model: mujoco.MjModel, joints: tuple[str, ...], distal: tuple[str, ...], palm: str,
                posture: np.ndarray) -> np.ndarray:
    """(22, 3), m: how a small turn of each finger joint from `posture` (the model's angles) moves the point
    `_ALONG_DISTAL` along its finger's distal phalanx, in the palm frame."""
    data = mujoco.MjData(model)
    addresses = np.array([model.joint(j).qposadr[0] for j in joints])
    finger = [FINGERS.index(finger_of(ours)) for ours in SHADOW_HAND.finger_joints]

    def points(angles: np.ndarray) -> np.ndarray:
        data.qpos[:] = model.qpos0
        data.qpos[addresses] = angles
        mujoco.mj_kinematics(model, data)
        rotation, origin = data.xmat[model.body(palm).id].reshape(3, 3), data.xpos[model.body(palm).id]
        ids = [model.body(b).id for b in distal]
        along = data.xpos[ids] + data.xmat[ids].reshape(-1, 3, 3)[:, :, 2] * _ALONG_DISTAL
        return (along - origin) @ rotation

    before = points(posture)
    return np.array([points(posture + _TURN * np.eye(len(joints))[i])[finger[i]] - before[finger[i]]
                     for i in range(len(joints))])


def _cosines(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))


def _ours(posture: np.ndarray) -> np.ndarray:
    return _tip_motion(SHADOW_HAND.model, SHADOW_HAND.finger_joints, DISTAL_SEGMENTS, SHADOW_HAND.palm, posture)


def _axes(model: mujoco.MjModel, joints: tuple[str, ...], palm: str) -> np.ndarray:
    """(n, 3): the joints' axes in the palm frame, the hand straight."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rotation = data.xmat[model.body(palm).id].reshape(3, 3)
    return data.xaxis[[model.joint(j).id for j in joints]] @ rotation


def _flipped(model: mujoco.MjModel, joints: tuple[str, ...], palm: str) -> tuple[str, ...]:
    """The joints whose axis, in the palm frame of the straight hand, points against ours."""
    cosines = _cosines(_axes(model, joints, palm), _axes(SHADOW_HAND.model, SHADOW_HAND.finger_joints, SHADOW_HAND.palm))
    return tuple(j for j, c in zip(joints, cosines) if c < 0)


def joint_agreement(hand: HandModel) -> np.ndarray:
    """How each of a model's finger joints moves its fingertip against ours, from the half-closed hand, in the
    paper's sense (1: the same direction).

    Args:
        hand: a description.

    Returns:
        (22,): the cosine between the fingertip motions of a 0.1 rad turn, in posture order.
    """
    half_closed = 0.5 * (SHADOW_HAND.keyframe_posture("open") + SHADOW_HAND.keyframe_posture("closed"))
    distal = tuple(hand.finger_segments[f][-1] for f in FINGERS)
    model = hand.model
    theirs = _tip_motion(model, hand.finger_joints, distal, hand.palm, hand.to_model(half_closed))
    signs = hand.to_model(np.ones(len(hand.finger_joints)))  # a turn in the paper's sense, in the model's
    return _cosines(theirs * signs[:, None], _ours(half_closed))


def _proximal_phalanges(hand: HandModel) -> np.ndarray:
    """(5, 3), m: where each finger's proximal phalanx starts in the palm frame, the hand straight."""
    model, data = hand.model, mujoco.MjData(hand.model)
    mujoco.mj_kinematics(model, data)
    palm = model.body(hand.palm).id
    ids = [model.body(hand.finger_segments[f][-3]).id for f in FINGERS]
    return (data.xpos[ids] - data.xpos[palm]) @ data.xmat[palm].reshape(3, 3)


def _check_like_ours(hand: HandModel) -> None:
    agreement = joint_agreement(hand)
    unlike = [f"{j} ({c:.2f})" for j, c in zip(hand.finger_joints, agreement) if not c > JOINT_AGREEMENT]
    if unlike:
        raise InvalidInput(f"the hand model {hand.name!r} has joints that do not move as the paper's do (cosine of "
                           f"the fingertip motions, at least {JOINT_AGREEMENT} wanted): {', '.join(unlike)}")
    offsets = np.linalg.norm(_proximal_phalanges(hand) - _proximal_phalanges(SHADOW_HAND), axis=1)
    far = [f"{hand.finger_segments[f][-3]} {d * 1000:.0f} mm" for f, d in zip(FINGERS, offsets) if not d <= PALM_TOLERANCE]
    if far:
        raise InvalidInput(f"the hand model {hand.name!r} is not placed in its palm frame as a right Shadow Hand is "
                           f"(a left hand, or another palm frame): proximal phalanges from ours: {', '.join(far)}")


def hand_name(hand: str | Path, argument: str = "hand") -> str:
    """A hand as the library records it, without loading it: one of `HAND_MODELS`, or the absolute path of an
    MJCF file.

    Args:
        hand: a name or a path.
        argument: what the caller calls it (for the message).

    Returns:
        The name, or the absolute path.

    Raises:
        InvalidInput: neither a known name nor the path of an .xml file.
    """
    hand = current_name("hand", hand)  # a name written before 0.2
    if isinstance(hand, str) and hand in HAND_MODELS:
        return hand
    if isinstance(hand, (str, Path)) and str(hand).endswith(".xml"):
        return str(check_input_file(hand, argument))
    raise InvalidInput(f"{argument} must be one of {HAND_MODELS} or the path of an MJCF file (.xml), got {hand!r}")


def hand_model(hand: str | Path = SHADOW_HAND.name) -> HandModel:
    """A hand model by name or by the path of its MJCF file, checked against its MJCF.

    Args:
        hand: one of `HAND_MODELS` (`menagerie` reads `$MENAGERIE_ROOT/shadow_hand/right_hand.xml`), or the path
            of an MJCF file of a right Shadow Hand alone (`mjcf_hand`).

    Returns:
        Its description: one object per name, and per path and content (a file edited in place, or one of
        the files it includes or its meshes, is read again; `HandModel.digest` tells the two apart).

    Raises:
        InvalidInput: an unknown name, a file that is not a Shadow Hand, or a model that lacks a part its
            description names (listed).
        ImportError: the model's package is not installed (the message says how to install it).
    """
    name = hand_name(hand)
    return _described(name, "" if name in HAND_MODELS else _file_digest(name))


def _file_digest(path: str) -> str:
    """A digest of the hand file as MuJoCo compiles it (its includes and meshes with it)."""
    try:
        model = hand_file_spec(path).compile()
    except ValueError as error:
        raise InvalidInput(f"the hand model {path!r} does not compile: {error}") from None
    binary = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, binary)
    return hashlib.sha256(binary.tobytes()).hexdigest()


@functools.cache
def _described(hand: str, content: str) -> HandModel:
    """The description of a named hand, or of a hand file with this content (the cache's key)."""
    if hand == SHADOW_HAND.name:
        described = SHADOW_HAND
    elif hand.startswith("gymnasium-robotics"):
        described = _gymnasium_robotics(touch=hand.endswith("-touch"))
    elif hand == "menagerie":
        described = mjcf_hand(_menagerie_file(), name="menagerie")
    else:
        described = mjcf_hand(hand)
    check_hand_model(described)
    return described


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
    drives = np.abs(hand.coupling()).sum(axis=0)
    if not np.all(drives <= 1):
        raise InvalidInput(f"the hand model {hand.name!r} drives a finger joint with more than one actuator")
    driven = {joint for joint, count in zip(hand.finger_joints, drives) if count}
    undriven = [joint for joint in hand.finger_joints if joint not in driven
                and not any(joint in tendon and tendon & driven for tendon in _fixed_tendons(hand.model))]
    if undriven:
        raise InvalidInput(f"the hand model {hand.name!r} has no actuator for {', '.join(undriven)}, nor a fixed tendon "
                           "that couples it to a driven joint: the controller could not move it")


def _fixed_tendons(model: mujoco.MjModel) -> list[set[str]]:
    """The joints of each fixed tendon of a model."""
    wraps = [range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t]) for t in range(model.ntendon)]
    return [{model.joint(model.wrap_objid[w]).name for w in tendon if model.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT}
            for tendon in wraps]
