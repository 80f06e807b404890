"""The Shadow Dexterous Hand: names, joint ranges and the MJCF model shipped with the library.

Everything that other modules need to know about a hand model lives in one object, a `HandModel`:
the joint order of a grasp posture, which segment each joint moves (for the Partial Contact
Posture), the actuators; the J1+J2 coupling and the open and closed postures are read from its MJCF.
`SHADOW_HAND` is ours and the default; the module's tables (`FINGER_JOINTS`, `SEGMENTS`, ...) are its.
`tests/test_hand.py` checks each table against the compiled model.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np

from ..base.errors import InvalidInput

FINGERS: tuple[str, ...] = ("ff", "mf", "rf", "lf", "th")
"""The five fingers: first, middle, ring, little finger and thumb."""

def asset_path(name: str) -> Path:
    """Path of a file shipped in the library's assets (wheel install or source checkout)."""
    packaged = resources.files("graspmanifold") / "assets" / name
    if packaged.is_file():
        return Path(str(packaged))
    checkout = Path(__file__).resolve().parents[3] / "assets" / name
    if checkout.is_file():
        return checkout
    raise FileNotFoundError(f"asset {name!r} is neither in the installed package nor in {checkout.parent}")


@functools.lru_cache(maxsize=8)
def _read_spec(path: str) -> mujoco.MjSpec:
    """A model file of the library's assets, read once (`HandModel.spec` copies it)."""
    return mujoco.MjSpec.from_file(path)


