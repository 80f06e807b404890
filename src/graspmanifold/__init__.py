"""graspmanifold: experience-based, tactile-driven dextrous grasping with SOM grasp manifolds.

An implementation (and extension) of "SOM-based experience representation for dextrous grasping"
(WSOM 2007) on a MuJoCo model of the 24-joint Shadow Dexterous Hand.
"""

from .base.errors import (
    BackendUnavailable, GenerationError, GraspManifoldError, InvalidInput, NotFittedError, OutputInUse, QualityError,
    RenderingUnavailable, SimulationError, WorkersLost,
)
from .base.moved import install, moved_warning, new_name
from .sim.render import choose_offscreen_backend

install()  # the modules that moved in 0.2 answer to their old names, with a warning

choose_offscreen_backend()  # before MuJoCo's first import (below): pictures in this process on a headless machine

from .manifold.analysis import resume_learning, smoothness  # noqa: E402
from .control.controller import ControllerParams, GraspController, PalmSteering
from .control.recall import ApproachRecall, BlendRecall, TargetRecall
from .control.regrasp import Regrasp
from .trials.evaluation import EvaluationResult, evaluate
from .manifold.experience import Experience, PostureDatabase
from .synthesis.generator import DATASET_PRESETS, GeneratorParams, generate_postures, verify_postures
from .synthesis.start_cache import starting_postures
from .trials.grid import grid_preset, reachable, why_unreachable
from .sim.hand import (
    ACTUATORS,
    DISTAL_SEGMENTS,
    FINGER_JOINTS,
    FINGER_SEGMENTS,
    FINGERS,
    FINGERTIP_SITES,
    HandModel,
    HAND_JOINTS,
    SHADOW_HAND,
    JOINT_RANGES,
    SEGMENTS,
    finger_limits,
    load_hand,
)
from .sim.flange import FlangeLimits
from .sim.objects import PAPER_OBJECTS, GraspObject, get_object, make_object
from .sim.posture import (
    clip_posture,
    closed_posture,
    dict_to_posture,
    open_posture,
    pcp_mask,
    pcp_masks,
    posture_to_ctrl,
    posture_to_dict,
    validate_posture,
    within_limits,
)
from .manifold.postureset import PostureSet
from .judging.quality import epsilon_l1
from .sim.scene import Scene, facing_pose
from .manifold.som import SOM, SOMSchedule
from .manifold.ukr import UKR
from .manifold.linear import LinearManifold
from .synthesis.refinement import StartingPosture
from .sim.tactile import TactileReading, TactileSensor
from .trials.recording import Recording, record_trial
from .trials.setup import Noise, TrialSetup
from .trials.stats import headroom, holm, mcnemar, wilson_interval
from .trials.stats import compare
from .base.progress import show_progress
from .base.version import __version__

#: modules reachable as attributes (`gm.plots`, `gm.stats`, ...), by the subpackage they live in, without
#: importing them up front: plotting pulls in matplotlib, which a simulation-only user does not need
_SUBMODULES = {
    "analysis": "manifold", "benchmark": "trials", "errors": "base", "evaluation": "trials",
    "experience_pays": "trials", "figures": "paper", "grid": "trials", "io": "base", "judge": "judging",
    "plots": "manifold", "quality": "judging", "regrasp": "control", "render": "sim", "report": "paper",
    "reproduce": "paper", "stats": "trials", "strategy_selector": "trials", "trial": "trials", "validation": "base",
    "workers": "base",
}
#: attributes that named modules since renamed (`base.moved`): they still answer, with a warning
_RENAMED_ATTRIBUTES = {"selector": "trials.selector", "study": "trials.study"}


#: functions reachable as attributes without importing their module up front (the plots pull in matplotlib)
_LAZY_FUNCTIONS = {"lattice_figure": "manifold.plots"}


def __getattr__(name: str) -> object:
    if name in _SUBMODULES or name in _LAZY_FUNCTIONS:
        import importlib

        if name in _LAZY_FUNCTIONS:
            return getattr(importlib.import_module(f".{_LAZY_FUNCTIONS[name]}", __name__), name)
        return importlib.import_module(f".{_SUBMODULES[name]}.{name}", __name__)
    if name in _RENAMED_ATTRIBUTES:
        import importlib

        new = new_name(_RENAMED_ATTRIBUTES[name])
        assert new is not None
        moved_warning(name, new)
        return importlib.import_module(f".{new}", __name__)
    raise AttributeError(f"module 'graspmanifold' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public names and the submodules reachable as attributes (so `dir(gm)` and tab completion show them)."""
    return sorted({*__all__, *_SUBMODULES, *_LAZY_FUNCTIONS})

__all__ = [
    "ACTUATORS", "DISTAL_SEGMENTS", "FINGER_JOINTS", "FINGER_SEGMENTS", "FINGERS", "FINGERTIP_SITES",
    "HAND_JOINTS", "HandModel", "SHADOW_HAND", "JOINT_RANGES", "PAPER_OBJECTS", "SEGMENTS", "SOM", "UKR", "LinearManifold", "Experience",
    "GraspObject",
    "PostureDatabase", "PostureSet", "SOMSchedule", "DATASET_PRESETS", "GeneratorParams", "Scene", "StartingPosture", "TactileReading",
    "TactileSensor", "ControllerParams", "TargetRecall", "BlendRecall", "ApproachRecall",
    "PalmSteering", "FlangeLimits", "GraspController", "Regrasp", "compare", "headroom", "holm", "mcnemar",
    "wilson_interval", "EvaluationResult", "Noise", "Recording", "TrialSetup", "record_trial", "clip_posture",
    "epsilon_l1", "BackendUnavailable", "GraspManifoldError", "InvalidInput", "NotFittedError", "OutputInUse", "RenderingUnavailable",
    "WorkersLost", "QualityError", "SimulationError", "evaluate", "grid_preset", "reachable", "why_unreachable", "resume_learning", "smoothness", "closed_posture", "dict_to_posture", "facing_pose", "finger_limits",
    "generate_postures", "verify_postures", "GenerationError", "get_object", "starting_postures", "load_hand", "make_object", "open_posture", "pcp_mask", "pcp_masks", "posture_to_ctrl",
    "posture_to_dict", "show_progress", "validate_posture", "within_limits", "__version__",
]
