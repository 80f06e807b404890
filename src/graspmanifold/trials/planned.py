"""The benchmark of planned grasps: every trial has a plan, and the object is not where the plan assumed it.

A plan is a verified grasp of the object (a palm pose in the object's frame and a posture, from the generator,
verified under the default protocol), with the pregrasp and squeeze it was verified with (`dexgraspbench.
open_loop_grasps`). A trial puts the hand in the plan's pregrasp, its palm where the plan says for the *nominal* object
pose, and the object lies displaced by a stated error (`displacements`: 0 cm once, then 1, 2, 3, 5 cm in 8 directions
of the palm's plane, each turned about the palm normal by a yaw drawn within +-30 degrees scaled as the level is to
the largest). Where the pregrasp would start inside the displaced object (`grid.PLANNED_START_DEPTH`), the trial
starts from the open hand at the grasp's palm pose (`open_start`); where that too is inside, no arm runs
(`PlanTrials.start` says which): a geometric rule fixed before any trial, the same for every arm. Every arm's
support fades before the release (`PLANNED_PROTOCOL`).

The arms (`ARMS`), all on the same start state, the same spring support and release, the same hold test; a fault
is a failure of its arm and is reported by arm:

- `open-loop`: the plan executed open loop (`open_loop.OpenLoop`: from the pregrasp to the grasp and the squeeze
  it was verified with, in the replay's targets);
- `heuristic`: the plain closing heuristic (no experience);
- `paper`: the paper's controller with the object's experience;
- `blend-recall`: the blend with a perfect recall (its experience is the plan's own posture);
- `blend`: the blend with the object's experience;
- `approach-recall`, `approach`, `approach-scrambled`: the paper's reading executed as a verified grasp is
  (`controller.APPROACH`: to the recall, on along the way there, pressing by the recalled grasp's verified squeeze)
  with a perfect recall (the plan's posture and squeeze), the object's experience, or the null experience (the
  object's postures with each joint column permuted: `manifold.experience.scrambled`);
- `approach-recall-fixed`: the perfect recall without the plan's squeeze, pressing a fixed 0.3 rad along the way
  (the approach execution before issue 84);
- `approach-bounded-recall`, `approach-bounded`: the approach with its total grip force bounded from the segment
  forces (`controller.BOUNDED_APPROACH`), with a perfect recall or the object's experience;
- the palm family (`PALM_ARMS`, issue 66), the hand on an arm's flange in every one of them: `flange-open-loop`
  (and `-x2`, two attempts), `oracle-correction` (the palm moved by the true displacement first, then the open loop),
  `oracle-translation` (by its translation alone), `oracle-fingers` (the correction, then the approach execution),
  `fingers-only`, `palm-touch`, `palm-experience` and the last three with two attempts (`-x2`).

No controller reads the displacement: it senses joints and touch only (the open loop senses nothing); the oracle
arms, ceilings, are the only ones whose trials read it, and say so in their names.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, replace

import numpy as np

from ..base.errors import InvalidInput
from ..base.poses import invert
from ..base.workers import parallel_map
from ..control.controller import APPROACH, CONTROLLERS, PALM_EXPERIENCE, PALM_TOUCH, ControllerParams
from ..control.regrasp import Regrasp
from ..judging.protocols import HOLD_TEST_FADED
from ..judging.plans import OpenLoopGrasp
from .open_loop import OpenLoop
from ..manifold.experience import Experience, PostureDatabase
from ..sim.flange import FlangeLimits
from ..sim.objects import GraspObject, get_object
from ..sim.posture import open_posture
from .grid import planned_start_clear
from .episode import run_trials
from .record import Trial
from .setup import TrialSetup

#: m, the levels of displacement in the palm's plane
LEVELS: tuple[float, ...] = (0.0, 0.01, 0.02, 0.03, 0.05)
#: directions of the palm's plane each level above 0 is taken in (evenly spaced)
DIRECTIONS = 8
#: rad, the largest yaw about the palm normal (at the largest level; a level's bound scales with it)
MAX_YAW = math.radians(30.0)
#: how every arm is judged: our hold test after a support that fades over 0.3 s (`protocols.HOLD_TEST_FADED`): with the
#: support let go at once, the blend lost grasps whose squeeze had pushed the object 6-16 mm against the spring
PLANNED_PROTOCOL = HOLD_TEST_FADED


@dataclass(frozen=True)
class Arm:
    """One arm of the planned-grasp benchmark.

    Attributes:
        name: its name in results and reports.
        controller: 'open-loop', or one of ours by name (`controller.CONTROLLERS`), or 'heuristic' (ours without
            experience).
        experience: what it recalls from: 'none', 'plan' (the plan's own posture and squeeze: a perfect recall),
            'plan-posture' (the plan's posture alone: the press is the controller's fixed one), 'object' (the
            object's experience) or 'scrambled' (the null experience).
        params: the controller's parameters where they are not the named controller's (None: those).
        palm: the hand hangs on an arm's flange (`TrialSetup.palm`, the default `FlangeLimits`); False: the palm
            stays where the trial put it unless the controller shifts it.
        oracle: the flange first moves the palm by the true displacement (`TrialSetup.oracle`: a ceiling; True the
            full correction, 'translation' without the yaw).
        attempts: grasp attempts (`regrasp.Regrasp`; 2: the first attempt's way again after a failed lift probe).
    """

    name: str
    controller: str
    experience: str
    params: ControllerParams | None = None
    palm: bool = False
    oracle: bool | str = False
    attempts: int = 1


#: every arm by name: the issue 65 family (`EXECUTION_ARMS`) and the palm family (`PALM_ARMS`)
ARMS: dict[str, Arm] = {arm.name: arm for arm in (
    Arm("open-loop", "open-loop", "none"),
    Arm("heuristic", "heuristic", "none"),
    Arm("paper", "paper", "object"),
    Arm("blend-recall", "blend", "plan"),
    Arm("blend", "blend", "object"),
    Arm("approach-recall", "approach", "plan"),
    Arm("approach-recall-fixed", "approach", "plan-posture"),
    Arm("approach", "approach", "object"),
    Arm("approach-scrambled", "approach", "scrambled"),
    Arm("approach-bounded-recall", "approach-bounded", "plan"),
    Arm("approach-bounded", "approach-bounded", "object"),
    Arm("flange-open-loop", "open-loop", "none", palm=True),
    Arm("flange-open-loop-x2", "open-loop", "none", palm=True, attempts=2),
    Arm("oracle-correction", "open-loop", "none", palm=True, oracle=True),
    Arm("oracle-translation", "open-loop", "none", palm=True, oracle="translation"),
    Arm("oracle-fingers", "approach", "object", palm=True, oracle=True),
    Arm("fingers-only", "approach", "object", palm=True),
    Arm("palm-touch", "approach", "object", replace(APPROACH, palm=PALM_TOUCH), palm=True),
    Arm("palm-experience", "approach", "object", replace(APPROACH, palm=PALM_EXPERIENCE), palm=True),
    Arm("fingers-only-x2", "approach", "object", palm=True, attempts=2),
    Arm("palm-touch-x2", "approach", "object", replace(APPROACH, palm=PALM_TOUCH), palm=True, attempts=2),
    Arm("palm-experience-x2", "approach", "object", replace(APPROACH, palm=PALM_EXPERIENCE), palm=True, attempts=2),
)}
#: the arms of issue 65's study (`studies.planned_grasps`): the execution of a plan, the palm where the trial put it
EXECUTION_ARMS: tuple[str, ...] = tuple(name for name, arm in ARMS.items() if not arm.palm)
#: the arms of issue 66's study (`studies.palm`), every one on the arm's flange (one physics for all): the plan
#: open loop, once and with two attempts (the plan again from its pregrasp after a failed lift probe: what the
#: two-attempt arms are compared with); the oracles, ceilings and the only arms that read the displacement
#: (`TrialSetup.oracle`): the palm moved by the true displacement before the open loop (`oracle-correction`), by its
#: translation alone (`oracle-translation`), or before the approach execution with the object's experience
#: (`oracle-fingers`; the ceiling is each trial's best of the first and the last); the approach execution with the
#: object's experience, its palm still (fingers only), re-centred from touch alone (`PALM_TOUCH`) or steered by the
#: recalled object place (`PALM_EXPERIENCE`); the last three again with two attempts (`regrasp.Regrasp(attempts=2)`:
#: the first attempt's way again after a failed lift probe, the palm staying where it went)
PALM_ARMS: tuple[str, ...] = tuple(name for name, arm in ARMS.items() if arm.palm)
#: the kinds of experience an arm names besides 'none', 'plan' and 'plan-posture'
EXPERIENCES = ("object", "scrambled")


def displacements(levels: Sequence[float] = LEVELS, directions: int = DIRECTIONS, seed: int = 0,
                  plan: int = 0) -> np.ndarray:
    """The object's displacements of one plan's trials (the module doc): 0 once, then each level in `directions`
    evenly spaced directions of the palm's plane, each with a yaw drawn uniformly within +-`MAX_YAW` x level /
    the largest level.

    Args:
        levels: m, the levels, increasing (0 first, where there is one).
        directions: directions per level above 0.
        seed: with `plan`, seeds the yaws ([seed, plan]).
        plan: the plan's index.

    Returns:
        (k, 4): x, z, gap (0) in m, yaw in rad (`grid.displaced_palm_pose`).
    """
    levels = tuple(float(v) for v in levels)
    if not levels or any(not math.isfinite(v) or v < 0 for v in levels) or list(levels) != sorted(levels):
        raise InvalidInput(f"levels must be increasing distances >= 0 (m), got {levels}")
    if isinstance(directions, bool) or not isinstance(directions, int) or directions < 1:
        raise InvalidInput(f"directions must be a positive integer, got {directions!r}")
    rng = np.random.default_rng([seed, plan])
    rows = []
    for level in levels:
        if level == 0.0:
            rows.append([0.0, 0.0, 0.0, 0.0])
            continue
        angles = 2 * math.pi * np.arange(directions) / directions
        yaws = rng.uniform(-1.0, 1.0, directions) * MAX_YAW * level / max(levels)
        rows += [[level * math.cos(a), level * math.sin(a), 0.0, yaw] for a, yaw in zip(angles, yaws)]
    return np.array(rows)


def level_of(displacement: np.ndarray) -> np.ndarray:
    """m, the level of each displacement (n, 4): its length in the palm's plane, rounded to 0.1 mm."""
    return np.round(np.hypot(displacement[..., 0], displacement[..., 1]), 4)


def arm_params(arm: Arm) -> ControllerParams | None:
    """The controller parameters an arm runs with (None: the open loop, which has none).

    Args:
        arm: the arm.

    Returns:
        Its own `params`, else the named controller's (`controller.CONTROLLERS`; ours without experience for
        'heuristic').
    """
    if arm.controller == "open-loop":
        return None
    return arm.params or (ControllerParams() if arm.controller == "heuristic" else CONTROLLERS[arm.controller])


def arm_setup(arm: Arm, obj: GraspObject, plan: OpenLoopGrasp, experiences: Mapping[str, Experience | None],
              method: str = "") -> TrialSetup:
    """The trial set-up of one arm on one plan.

    Args:
        arm: the arm.
        obj: the object.
        plan: the plan.
        experiences: 'object' and 'scrambled' experiences (an arm that names one needs it).
        method: the result's label (empty: the arm's name).

    Returns:
        The `TrialSetup`.
    """
    label = method or arm.name
    palm = FlangeLimits() if arm.palm else None
    if arm.controller == "open-loop":
        return TrialSetup(object=obj, plan=plan, controller=OpenLoop(plan), method=label, protocol=PLANNED_PROTOCOL,
                          palm=palm, oracle=arm.oracle, regrasp=Regrasp(attempts=arm.attempts))
    if arm.experience == "plan":
        experience: Experience | None = PostureDatabase(plan.postures[1][None], squeezes=plan.squeeze_offset[None])
    elif arm.experience == "plan-posture":
        experience = PostureDatabase(plan.postures[1][None])
    elif arm.experience == "none":
        experience = None
    elif arm.experience in experiences and experiences[arm.experience] is not None:
        experience = experiences[arm.experience]
    else:
        raise InvalidInput(f"arm {arm.name!r} recalls from the {arm.experience!r} experience: give it "
                           f"(experiences has {sorted(experiences)})")
    return TrialSetup(object=obj, experience=experience, params=arm_params(arm) or ControllerParams(), plan=plan, method=label,
                      protocol=PLANNED_PROTOCOL, palm=palm, oracle=arm.oracle, regrasp=Regrasp(attempts=arm.attempts))


#: how a planned trial starts (`PlanTrials.start`): not at all, in the plan's pregrasp, or in the open hand
STARTS: tuple[str, ...] = ("none", "pregrasp", "open")


def open_start(plan: OpenLoopGrasp) -> OpenLoopGrasp:
    """The plan started from the open hand instead of its pregrasp (the palm at the grasp's pose): where the
    pregrasp would start inside the displaced object.

    Args:
        plan: the plan.

    Returns:
        The plan whose first stage is the hand's open posture at the grasp's palm pose.
    """
    return OpenLoopGrasp(plan.poses[[1, 1, 2]], np.vstack([open_posture(), plan.postures[1:]]))


@dataclass(frozen=True)
class PlanTrials:
    """One plan's trials, every arm on the same displacements.

    Attributes:
        displacements: (k, 4) the object's displacements (`displacements`).
        start: (k,) index into `STARTS`: how each displacement's trials started (0: none ran, the hand would start
            inside the object).
        trials: {arm: one `Trial` per started displacement, in order}.
        places: (k, 3) m, where the displaced object lies in the palm frame of each trial's start (NaN where none
            ran): the truth the controllers' `Trial.object_estimate` is measured against.
    """

    displacements: np.ndarray
    start: np.ndarray
    trials: dict[str, list[Trial]]
    places: np.ndarray

    @property
    def started(self) -> np.ndarray:
        """(k,) bool: trials ran there."""
        return self.start > 0

    def held(self, arm: str) -> np.ndarray:
        """(k,) bool: held without a fault (False where no trial started)."""
        out = np.zeros(len(self.displacements), dtype=bool)
        out[self.started] = [t.valid and t.hold for t in self.trials[arm]]
        return out

    def faulted(self, arm: str) -> np.ndarray:
        """(k,) bool: the physics failed."""
        out = np.zeros(len(self.displacements), dtype=bool)
        out[self.started] = [not t.valid for t in self.trials[arm]]
        return out


def run_plan(plan: OpenLoopGrasp, obj: GraspObject, arms: Sequence[str], experiences: Mapping[str, Experience | None],
             moved: np.ndarray, seed: int = 0) -> PlanTrials:
    """Every arm's trials of one plan at these displacements: from the plan's pregrasp where the hand in it is
    clear of the displaced object (`grid.PLANNED_START_DEPTH`, or no deeper in it than at the nominal pose), else
    from the open hand at the grasp's palm pose where that is clear (`open_start`), else none.

    Args:
        plan: the plan.
        obj: the object.
        arms: names in `ARMS`.
        experiences: the 'object' and 'scrambled' experiences the arms need.
        moved: (k, 4) the displacements.
        seed: the trials' seed (trial i draws from [seed, i]; planned trials have no noise).

    Returns:
        The `PlanTrials`.
    """
    variants = (plan, open_start(plan))
    start = np.zeros(len(moved), dtype=int)
    for kind, variant in enumerate(variants, start=1):
        left = np.flatnonzero(start == 0)
        clear, _, _ = planned_start_clear(obj, variant.poses[0], variant.postures[0], moved[left])
        start[left[clear]] = kind
    trials: dict[str, list[Trial]] = {}
    for name in arms:
        ran: dict[int, Trial] = {}
        for kind, variant in enumerate(variants, start=1):
            rows = np.flatnonzero(start == kind)
            if len(rows):
                setup = arm_setup(ARMS[name], obj, variant, experiences)
                done = run_trials(setup, moved[rows], [np.random.default_rng([seed, int(i)]) for i in rows])
                ran.update(zip(rows.tolist(), done))
        trials[name] = [ran[i] for i in sorted(ran)]
    places = np.full((len(moved), 3), np.nan)
    for kind, variant in enumerate(variants, start=1):
        rows = start == kind
        x, z, gap = moved[rows, 0], moved[rows, 1], moved[rows, 2]  # `grid.displaced_palm_pose`
        places[rows] = invert(variant.poses[0, :3], variant.poses[0, 3:])[0] + np.column_stack([x, -gap, z])
    return PlanTrials(moved, start, trials, places)


def verify_plans(obj: str | GraspObject, plans: Sequence[OpenLoopGrasp], arm: str = "open-loop", seed: int = 0,
                 workers: int = 1, executor: Executor | None = None) -> np.ndarray:
    """The plans verified under the benchmark's own protocol and physics: each executed open loop at its own palm
    pose (0 cm) from the trial's start, on the spring support, released as `PLANNED_PROTOCOL` releases it and judged
    by its hold test (`run_plan` with an open-loop arm): one meaning of verified, so that the open loop at 0 cm
    holds every plan this passes (the generator verifies on the free, weightless object).

    Args:
        obj: the object, or its name.
        plans: its plans.
        arm: the open-loop arm whose physics verifies ('open-loop', or 'flange-open-loop' for the palm's family).
        seed: the trials' seed (`run_plan`).
        workers: worker processes (a plan a task); `executor`: run them there instead.

    Returns:
        (len(plans),) bool: held at 0 cm.
    """
    if arm not in ARMS or ARMS[arm].controller != "open-loop" or ARMS[arm].oracle or ARMS[arm].attempts != 1:
        raise InvalidInput(f"verify_plans verifies with an open-loop arm of one attempt without the oracle, got "
                           f"{arm!r}")
    held = run_planned(obj, plans, (arm,), {}, (0.0,), seed=seed, workers=workers, executor=executor)
    return np.array([bool(result.held(arm)[0]) for result in held], dtype=bool)


def _plan_task(task: tuple[int, OpenLoopGrasp, np.ndarray], obj: GraspObject, arms: tuple[str, ...],
               experiences: Mapping[str, Experience | None], seed: int) -> PlanTrials:
    _, plan, moved = task
    return run_plan(plan, obj, arms, experiences, moved, seed)


def run_planned(obj: str | GraspObject, plans: Sequence[OpenLoopGrasp], arms: Sequence[str] = tuple(ARMS),
                experiences: Mapping[str, Experience | None] | None = None, levels: Sequence[float] = LEVELS, *,
                seed: int = 0, workers: int = 1, executor: Executor | None = None) -> list[PlanTrials]:
    """The planned-grasp benchmark of one object: every plan, every arm, every displacement (the module doc).

    Args:
        obj: the object, or its name.
        plans: its plans (`plans.open_loop_grasps` of verified postures).
        arms: names in `ARMS`.
        experiences: {'object': ..., 'scrambled': ...} for the arms that name them.
        levels: m, the displacements' levels.
        seed: seeds the yaws (plan i's: [seed, i]) and the trials.
        workers: worker processes (a plan a task); `executor`: run them there instead.

    Returns:
        One `PlanTrials` per plan, in order.
    """
    obj = get_object(obj)
    unknown = [a for a in arms if a not in ARMS]
    if unknown:
        raise InvalidInput(f"unknown arm(s) {unknown}; expected some of {tuple(ARMS)}")
    if not plans or not all(isinstance(p, OpenLoopGrasp) for p in plans):
        raise InvalidInput("plans must be a non-empty sequence of OpenLoopGrasp (plans.open_loop_grasps)")
    experiences = dict(experiences or {})
    for name in arms:  # refused before any trial
        arm_setup(ARMS[name], obj, plans[0], experiences)
    tasks = [(i, plan, displacements(levels, seed=seed, plan=i)) for i, plan in enumerate(plans)]
    run = functools.partial(_plan_task, obj=obj, arms=tuple(arms), experiences=experiences, seed=seed)
    return parallel_map(run, tasks, workers, executor=executor)