@dataclass(frozen=True, eq=False)
class HandModel:
    """A hand model as the library sees it, in one object: which of its joints make the paper's 22-joint
    posture and in what order, its segments (for the Partial Contact Posture and touch), its fingertip
    sites and actuators; the J1/J2 coupling and the open and closed postures are read from its MJCF (the
    actuators' joints or fixed tendons, the keyframes `open` and `closed`). `SHADOW_HAND`, our MJCF, is
    the default, and the module's tables (`FINGER_JOINTS`, `SEGMENTS`, ...) are its.

    Attributes:
        name: what the model is called.
        mjcf: the asset file of the hand alone, hanging on the mocap body `mount`.
        finger_joints: the model's joints in posture order (22).
        wrist_joints: the model's wrist joints (2).
        finger_segments: the bodies of each finger (FINGERS) that can touch an object, palm side first.
        base_segments: the other bodies that can touch an object (forearm, wrist, palm).
        joint_segment: the segment each finger joint moves.
        fingertip_sites: one site per finger.
        actuators: the position actuators, in the model's order.
        timestep: s, the physics step of the model (its <option timestep>).
        mount: the mocap body the hand hangs on.
        palm: the palm's body.
        loader: builds the hand's MjSpec (None: read `mjcf` from the library's assets).
        postures: the open and closed postures (22 values in posture order, the paper's sense, rad) for a
            model whose MJCF has no such keyframes; clipped to the model's joint ranges.
        flipped: the finger joints that turn the other way than the paper's (flexion negative): a posture
            angle a is the model's -a there (`to_model`, `from_model`).
    """

    name: str
    mjcf: str
    finger_joints: tuple[str, ...]
    wrist_joints: tuple[str, ...]
    finger_segments: dict[str, tuple[str, ...]]
    base_segments: tuple[str, ...]
    joint_segment: dict[str, str]
    fingertip_sites: tuple[str, ...]
    actuators: tuple[str, ...]
    timestep: float
    mount: str = "hand_mount"
    palm: str = "palm"
    loader: Callable[[], mujoco.MjSpec] | None = None
    postures: dict[str, tuple[float, ...]] = field(default_factory=dict)
    flipped: tuple[str, ...] = ()

    @functools.cached_property
    def _signs(self) -> np.ndarray:
        return np.array([-1.0 if joint in self.flipped else 1.0 for joint in self.finger_joints])

    def to_model(self, posture: np.ndarray) -> np.ndarray:
        """A posture in the paper's sense as this model's finger joint angles.

        Args:
            posture: (..., 22), rad.

        Returns:
            The model's angles (..., 22), rad, in `finger_joints` order.
        """
        return np.asarray(posture, dtype=float) * self._signs

    def from_model(self, angles: np.ndarray) -> np.ndarray:
        """This model's finger joint angles as a posture in the paper's sense.

        Args:
            angles: (..., 22), rad, in `finger_joints` order.

        Returns:
            The posture (..., 22), rad.
        """
        return np.asarray(angles, dtype=float) * self._signs

    @functools.cached_property
    def digest(self) -> str:
        """What the hand is, as a key: a digest of its compiled model (MuJoCo's binary model of the MJCF with
        every file it includes and every mesh it loads) and of its description (joints, segments, sites, ...),
        not of its name or path. Every result made with the hand is keyed by it (`checkpoints.result_key`), so
        a hand file edited in place gives new results, never the old file's."""
        binary = np.zeros(mujoco.mj_sizeModel(self.model), dtype=np.uint8)
        mujoco.mj_saveModel(self.model, None, binary)
        digest = hashlib.sha256(binary.tobytes())
        description = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("name", "mjcf", "loader")}
        digest.update(json.dumps(description, sort_keys=True, default=str).encode())
        return digest.hexdigest()[:20]

    @functools.cached_property
    def span(self) -> float:
        """The hand's span, m: the largest distance from the thumb's tip to another fingertip with the hand open
        (the `open` posture); an object wider than this at its narrowest cannot be closed around."""
        model = self.model
        data = mujoco.MjData(model)
        angles = self.to_model(self.keyframe_posture("open"))
        for joint, angle in zip(self.finger_joints, angles):
            data.qpos[model.joint(joint).qposadr[0]] = angle
        mujoco.mj_kinematics(model, data)
        tips = np.array([data.site_xpos[model.site(site).id] for site in self.fingertip_sites])
        thumb = FINGERS.index("th")
        return float(np.linalg.norm(np.delete(tips, thumb, axis=0) - tips[thumb], axis=1).max())

    @functools.cached_property
    def joint_ranges(self) -> dict[str, tuple[float, float]]:
        """Each wrist and finger joint's range, rad, by name, as its MJCF gives it (where ranges are written)."""
        ranges = {name: self.model.joint(name).range for name in self.wrist_joints + self.finger_joints}
        return {name: (float(low), float(high)) for name, (low, high) in ranges.items()}

    @functools.cached_property
    def _limits(self) -> np.ndarray:
        ranges = self.to_model(np.array([self.joint_ranges[j] for j in self.finger_joints]).T).T
        return np.sort(ranges, axis=1)

    def limits(self) -> np.ndarray:
        """The finger joints' ranges in the paper's sense.

        Returns:
            (22, 2) array of [lower, upper], rad, in posture order.
        """
        return self._limits.copy()

    @property
    def segments(self) -> tuple[str, ...]:
        """Every body that can touch an object (a tactile "segment"): the base segments, then each finger's."""
        return self.base_segments + tuple(s for f in FINGERS for s in self.finger_segments[f])

    def spec(self) -> mujoco.MjSpec:
        """A fresh, editable MjSpec of the hand (Scene adds the object to it): its loader's, or a copy of the
        library's file read once per process (the same model bit for bit as reading the file again; a batch of a
        thousand scenes read it a thousand times, and on the GPU machine, after the GPU's start, one of those reads
        failed: "XML Error: unknown error in attribute 'mass'").

        Returns:
            The spec.
        """
        return self.loader() if self.loader is not None else _read_spec(str(asset_path(self.mjcf))).copy()

    def to_xml(self) -> str:
        """The hand alone as MJCF text, as MuJoCo writes its spec (`spec().to_xml()`): to open it in another tool,
        or to edit it into a hand file of one's own (`hand_models.hand_model(path)` reads one back).

        Returns:
            The XML text.
        """
        return self.spec().to_xml()

    @functools.cached_property
    def model(self) -> mujoco.MjModel:
        """The compiled hand alone (compiled once; do not change it, `spec().compile()` gives a fresh one)."""
        return self.spec().compile()

    def keyframe_posture(self, key: str) -> np.ndarray:
        """A posture stored in the MJCF as a keyframe (or, for a model without it, in `postures`), in the
        paper's sense. Read from the model once per key (the starting-posture search asks hundreds of thousands
        of times).

        Args:
            key: the keyframe's name (`open`, `closed`).

        Returns:
            Its finger joint angles in posture order (22,), rad (a copy: the caller may change it).
        """
        if key not in self._keyframes:
            self._keyframes[key] = self._read_keyframe(key)
        return self._keyframes[key].copy()

    @functools.cached_property
    def _keyframes(self) -> dict[str, np.ndarray]:
        """The keyframe postures read so far, by key."""
        return {}

    def _read_keyframe(self, key: str) -> np.ndarray:
        model = self.model
        try:
            qpos = model.key(key).qpos
        except KeyError:
            if key not in self.postures:
                raise InvalidInput(f"the hand model {self.name!r} has no keyframe {key!r}") from None
            ranges = np.array([model.joint(name).range for name in self.finger_joints])
            return self.from_model(np.clip(self.to_model(np.asarray(self.postures[key])), ranges[:, 0], ranges[:, 1]))
        return self.from_model(np.array([qpos[model.joint(name).qposadr[0]] for name in self.finger_joints]))

    @functools.cached_property
    def ctrl_matrix(self) -> np.ndarray:
        """(actuators, 22): actuator targets = ctrl_matrix @ posture, for a posture in the paper's sense
        (`coupling` with the flipped joints' columns negated); the wrist rows are 0."""
        return self.coupling() * self._signs

    @functools.cached_property
    def wrist_rows(self) -> np.ndarray:
        """The rows of `actuators` that drive the wrist joints, in `wrist_joints` order."""
        model = self.model
        driven = {model.joint(int(model.actuator(name).trnid[0])).name: row for row, name in enumerate(self.actuators)
                  if model.actuator(name).trntype[0] == mujoco.mjtTrn.mjTRN_JOINT}
        return np.array([driven[joint] for joint in self.wrist_joints])

    def missing(self) -> list[str]:
        """What this description names that its MJCF lacks (an incomplete or foreign model).

        Returns:
            One entry per missing joint, body, site or actuator ('joint FFJ4', ...); empty when complete.
        """
        model = self.model
        wanted = ([("joint", j) for j in self.wrist_joints + self.finger_joints]
                  + [("body", b) for b in (self.mount, self.palm, *self.segments)]
                  + [("site", s) for s in self.fingertip_sites] + [("actuator", a) for a in self.actuators])
        found = {"joint": model.joint, "body": model.body, "site": model.site, "actuator": model.actuator}
        absent = []
        for kind, name in wanted:
            try:
                found[kind](name)
            except KeyError:
                absent.append(f"{kind} {name}")
        absent += [f"joint {j} (no segment for it)" for j in self.finger_joints if j not in self.joint_segment]
        return absent

    def coupling(self) -> np.ndarray:
        """How a posture drives the actuators: a (actuators, 22) matrix with a 1 where an actuator's
        joint, or a joint of its fixed tendon (J1 + J2 of a finger), is a posture joint; wrist rows are 0.

        Returns:
            The matrix.
        """
        model, index = self.model, {name: i for i, name in enumerate(self.finger_joints)}
        matrix = np.zeros((len(self.actuators), len(self.finger_joints)))
        for row, name in enumerate(self.actuators):
            actuator = model.actuator(name)
            target = int(actuator.trnid[0])
            if actuator.trntype[0] == mujoco.mjtTrn.mjTRN_JOINT:
                joints = [model.joint(target).name]
            else:  # a fixed tendon: the joints it sums
                first, count = model.tendon_adr[target], model.tendon_num[target]
                joints = [model.joint(model.wrap_objid[w]).name for w in range(first, first + count)]
            for joint in joints:
                if joint in index:
                    matrix[row, index[joint]] = 1.0
        return matrix


