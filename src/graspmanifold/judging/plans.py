"""Plans: a grasp as an open loop executes it (`OpenLoopGrasp`: the pregrasp, the grasp and the squeeze, each a palm
pose in the object frame and a posture), and how a posture at its palm pose becomes one (`GraspStages`,
`open_loop_grasp`, `open_loop_grasps`). The replay (`replay`), the push test (`push_test`), planned trials and grasp
files all take this value.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import check_choice
from ..manifold.postureset import PostureSet
from ..sim.grip import SQUEEZE, squeezed
from ..sim.hand import SHADOW_HAND
from ..sim.normal_offsets import offset_along_normals
from ..sim.objects import GraspObject, object_from_params
from ..sim.posture import open_posture
from ..sim.scene import Scene

#: the stages of an open-loop grasp, in order
STAGE_NAMES: tuple[str, ...] = ("pregrasp", "grasp", "squeeze")
#: the farthest a stage's palm may lie from the object's centre (m): farther is no grasp of it (a stage moved a
#: million metres away replayed as held: the free object waited, weightless, for the hand to come back)
MAX_REACH = 1.0


@dataclass(frozen=True)
class OpenLoopGrasp:
    """A grasp as DexGraspBench replays it: the pregrasp, the grasp and the squeeze, each a palm pose in the
    object frame and a posture.

    Attributes:
        poses: (3, 7) the palm's position (m) and orientation (w x y z) in the object frame, per stage.
        postures: (3, 22) rad, the finger joints per stage (the paper's joint order and senses).
    """

    poses: np.ndarray
    postures: np.ndarray

    def __post_init__(self) -> None:
        for name, width in (("poses", 7), ("postures", 22)):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3, width):
                raise InvalidInput(f"OpenLoopGrasp.{name} must be (3, {width}) values (pregrasp, grasp, squeeze), got "
                                   f"shape {value.shape}")
            if not np.all(np.isfinite(value)):
                raise InvalidInput(f"OpenLoopGrasp.{name} must be finite, got NaN or infinite values in the "
                                   f"{', '.join(STAGE_NAMES[i] for i in np.flatnonzero(~np.isfinite(value).all(axis=1)))}")
            object.__setattr__(self, name, value)
        reach = np.linalg.norm(self.poses[:, :3], axis=1)
        if np.any(reach > MAX_REACH):
            stage = int(np.argmax(reach))
            raise InvalidInput(f"OpenLoopGrasp.poses: the {STAGE_NAMES[stage]}'s palm lies {reach[stage]:.3g} m from the "
                               f"object's centre; a grasp's palm is within {MAX_REACH:g} m of it")
        length = np.linalg.norm(self.poses[:, 3:], axis=1)
        if np.any(np.abs(length - 1.0) > 1e-6):
            raise InvalidInput(f"OpenLoopGrasp.poses: each orientation must be a unit quaternion (w x y z), got lengths "
                               f"{np.round(length, 6).tolist()}")

    @property
    def squeeze_offset(self) -> np.ndarray:
        """(22,) rad, the squeeze's posture less the grasp's: how hard the grasp presses, joint by joint (what an
        experience carries as a grasp's `squeezes`, `manifold.experience`)."""
        return self.postures[2] - self.postures[1]


#: m the pregrasp's palm stands back from the grasp's, away from the object's centre
PREGRASP_BACK_OFF = 0.02


@dataclass(frozen=True)
class GraspStages:
    """How a posture at its palm pose becomes an open-loop grasp (`open_loop_grasp`): its pregrasp and squeeze.

    Attributes:
        pregrasp: 'open' (the open hand with its palm `back_off` further from the object's centre) or 'contacts'
            (the grasp with every touching finger segment `back_off` out along the object's normal, the palm at
            the grasp's pose: an approach along the normals that does not sweep the object;
            `normal_offsets.offset_along_normals`).
        squeeze: 'flexion' (the flexion joints `squeeze_angle` further towards the closed hand, as the
            controller squeezes: `sim.grip.squeezed`) or 'contacts' (every touching segment `squeeze_depth` into
            the object along its normal, so that each servo presses its contact inwards).
        back_off: m.
        squeeze_angle: rad.
        squeeze_depth: m.
    """

    pregrasp: str = "open"
    squeeze: str = "flexion"
    back_off: float = PREGRASP_BACK_OFF
    squeeze_angle: float = SQUEEZE
    squeeze_depth: float = 0.01

    def __post_init__(self) -> None:
        for name, choices in (("pregrasp", ("open", "contacts")), ("squeeze", ("flexion", "contacts"))):
            check_choice(getattr(self, name), choices, f"GraspStages.{name}")
        for name in ("back_off", "squeeze_angle", "squeeze_depth"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 0.5:
                raise InvalidInput(f"GraspStages.{name} must be a number in [0, 0.5), got {value!r}")

    @property
    def from_contacts(self) -> bool:
        """Whether a stage is made from the grasp's contacts (it then needs a scene of the object)."""
        return "contacts" in (self.pregrasp, self.squeeze)


#: the stages of open-loop grasps by name: the open hand and the controller's squeeze ('open'), and those made from
#: the contacts ('contacts', the generator's default: more of its candidates hold when replayed, docs/studies/protocols.md)
GRASP_STAGES: dict[str, GraspStages] = {"open": GraspStages(),
                                        "contacts": GraspStages(pregrasp="contacts", squeeze="contacts")}
#: the stages the generator verifies with unless told otherwise (`GeneratorParams.stages`)
VERIFY_STAGES = "contacts"


def open_loop_grasp(hand_pose: np.ndarray, posture: np.ndarray, stages: GraspStages = GRASP_STAGES["open"],
                    scene: Scene | None = None) -> OpenLoopGrasp:
    """One posture at its palm pose as an open-loop grasp: the pregrasp, the grasp (the posture at its palm pose)
    and the squeeze, as `stages` says.

    Args:
        hand_pose: (7,) the palm's position (m) and orientation (w x y z) in the object frame.
        posture: (22,) rad, the grasp's finger joints.
        stages: how the pregrasp and the squeeze are made (`GRASP_STAGES`).
        scene: a scene of the object and the hand: its hand's open and closed postures; needed for stages made
            from the contacts (its state is changed). None: our hand, flexion stages only.

    Returns:
        The `OpenLoopGrasp`.
    """
    pose, posture = np.asarray(hand_pose, dtype=float), np.asarray(posture, dtype=float)
    if stages.from_contacts and scene is None:
        raise InvalidInput("open_loop_grasp: stages made from the contacts need the object's scene (scene=)")
    hand = SHADOW_HAND if scene is None else scene.hand
    if stages.pregrasp == "open":
        away = pose[:3] / max(float(np.linalg.norm(pose[:3])), 1e-9)
        pregrasp = np.r_[pose[:3] + stages.back_off * away, pose[3:]], open_posture(hand)
    else:
        assert scene is not None  # refused above
        pregrasp = pose, offset_along_normals(scene, pose, posture, -stages.back_off)
    if stages.squeeze == "flexion":
        squeeze = squeezed(posture, stages.squeeze_angle, hand)
    else:
        assert scene is not None  # refused above
        squeeze = offset_along_normals(scene, pose, posture, stages.squeeze_depth)
    return OpenLoopGrasp(np.array([pregrasp[0], pose, pose]), np.array([pregrasp[1], posture, squeeze]))


def open_loop_grasps(postures: PostureSet, stages: GraspStages | None = None,
                     obj: str | GraspObject | None = None) -> list[OpenLoopGrasp]:
    """Our postures as open-loop grasps (`open_loop_grasp` of each at its palm pose).

    Args:
        postures: a posture set (palm poses in the object frame and postures).
        stages: how the pregrasp and the squeeze are made (`GRASP_STAGES`); None: those the set was verified with
            (its metadata's `generator.stages` and `squeeze`; 'open' for a set made without them).
        obj: the set's object, or its name (for stages made from the contacts; None: the object its metadata
            names); the set's hand is its metadata's.

    Returns:
        One `OpenLoopGrasp` per posture.
    """
    if stages is None:
        made = postures.metadata.get("generator", {})
        stages = replace(GRASP_STAGES[made.get("stages", "open")], squeeze_angle=made.get("squeeze", GraspStages.squeeze_angle))
    if obj is None and stages.from_contacts:
        if "object" not in postures.metadata:
            raise InvalidInput("open_loop_grasps: stages made from the contacts need the set's object (obj=): its "
                               "metadata names none")
        obj = object_from_params(postures.metadata["object"])
        if obj.shape == "mesh" and obj.mesh is None:  # a file keeps a mesh's digest, not the mesh
            raise InvalidInput(f"open_loop_grasps: the set's object {obj.name!r} is a mesh its file does not hold: "
                               "give it, open_loop_grasps(postures, obj=the_mesh_object)")
    scene = None if obj is None else Scene(obj, hand=postures.hand)
    return [open_loop_grasp(pose, posture, stages, scene)
            for pose, posture in zip(postures.hand_poses, postures.postures)]