SHADOW_HAND = HandModel(
    name="shadow-primitives",
    mjcf="shadow_hand.xml",
    finger_joints=(
        "FFJ4", "FFJ3", "FFJ2", "FFJ1",
        "MFJ4", "MFJ3", "MFJ2", "MFJ1",
        "RFJ4", "RFJ3", "RFJ2", "RFJ1",
        "LFJ5", "LFJ4", "LFJ3", "LFJ2", "LFJ1",
        "THJ5", "THJ4", "THJ3", "THJ2", "THJ1",
    ),
    wrist_joints=("WRJ2", "WRJ1"),
    finger_segments={
        "ff": ("ffproximal", "ffmiddle", "ffdistal"),
        "mf": ("mfproximal", "mfmiddle", "mfdistal"),
        "rf": ("rfproximal", "rfmiddle", "rfdistal"),
        "lf": ("lfmetacarpal", "lfproximal", "lfmiddle", "lfdistal"),
        "th": ("thproximal", "thmiddle", "thdistal"),
    },
    base_segments=("forearm", "wrist", "palm"),
    # the segment S_{i,j} that joint j of finger i moves: the first body with geometry at or beyond the
    # joint (knuckle, thbase and thhub carry no geometry of their own)
    joint_segment={
        **{f"{F}J{j}": f"{F.lower()}{seg}" for F in ("FF", "MF", "RF", "LF")
           for j, seg in ((4, "proximal"), (3, "proximal"), (2, "middle"), (1, "distal"))},
        "LFJ5": "lfmetacarpal",
        "THJ5": "thproximal", "THJ4": "thproximal",
        "THJ3": "thmiddle", "THJ2": "thmiddle",
        "THJ1": "thdistal",
    },
    fingertip_sites=tuple(f"{f}tip" for f in FINGERS),
    actuators=(
        "A_WRJ2", "A_WRJ1",
        "A_FFJ4", "A_FFJ3", "A_FFJ0",
        "A_MFJ4", "A_MFJ3", "A_MFJ0",
        "A_RFJ4", "A_RFJ3", "A_RFJ0",
        "A_LFJ5", "A_LFJ4", "A_LFJ3", "A_LFJ0",
        "A_THJ5", "A_THJ4", "A_THJ3", "A_THJ2", "A_THJ1",
    ),
    timestep=0.002,
)  # fmt: skip
"""Our MJCF of the Shadow Dexterous Hand, written from the published kinematics: the default hand. The
tables below are its."""

FINGER_JOINTS: tuple[str, ...] = SHADOW_HAND.finger_joints
"""The 22 finger joints in grasp-posture order: finger by finger, proximal to distal."""

N_FINGER_JOINTS = len(FINGER_JOINTS)
"""The length of a grasp posture: the number of finger joints (22)."""

WRIST_JOINTS: tuple[str, ...] = SHADOW_HAND.wrist_joints
"""The two wrist joints."""

HAND_JOINTS: tuple[str, ...] = WRIST_JOINTS + FINGER_JOINTS
"""All 24 hinge joints, wrist first, in the model's order."""

JOINT_RANGES: dict[str, tuple[float, float]] = SHADOW_HAND.joint_ranges
"""Joint ranges (radians) by joint name, read from our MJCF (which tests/test_hand.py checks against the kinematics
sheet)."""

FINGER_SEGMENTS: dict[str, tuple[str, ...]] = SHADOW_HAND.finger_segments
"""The segments of each finger that carry collision geometry, palm side first."""

SEGMENTS: tuple[str, ...] = SHADOW_HAND.segments
"""Every hand body that can touch an object (a tactile "segment"), in a fixed order."""

DISTAL_SEGMENTS: tuple[str, ...] = tuple(FINGER_SEGMENTS[f][-1] for f in FINGERS)
"""The fingertip segments, one per finger in FINGERS order."""

FINGERTIP_SITES: tuple[str, ...] = SHADOW_HAND.fingertip_sites
"""The fingertip sites of the model (the springs of the posture generator pull there)."""

JOINT_SEGMENT: dict[str, str] = SHADOW_HAND.joint_segment
"""The segment S_{i,j} that joint j of finger i moves (the PCP of Eq. 1)."""

ACTUATORS: tuple[str, ...] = SHADOW_HAND.actuators
"""The 20 position actuators, in the model's order. xxJ0 drives J1 + J2 of that finger."""

PHYSICS_TIMESTEP = SHADOW_HAND.timestep
"""s, the physics step of the model (its <option timestep>): a control period is a whole number of them."""


def load_hand() -> mujoco.MjModel:
    """The compiled hand alone, mounted at the world origin on its mocap body `hand_mount`."""
    return SHADOW_HAND.spec().compile()


def finger_of(name: str) -> str | None:
    """Finger ('ff', 'mf', 'rf', 'lf', 'th') of a joint or segment name; None for palm, wrist, forearm."""
    prefix = name[:2].lower()
    return prefix if prefix in FINGERS else None


def finger_limits() -> np.ndarray:
    """(22, 2) array of [lower, upper] joint limits in posture order (radians): ours (`HandModel.limits`)."""
    return SHADOW_HAND.limits()


def segment_of_geoms(model: mujoco.MjModel, hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """For every geom of a model holding the hand, the index in SEGMENTS of the segment (body) it
    belongs to, -1 for geoms that are not the hand's (the object, a table) or that never collide (a
    model's visual meshes)."""
    index = {name: i for i, name in enumerate(hand.segments)}
    collides = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.array([index.get(model.body(model.geom_bodyid[g]).name, -1) if collides[g] else -1
                     for g in range(model.ngeom)], dtype=int)


class SegmentKinematics:
    """Where the hand's segments are for a posture: the centre of each segment's collision geometry in
    the palm frame (m), from the hand model alone (the hand's knowledge of its own body, no object).

    The controller's reach extension compares where a touching segment is now with where a recalled
    grasp would put it (`controller.ControllerParams.reach`)."""

    def __init__(self, hand: HandModel = SHADOW_HAND) -> None:
        self.hand = hand
        self.model = hand.model  # read only: the positions are computed in this object's own data
        self.data = mujoco.MjData(self.model)
        self._qpos = np.array([self.model.joint(name).qposadr[0] for name in hand.finger_joints])
        segment_of = segment_of_geoms(self.model, hand)
        self._geoms = np.array([int(np.flatnonzero(segment_of == i)[0]) for i in range(len(hand.segments))])
        self._palm = self.model.body(hand.palm).id
        self._tips = np.array([self.model.site(site).id for site in hand.fingertip_sites])

    def fingertips(self, posture: np.ndarray) -> np.ndarray:
        """Where the fingertips are for a posture, the wrist straight.

        Args:
            posture: the 22 finger joint angles, radians, the paper's sense.

        Returns:
            The fingertip sites (5, 3), m, in the palm frame, in `fingertip_sites` order.
        """
        self.data.qpos[:] = 0.0
        self.data.qpos[self._qpos] = self.hand.to_model(posture)
        mujoco.mj_kinematics(self.model, self.data)
        rotation = self.data.xmat[self._palm].reshape(3, 3)
        return (self.data.site_xpos[self._tips] - self.data.xpos[self._palm]) @ rotation

    def positions(self, posture: np.ndarray) -> np.ndarray:
        """Where the segments are for a posture, the wrist straight.

        Args:
            posture: the 22 finger joint angles, radians, the paper's sense.

        Returns:
            The centres (len(SEGMENTS), 3) of the segments' collision geometry, m, in the palm frame.
        """
        self.data.qpos[:] = 0.0
        self.data.qpos[self._qpos] = self.hand.to_model(posture)
        mujoco.mj_kinematics(self.model, self.data)
        rotation = self.data.xmat[self._palm].reshape(3, 3)
        return (self.data.geom_xpos[self._geoms] - self.data.xpos[self._palm]) @ rotation
