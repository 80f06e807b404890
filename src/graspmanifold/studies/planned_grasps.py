"""The planned-grasp study: a grasp the controller knows, executed where the object is not quite where it was
planned, by every arm of `trials.planned`.

    python scripts/study_planned_grasps.py [--quick] [--workers 2] [--seeds 2 3 4] [--plans 34] [--displaced 3]
                                           [--draw 0] [--out study-planned-grasps] [--doc docs/studies/planned_grasps.md]

For each of the experience benchmark's seven objects (`trials.benchmark.OBJECTS`) and each seed, `--plans` grasps
verified by the generator (`generate_postures(obj, n, seed, params=GeneratorParams(designs="grasp_types"))`, on the
free, weightless object) are the object's experience: a 10 x 10 SOM trained on them carrying where each grasp had the
object and how hard it pressed (`SOM.carry_places`, `carry_squeezes`), the null experience the same SOM trained on
them scrambled (`manifold.experience.scrambled`). The plans are those the study verifies again under its own
protocol and physics (`trials.planned.verify_plans`: the family's open loop at the plan's own palm pose, on the
spring support, the release fading): one meaning of verified. Every plan is run by every arm at 0 cm (the ceiling);
`--displaced` plans of each object and seed, drawn at random among them (`drawn_plans`, seeded by `--draw`, the seed
and the object, and recorded), also at 1, 2, 3 and 5 cm in 8 directions (`trials.planned.displacements`). Every arm
is judged by `trials.planned.PLANNED_PROTOCOL` (the support fading before the release). The approach execution
(`controller.APPROACH`) was chosen on a probe of generator seed 0 (12 plans of each object), after traces of seed 1's
first 10 plans of the marble, pen and disc; the fading release and the bounded grip force
(`controller.BOUNDED_APPROACH`) on seed 0. The study runs seeds 2, 3 and 4, so all are scored on plans they were
neither chosen nor traced on.

Reported: the hold rate of every arm by level (a fault is a failure, and faults are counted by arm), pooled, per
object and per design, with Wilson intervals; McNemar on the same trials with Holm over the family, and beside it
each difference's 95 % interval from a cluster bootstrap over plans (`trials.stats.bootstrap_difference`: trials of
one plan are not independent); the family's first question is its primary comparison. Writes `--out/study.json`,
the report `--doc` and its figure beside it.
"""

from __future__ import annotations

import argparse
import functools
import re
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base.checkpoints import result_key
from ..base.errors import InvalidInput
from ..base.io import load_npz, markdown_table, save_npz
from ..base.validation import check_choice, check_int
from ..control.controller import ControllerParams
from ..judging.judge import JUDGING
from ..judging.plans import OpenLoopGrasp, open_loop_grasps
from ..manifold.experience import Experience, object_places, scrambled
from ..manifold.postureset import PostureSet
from ..manifold.som import SOM
from ..sim.hand import SEGMENTS
from ..synthesis.generator import GeneratorParams, generate_postures
from ..trials.benchmark import OBJECTS
from ..trials.planned import (
    ARMS,
    EXECUTION_ARMS,
    LEVELS,
    PLANNED_PROTOCOL,
    STARTS,
    PlanTrials,
    arm_params,
    displacements,
    level_of,
    run_plan,
)
from ..trials.stats import bootstrap_difference, headroom_share, mcnemar, rate_text
from ..trials.record import Trial
from .runner import StudyRun, comparison_table, holm_family, publish, rate_curve, run_study, save_figure, study_config

#: the questions of issues 65 and 84, each a pair of arms (first against second) at some levels (m); the first is
#: the study's primary comparison, named before it ran
QUESTIONS: tuple[tuple[str, str, str, tuple[float, ...]], ...] = (
    ("perfect recall, approach execution with the recalled squeeze, against the open loop at 0 cm",
     "approach-recall", "open-loop", (0.0,)),
    ("perfect recall: the recalled squeeze against the fixed press at 0 cm", "approach-recall",
     "approach-recall-fixed", (0.0,)),
    ("perfect recall, old execution, against the open loop at 0 cm", "blend-recall", "open-loop", (0.0,)),
    ("perfect recall: approach execution against the old execution at 0 cm", "approach-recall", "blend-recall",
     (0.0,)),
    ("experience (approach) against the open loop at 1-2 cm", "approach", "open-loop", (0.01, 0.02)),
    ("experience against the null experience (approach) at 1-3 cm", "approach", "approach-scrambled",
     (0.01, 0.02, 0.03)),
    ("experience (approach) against the plain heuristic at 1-3 cm", "approach", "heuristic", (0.01, 0.02, 0.03)),
    ("experience: the approach execution against the blend at 1-3 cm", "approach", "blend", (0.01, 0.02, 0.03)),
    ("perfect recall: the bounded grip force against the approach at 0 cm", "approach-bounded-recall",
     "approach-recall", (0.0,)),
    ("experience: the bounded grip force against the approach at 1-3 cm", "approach-bounded", "approach",
     (0.01, 0.02, 0.03)),
)


def _squeeze_share(info: dict) -> str:
    """The recalled squeeze's share of the fixed press's headroom to the open loop, in words ('' where not known)."""
    share = info.get("headroom", {}).get("approach-recall")
    if share is None or not np.isfinite(share["value"]):
        return ""
    return (f": the recalled squeeze takes {100 * share['value']:.0f} % [{100 * share['low']:.0f}, "
            f"{100 * share['high']:.0f}] of the fixed press's headroom to the open loop")


def _execution_verdict(info: dict) -> str:
    ceiling = info["ceiling"]
    recall, open_loop, som = ceiling["approach-recall"], ceiling["open-loop"], ceiling["approach"]
    primary = info["comparisons"][0]
    gap = primary["bootstrap"]
    return (f"Perfect recall with the approach execution pressing the recalled squeeze holds {rate_text(*recall)} of "
            f"{recall[1]} plans at 0 cm, the open loop {rate_text(*open_loop)}: {100 * gap['value']:+.1f} pts, "
            f"{100 * gap['low']:+.1f} to {100 * gap['high']:+.1f} over plans (target >= -3 pts: "
            f"{'met' if gap['value'] >= -0.03 else 'not met'}); with the fixed press "
            f"{rate_text(*ceiling['approach-recall-fixed'])}{_squeeze_share(info)}. The map-based approach (the object's SOM) holds "
            f"{rate_text(*som)} at 0 cm (target >= 80 %: {'met' if som[0] >= 0.8 * max(som[1], 1) else 'not met'}); "
            f"the old execution {rate_text(*ceiling['blend-recall'])}; with the grip force bounded "
            f"{rate_text(*ceiling['approach-bounded-recall'])}.")


@dataclass(frozen=True)
class Headroom:
    """What a family's headroom share measures: (arm - floor) / (ceiling - floor) on the same trials, with the
    cluster bootstrap over plans (`trials.stats.headroom_share`).

    Attributes:
        floor: the arm the share starts from.
        ceiling: the arms whose per-trial best is the ceiling.
        levels: m, the levels whose trials count (0 cm: every plan; above it, the displaced plans').
        arms: the arms whose share is reported (empty: every arm but the floor and the ceiling's).
    """

    floor: str
    ceiling: tuple[str, ...]
    levels: tuple[float, ...]
    arms: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for arm in (self.floor, *self.ceiling, *self.arms):
            check_choice(arm, tuple(ARMS), "Headroom arm")
        if not self.ceiling or not self.levels or any(level not in LEVELS for level in self.levels):
            raise InvalidInput(f"a Headroom needs a ceiling and levels among {LEVELS} m, got ceiling {self.ceiling} "
                               f"and levels {self.levels}")

    def describe(self) -> str:
        """The share in words, for the report.

        Returns:
            E.g. '(arm - open-loop) / (ceiling - open-loop) at 2-5 cm (the displaced plans), the ceiling ...'.
        """
        at = "0 cm (every plan)" if self.levels == (0.0,) else \
            f"{100 * min(self.levels):.0f}-{100 * max(self.levels):.0f} cm (the displaced plans)"
        ceiling = f"a trial's best of {' and '.join(self.ceiling)}" if len(self.ceiling) > 1 else self.ceiling[0]
        return f"(arm - {self.floor}) / (ceiling - {self.floor}) at {at}, the ceiling {ceiling}"


@dataclass(frozen=True)
class Family:
    """One study of the planned-grasp benchmark: its arms, its questions and how its verdict reads.

    Attributes:
        name: its name (`FAMILIES`, the script's `--family`).
        title: the report's title.
        arms: names in `trials.planned.ARMS`.
        questions: (label, arm, against arm, levels in m): the family of paired comparisons (Holm over them).
        every_plan_at_zero: every plan runs at 0 cm (the ceiling), not only the displaced ones.
        verdict: the report's verdict from its numbers (`summarise`'s dict).
        issue: the issue whose questions these are.
        default_out: the study folder by default (`-quick` added for a smoke run).
        default_doc: the report by default.
        script: the script that runs it.
        floor: the open-loop arm that verifies the plans under the study's own protocol and physics
            (`trials.planned.verify_plans`) and is the noise floor's arm.
        headroom: what the family's headroom share measures (`headroom_shares`), or None.
        zero_only: arms run at 0 cm only (not on the displaced plans' 1-5 cm trials).
    """

    name: str
    title: str
    arms: tuple[str, ...]
    questions: tuple[tuple[str, str, str, tuple[float, ...]], ...]
    every_plan_at_zero: bool
    verdict: Callable[[dict], str] = field(repr=False)
    issue: str
    default_out: str
    default_doc: str
    script: str
    floor: str = "open-loop"
    headroom: Headroom | None = None
    zero_only: tuple[str, ...] = ()


EXECUTION = Family("execution", "Planned grasps: execution at the verified grasp's level, against a fair open loop",
                   EXECUTION_ARMS, QUESTIONS, True, _execution_verdict, "issues 65 and 84", "study-planned-grasps",
                   "docs/studies/planned_grasps.md", "scripts/study_planned_grasps.py", zero_only=("approach-recall-fixed",),
                   headroom=Headroom("approach-recall-fixed", ("open-loop",), (0.0,), ("approach-recall",)))
#: the families by name; `studies.palm` adds the palm's
FAMILIES: dict[str, Family] = {EXECUTION.name: EXECUTION}
#: the arms' colours in the figure
_STYLE = {"open-loop": "k", "heuristic": "0.6", "paper": "tab:purple", "blend-recall": "tab:orange",
          "blend": "tab:red", "approach-recall": "tab:cyan", "approach": "tab:blue", "approach-scrambled": "tab:green",
          "approach-bounded-recall": "tab:olive", "approach-bounded": "tab:brown", "flange-open-loop": "k",
          "oracle-correction": "0.5", "fingers-only": "tab:blue", "palm-touch": "tab:orange",
          "palm-experience": "tab:red", "fingers-only-x2": "tab:cyan", "palm-touch-x2": "gold",
          "palm-experience-x2": "tab:pink"}


#: the most plans per object and seed a study asks the generator for (the default 34 takes about 45 minutes; a
#: thousand would take a day, and 1e9 was taken without a word)
MAX_PLANS = 1000


@dataclass(frozen=True)
class PlannedStudyConfig:
    """How the study runs.

    Attributes:
        quick: a smoke run (two objects, one seed, 6 plans, 2 displaced).
        workers: worker processes.
        seeds: each the generator's, the SOMs' and the trials' seed: the study runs once per seed.
        plans: grasps per object and seed the generator verifies (the experience); those the study's own
            verification passes (`trials.planned.verify_plans`) are the plans, each run at 0 cm where the family
            runs every plan there.
        displaced: plans per object and seed also run displaced, drawn at random among the verified ones
            (`drawn_plans`).
        family: the study's arms and questions (`FAMILIES`).
        draw: seeds the draw of the displaced plans (with the seed and the object).
    """

    quick: bool = False
    workers: int = 2
    seeds: tuple[int, ...] = (2, 3, 4)
    plans: int = 34
    displaced: int = 3
    family: str = "execution"
    draw: int = 0

    def __post_init__(self) -> None:
        check_choice(self.family, tuple(FAMILIES), "family")
        if not self.seeds or len(set(self.seeds)) != len(self.seeds) or any(
                isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in self.seeds):
            raise InvalidInput(f"seeds must be distinct integers >= 0, got {self.seeds!r}")
        for name in ("plans", "displaced"):
            check_int(getattr(self, name), name, low=1, high=MAX_PLANS)
        check_int(self.draw, "draw", low=0)

    @property
    def run_seeds(self) -> tuple[int, ...]:
        """The seeds run (a quick run: the first)."""
        return self.seeds[:1] if self.quick else self.seeds

    @property
    def objects(self) -> tuple[str, ...]:
        """The benchmark objects run (a quick run: the cylinder and the cube)."""
        return ("cylinder", "cube") if self.quick else tuple(OBJECTS)

    @property
    def sizes(self) -> tuple[int, int]:
        """(plans, displaced) per object."""
        return (6, 2) if self.quick else (self.plans, min(self.displaced, self.plans))


#: added to a seed for the noise floor's second draw of the displacements' yaws
NOISE_FLOOR_SEED = 1000


def _plan_task(task: tuple, plans: dict[tuple[str, int], list[OpenLoopGrasp]],
               experiences: dict[tuple[str, int], dict[str, Experience]], arms: tuple[str, ...],
               zero_only: tuple[str, ...] = (), redraw: int = 0) -> PlanTrials:
    name, seed, index, levels, _ = task
    moved = displacements(tuple(float(v) for v in levels.split(",")), seed=seed + redraw, plan=index)
    if levels != "0.0":  # the displaced levels: the arms of 0 cm only stay out
        arms = tuple(arm for arm in arms if arm not in zero_only)
    return run_plan(plans[name, seed][index], OBJECTS[name].object, arms, experiences[name, seed], moved, seed)


def drawn_plans(verified: np.ndarray, count: int, draw: int, seed: int, name: str) -> np.ndarray:
    """The plans of one object and seed run displaced: drawn at random among the verified ones (the generator emits
    them design by design, so the first few would be one or two designs' only).

    Args:
        verified: (n,) bool, the plans the study's verification passed.
        count: how many to draw (all the verified ones where there are fewer).
        draw: the draw's seed (`PlannedStudyConfig.draw`).
        seed: the study seed.
        name: the object (a benchmark object's name: its index in `OBJECTS` seeds the draw too).

    Returns:
        The drawn plans' indices, increasing.
    """
    check_int(count, "count", low=0)
    rng = np.random.default_rng([draw, seed, list(OBJECTS).index(name)])
    candidates = np.flatnonzero(verified)
    return np.sort(rng.choice(candidates, min(count, len(candidates)), replace=False)).astype(int)


def _per_start(result: PlanTrials, arm: str, value: Callable[[Trial], object], empty: object) -> np.ndarray:
    """(k, ...) one value of each of an arm's trials, `empty` where no trial started."""
    rows = [value(t) for t in result.trials[arm]]
    out = np.array([empty] * len(result.displacements))
    if rows:
        out[result.started] = rows
    return out


def _write(result: PlanTrials, path: Path, meta: dict) -> None:
    arrays = {"displacements": result.displacements, "start": result.start}
    for arm in result.trials:
        arrays[f"held_{arm}"] = result.held(arm)
        arrays[f"faulted_{arm}"] = result.faulted(arm)
        arrays[f"epsilon_{arm}"] = _per_start(result, arm, lambda t: t.epsilon, np.nan)
        arrays[f"seconds_{arm}"] = _per_start(result, arm, lambda t: t.time_to_grasp, np.nan)
        arrays[f"touching_{arm}"] = _per_start(result, arm, lambda t: t.touching, np.zeros(len(SEGMENTS), bool))
        arrays[f"estimate_{arm}"] = _per_start(result, arm, lambda t: t.object_estimate, np.full(3, np.nan))
    arrays["places"] = result.places
    save_npz(path, "planned_trials", arrays, {**meta, "arms": list(result.trials),
                                             "faults": {arm: [t.fault for t in trials if t.fault]
                                                        for arm, trials in result.trials.items()}})


@dataclass(frozen=True)
class _Outcomes:
    """What the report reads of one plan's trials (a `PlanTrials` as kept on disk)."""

    levels: np.ndarray
    start: np.ndarray
    held: dict[str, np.ndarray]
    faulted: dict[str, np.ndarray]
    faults: dict[str, list[str]]
    epsilon: dict[str, np.ndarray]  # (k,) each trial's force-closure epsilon (NaN: none started)
    seconds: dict[str, np.ndarray]  # (k,) s each trial's controller took to call its grasp done
    touching: dict[str, np.ndarray]  # (k, len(SEGMENTS)) bool, the segments touching the object when it was
    estimate: dict[str, np.ndarray]  # (k, 3) m, where each trial's touch first placed the object (NaN: nowhere)
    places: np.ndarray  # (k, 3) m, where the object lay in the palm frame of each trial's start (NaN: none ran)

    @property
    def started(self) -> np.ndarray:
        """(k,) bool: trials ran there."""
        return self.start > 0


def _read(path: Path) -> tuple[_Outcomes, dict]:
    arrays, meta = load_npz(path, "planned_trials", {"displacements": (None, 4), "start": (None,)})

    def by_arm(kind: str, dtype: type) -> dict[str, np.ndarray]:
        return {arm: arrays[f"{kind}_{arm}"].astype(dtype) for arm in meta["arms"]}

    outcomes = _Outcomes(levels=level_of(arrays["displacements"]), start=arrays["start"].astype(int),
                         held=by_arm("held", bool), faulted=by_arm("faulted", bool), faults=meta["faults"],
                         epsilon=by_arm("epsilon", float), seconds=by_arm("seconds", float),
                         touching=by_arm("touching", bool), estimate=by_arm("estimate", float),
                         places=arrays["places"])
    return outcomes, meta


def outcomes_of(result: PlanTrials | _Outcomes) -> _Outcomes:
    """What the report reads of one plan's trials, from the trials or as kept on disk."""
    if isinstance(result, _Outcomes):
        return result
    return _Outcomes(level_of(result.displacements), result.start, {a: result.held(a) for a in result.trials},
                     {a: result.faulted(a) for a in result.trials},
                     {a: [t.fault for t in ts if t.fault] for a, ts in result.trials.items()},
                     {a: _per_start(result, a, lambda t: t.epsilon, np.nan) for a in result.trials},
                     {a: _per_start(result, a, lambda t: t.time_to_grasp, np.nan) for a in result.trials},
                     {a: _per_start(result, a, lambda t: t.touching, np.zeros(len(SEGMENTS), bool))
                      for a in result.trials},
                     {a: _per_start(result, a, lambda t: t.object_estimate, np.full(3, np.nan))
                      for a in result.trials}, result.places)


def run(config: PlannedStudyConfig, study: StudyRun) -> dict:
    """Run the study of the config's family (the module doc) and return what its report shows."""
    family = FAMILIES[config.family]
    n_plans, n_displaced = config.sizes
    plans, digests, designs = {}, {}, {}
    experiences: dict[tuple[str, int], dict[str, Experience]] = {}
    for seed in config.run_seeds:
        for name in config.objects:
            obj = OBJECTS[name].object
            postures = study.postures(f"postures/{name}_{seed}", postures_key(name, n_plans, seed, config.quick),
                                      functools.partial(generate, name, n_plans, seed, study.workers, config.quick))
            plans[name, seed] = open_loop_grasps(postures, obj=obj)
            squeezes = np.array([plan.squeeze_offset for plan in plans[name, seed]])
            som = SOM(10, 10, seed=seed).fit(postures.postures)
            som.carry_places(postures.postures, object_places(postures))  # where each grasp had the object
            som.carry_squeezes(postures.postures, squeezes)  # how hard each pressed when verified
            null_postures = scrambled(postures.postures, seed)
            null = SOM(10, 10, seed=seed).fit(null_postures)
            null.carry_squeezes(null_postures, scrambled(squeezes, seed))  # the same permutation of each joint
            experiences[name, seed] = {"object": som, "scrambled": null}
            digests[name, seed] = result_key({"postures": postures.postures.tolist(),
                                              "poses": postures.hand_poses.tolist(), "arms": list(family.arms)})
            designs[name, seed] = [postures.start_names[k].split(":", 1)[-1] for k in postures.start_ids]
            study.log(f"{name}, seed {seed}: {len(postures)} plans")
    verified = _verify(config, study, plans, digests)
    drawn = {cell: drawn_plans(ok, n_displaced, config.draw, cell[1], cell[0]) for cell, ok in verified.items()}
    zero, displaced = "0.0", ",".join(str(v) for v in LEVELS[1:])
    tasks = [(name, seed, int(i), zero, digests[name, seed])
             for seed in config.run_seeds for name in config.objects
             for i in (np.flatnonzero(verified[name, seed]) if family.every_plan_at_zero else drawn[name, seed])]
    tasks += [(name, seed, int(i), displaced, digests[name, seed])
              for seed in config.run_seeds for name in config.objects for i in drawn[name, seed]]
    compute = functools.partial(_plan_task, plans=plans, experiences=experiences, arms=family.arms,
                                zero_only=family.zero_only)
    kept = study.keep_each("plans", tasks, compute, _read, _write,
                           lambda task, r: f"{task[0]} seed {task[1]} plan {task[2]}: " + ", ".join(
                               f"{a} {int(r.held(a).sum())}" for a in family.arms[:3] if a in r.trials))
    outcomes = {task: outcomes_of(result) for task, result in kept.items()}
    noise = study.keep_each("noise-floor", [task for task in tasks if task[3] == displaced],
                            functools.partial(_plan_task, plans=plans, experiences=experiences, arms=(family.floor,),
                                              redraw=NOISE_FLOOR_SEED), _read, _write)
    selection = {"generated": {f"{name} seed {seed}": len(ok) for (name, seed), ok in verified.items()},
                 "verified": {f"{name} seed {seed}": int(ok.sum()) for (name, seed), ok in verified.items()},
                 "drawn": {f"{name} seed {seed}": chosen.tolist() for (name, seed), chosen in drawn.items()},
                 "designs": {f"{name} seed {seed}": names for (name, seed), names in designs.items()}}
    info = summarise(config, outcomes, selection)
    info["noise_floor"] = noise_floor(outcomes, {task: outcomes_of(result) for task, result in noise.items()},
                                      family.floor)
    return info


def noise_floor(outcomes: dict, rerun: dict, floor: str) -> dict:
    """What chance moves: the floor arm on the displaced plans against itself rerun with the displacements' yaws
    drawn again (`NOISE_FLOOR_SEED`; the same plans, levels and directions, the trials paired in order), the
    difference with its cluster bootstrap over plans. Planned trials have no other noise (the physics is
    deterministic), so this is the part of a difference that one draw of the yaws alone can give.

    Args:
        outcomes: {task: _Outcomes} of the study.
        rerun: {task: _Outcomes} of the floor's rerun, the same tasks above 0 cm.
        floor: the floor arm.

    Returns:
        `ClusteredEstimate.to_dict()` of the first draw's rate less the rerun's (NaN where nothing ran), and "n".
    """
    first, again, plans, seeds = [], [], [], []
    for task, o in rerun.items():
        if task not in outcomes:
            continue
        both = outcomes[task].started & o.started
        first.append(outcomes[task].held[floor][both])
        again.append(o.held[floor][both])
        plans += [f"{task[0]}/{task[1]}/{task[2]}"] * int(both.sum())
        seeds += [task[1]] * int(both.sum())
    if not plans:
        return {"value": float("nan"), "low": float("nan"), "high": float("nan"), "trials": 0, "clusters": 0,
                "unit": "pts"}
    return bootstrap_difference(np.concatenate(first), np.concatenate(again), plans, seeds).to_dict()


def _verify(config: PlannedStudyConfig, study: StudyRun, plans: dict[tuple[str, int], list[OpenLoopGrasp]],
            digests: dict[tuple[str, int], str]) -> dict[tuple[str, int], np.ndarray]:
    """Each object's and seed's plans verified under the study's protocol and physics (`verify_plans` with the
    family's floor arm), kept in the study folder as the other trials are."""
    family = FAMILIES[config.family]
    tasks = [(name, seed, i, "0.0", digests[name, seed]) for (name, seed), grasps in plans.items()
             for i in range(len(grasps))]
    compute = functools.partial(_plan_task, plans=plans, experiences={cell: {} for cell in plans},
                                arms=(family.floor,))
    kept = study.keep_each("verified", tasks, compute, _read, _write)
    out = {cell: np.zeros(len(grasps), dtype=bool) for cell, grasps in plans.items()}
    for (name, seed, i, _, _), result in kept.items():
        out[name, seed][i] = bool(outcomes_of(result).held[family.floor][0])
    for (name, seed), ok in out.items():
        study.log(f"{name}, seed {seed}: {int(ok.sum())} of {len(ok)} plans hold open loop at 0 cm under the "
                  f"study's protocol")
    return out


def generator_params(quick: bool) -> GeneratorParams:
    """How the plans are generated.

    Args:
        quick: a smoke run.

    Returns:
        Every grasp type's design, 50 candidates per posture (10 for a smoke run).
    """
    return GeneratorParams(designs="grasp_types", max_candidates_per_posture=10 if quick else 50)


def postures_key(name: str, n: int, seed: int, quick: bool) -> str:
    """The key of an object's verified grasps of one seed (`generate`).

    Args:
        name: a benchmark object (`trials.benchmark.OBJECTS`).
        n: grasps.
        seed: the generator's seed.
        quick: a smoke run.

    Returns:
        A hexadecimal key (`checkpoints.result_key`).
    """
    return result_key({"object": OBJECTS[name].object.params(), "n": n, "seed": seed,
                       "params": repr(generator_params(quick))})


def generate(name: str, n: int, seed: int, workers: int, quick: bool, parts: Path) -> PostureSet:
    """An object's verified grasps of one seed: the plans and the experience.

    Args:
        name: a benchmark object (`trials.benchmark.OBJECTS`).
        n: grasps.
        seed: the generator's seed.
        workers: worker processes.
        quick: a smoke run (`generator_params`).
        parts: the checkpoint folder an interrupted generation resumes from.

    Returns:
        The `PostureSet`.
    """
    return generate_postures(OBJECTS[name].object, n, seed=seed, workers=workers, params=generator_params(quick),
                             checkpoint_dir=parts, progress=False)


def _drawn(outcomes: dict) -> set[tuple[str, int, int]]:
    """The plans run displaced: (object, seed, plan) of every task above 0 cm."""
    return {(name, seed, plan) for (name, seed, plan, lv, _) in outcomes if lv != "0.0"}


def _trials(outcomes: dict, arms: Sequence[str], levels: tuple[float, ...], objects: tuple[str, ...] | None = None,
            displaced_only: bool = False, seed: int | None = None) -> dict[str, np.ndarray]:
    """The started trials of these arms at these levels (of these objects; of the displaced plans only; of one
    seed) that every one of them ran: {"held": (n, len(arms)) bool, "plan": (n,) the plan's cluster label (object,
    seed, plan), "seed": (n,)}."""
    drawn = _drawn(outcomes) if displaced_only else set()
    held, plans, seeds = [], [], []
    for (name, run_seed, plan, _, _), o in outcomes.items():
        if (objects is not None and name not in objects) or (displaced_only and (name, run_seed, plan) not in drawn) \
                or (seed is not None and run_seed != seed) or any(arm not in o.held for arm in arms):
            continue
        at = np.isin(o.levels, levels) & o.started
        held.append(np.column_stack([o.held[arm][at] for arm in arms]))
        plans += [f"{name}/{run_seed}/{plan}"] * int(at.sum())
        seeds += [run_seed] * int(at.sum())
    return {"held": np.vstack(held) if held else np.zeros((0, len(arms)), bool), "plan": np.array(plans, dtype=str),
            "seed": np.array(seeds, dtype=int)}


def _pairs(outcomes: dict, arm: str, levels: tuple[float, ...], objects: tuple[str, ...] | None = None,
           displaced_only: bool = False, seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(held, started) of an arm over the started trials at these levels (`_trials`), every one started."""
    held = _trials(outcomes, (arm,), levels, objects, displaced_only, seed)["held"][:, 0]
    return held, np.ones(len(held), dtype=bool)


def _compare(outcomes: dict, a: str, b: str, levels: tuple[float, ...], seed: int = 0) -> dict:
    """A against B on the same trials: the cluster bootstrap over plans (resampled within seeds) of the difference."""
    table = _trials(outcomes, (a, b), levels, displaced_only=levels != (0.0,))
    if not len(table["held"]):
        return {"value": float("nan"), "low": float("nan"), "high": float("nan"), "trials": 0, "clusters": 0,
                "unit": "pts"}
    return bootstrap_difference(table["held"][:, 0], table["held"][:, 1], table["plan"].tolist(),
                                table["seed"].tolist(), seed=seed).to_dict()


def by_design(outcomes: dict, arms: Sequence[str], designs: dict[str, list[str]]) -> dict[str, dict]:
    """Hold counts by the plan's design (the generator's starting posture it came from), at 0 cm over every plan run
    there and at 1-5 cm over the displaced plans.

    Args:
        outcomes: {task: _Outcomes} of the study.
        arms: the arms.
        designs: {"<object> seed <seed>": each plan's design} (`run`'s selection).

    Returns:
        {"<object>: <design>": {"plans": plans at 0 cm, "zero": {arm: [held, n]}, "displaced": {arm: [held, n]}}}.
    """
    out: dict[str, dict] = {}
    drawn = _drawn(outcomes)
    for (name, seed, plan, lv, _), o in outcomes.items():
        cell = out.setdefault(f"{name}: {designs[f'{name} seed {seed}'][plan]}",
                              {"plans": 0, "zero": {arm: [0, 0] for arm in arms},
                               "displaced": {arm: [0, 0] for arm in arms}})
        zero = o.started & (o.levels == 0.0)
        cell["plans"] += int(zero.any())
        for part, at in (("zero", zero), ("displaced", o.started & (o.levels > 0.0))):
            if part == "displaced" and (name, seed, plan) not in drawn:
                continue
            for arm in arms:
                if arm in o.held and at.any():
                    cell[part][arm][0] += int(o.held[arm][at].sum())
                    cell[part][arm][1] += int(at.sum())
    return dict(sorted(out.items()))


def summarise(config: PlannedStudyConfig, outcomes: dict, selection: dict | None = None) -> dict:
    """The report's numbers from the kept outcomes.

    Args:
        config: the study's configuration.
        outcomes: {(object, seed, plan, levels, digest): _Outcomes}.
        selection: how the plans were chosen (`run`: generated, verified, drawn and each plan's design); None: not
            known (no per-design rates).

    Returns:
        What the report shows (`report`), as plain values.
    """
    family = FAMILIES[config.family]
    arms, objects = family.arms, config.objects
    info: dict = {"config": vars(config) | {"objects": list(objects)}, "levels": list(LEVELS), "arms": list(arms),
                  "title": family.title, "primary": family.questions[0][0]}
    info["ceiling"] = {arm: [int(x) for x in _count(*_pairs(outcomes, arm, (0.0,)))] for arm in arms}
    info["ceiling_by_object"] = {name: {arm: [int(x) for x in _count(*_pairs(outcomes, arm, (0.0,), (name,)))]
                                        for arm in arms} for name in objects}
    info["by_level"] = {arm: [[int(x) for x in _count(*_pairs(outcomes, arm, (lv,), displaced_only=True))]
                              for lv in LEVELS] for arm in arms}
    info["by_object_level"] = {name: {arm: [[int(x) for x in _count(*_pairs(outcomes, arm, (lv,), (name,), True))]
                                            for lv in LEVELS] for arm in arms} for name in objects}
    drawn = _drawn(outcomes)
    info["starts"] = {kind: [int(sum((o.start[o.levels == lv] == k).sum() for (name, seed, plan, _, _), o in
                                     outcomes.items() if (name, seed, plan) in drawn)) for lv in LEVELS]
                      for k, kind in enumerate(STARTS)}
    info["faults"] = {arm: int(sum(o.faulted[arm].sum() for o in outcomes.values() if arm in o.faulted))
                      for arm in arms}
    info["fault_reasons"] = {arm: dict(Counter(_reason(f) for o in outcomes.values() for f in o.faults.get(arm, [])))
                             for arm in arms}
    info["without_closure"] = {arm: without_closure(outcomes, arm) for arm in arms}
    pairs, signs, spreads = [], [], []
    for label, a, b, levels in family.questions:
        table = _trials(outcomes, (a, b), levels, displaced_only=levels != (0.0,))
        pairs.append((label, mcnemar(table["held"][:, 0], table["held"][:, 1])))
        spreads.append(_compare(outcomes, a, b, levels))
        per_seed = []
        for seed in config.run_seeds:
            held = _trials(outcomes, (a, b), levels, displaced_only=levels != (0.0,), seed=seed)["held"]
            per_seed.append(float(held[:, 0].mean() - held[:, 1].mean()) if len(held) else float("nan"))
        signs.append(per_seed)
    info["comparisons"] = holm_family(pairs, family.issue)
    for row, per_seed, spread in zip(info["comparisons"], signs, spreads):
        row["by_seed"] = per_seed
        row["same_sign"] = bool(all(d > 0 for d in per_seed) or all(d < 0 for d in per_seed))
        row["bootstrap"] = spread
    if family.headroom is not None:
        info["headroom"] = headroom_shares(outcomes, arms, family.headroom)
        if family.headroom.levels != (0.0,):  # the displaced trials' starts, where the headroom is theirs
            info["by_start"] = by_start(outcomes, arms)
    if selection is not None:
        info["selection"] = selection
        info["by_design"] = by_design(outcomes, arms, selection["designs"])
    info["place_errors"] = place_errors(outcomes, arms)
    info["verdict"] = family.verdict(info)
    info["command"] = f"python {family.script} " + " ".join(sys.argv[1:])
    return info


def headroom_shares(outcomes: dict, arms: Sequence[str], headroom: Headroom) -> dict[str, dict]:
    """Each arm's share of the ceiling's headroom over the floor, (arm - floor) / (ceiling - floor), on the trials
    of the headroom's levels, with the cluster bootstrap over plans (`trials.stats.headroom_share`); the ceiling
    holds a trial where any of its arms does (the per-trial best of the oracles).

    Args:
        outcomes: {task: _Outcomes} of the study.
        arms: the study's arms.
        headroom: the floor, the ceiling, the levels and the arms reported (`Headroom`).

    Returns:
        {arm: `ClusteredEstimate.to_dict()`}.
    """
    out = {}
    for arm in headroom.arms or arms:
        if arm == headroom.floor or arm in headroom.ceiling or arm not in arms:
            continue
        table = _trials(outcomes, (arm, headroom.floor, *headroom.ceiling), headroom.levels,
                        displaced_only=headroom.levels != (0.0,))
        if len(table["held"]):
            held = table["held"]
            out[arm] = headroom_share(held[:, 0], held[:, 1], held[:, 2:].any(axis=1), table["plan"].tolist(),
                                      table["seed"].tolist()).to_dict()
    return out


def by_start(outcomes: dict, arms: Sequence[str]) -> dict[str, dict[str, list[list[int]]]]:
    """Hold counts of the displaced plans' trials by how they started (`trials.planned.STARTS`: from the pregrasp,
    or from the open hand where the pregrasp would start inside the object) and level.

    Args:
        outcomes: {task: _Outcomes} of the study.
        arms: the arms.

    Returns:
        {arm: {start: [[held, n] per level of `LEVELS`]}}.
    """
    drawn = _drawn(outcomes)
    out: dict[str, dict[str, list[list[int]]]] = {}
    for arm in arms:
        out[arm] = {}
        for kind, start in enumerate(STARTS[1:], start=1):
            counts = []
            for level in LEVELS:
                held = n = 0
                for (name, seed, plan, _, _), o in outcomes.items():
                    if (name, seed, plan) in drawn and arm in o.held:
                        at = (o.start == kind) & (o.levels == level)
                        held, n = held + int(o.held[arm][at].sum()), n + int(at.sum())
                counts.append([held, n])
            out[arm][start] = counts
    return out


def place_errors(outcomes: dict, arms: Sequence[str]) -> dict[str, list[dict]]:
    """How far from the truth each arm's touch first placed the object, by level (issue 66's ceiling: how much of
    the displacement touch finds): in the palm's plane, where the palm re-centres.

    Args:
        outcomes: {task: _Outcomes} of the study.
        arms: the arms (those whose trials placed the object nowhere are left out).

    Returns:
        {arm: one row per level above 0: {"level" (m), "n", "median" (m, the estimate's error), "within_1cm" (its
        share), "unmoved" (m, the median error of assuming the object where the plan had it: the level itself)}}.
    """
    out = {}
    for arm in arms:
        rows = []
        for level in LEVELS[1:]:
            errors = []
            for (_, _, _, lv, _), o in outcomes.items():
                if arm not in o.estimate:
                    continue
                at = (o.levels == level) & o.started & (lv != "0.0")
                miss = (o.estimate[arm][at] - o.places[at])[:, [0, 2]]
                errors.append(np.hypot(miss[:, 0], miss[:, 1]))
            found = np.concatenate(errors) if errors else np.zeros(0)
            found = found[np.isfinite(found)]
            if len(found):
                rows.append({"level": level, "n": int(len(found)), "median": float(np.median(found)),
                             "within_1cm": float(np.mean(found <= 0.01)), "unmoved": level})
        if rows:
            out[arm] = rows
    return out


def without_closure(outcomes: dict, arm: str) -> dict[str, int]:
    """The examination of an arm's holds without force closure (epsilon at most `JUDGING.epsilon_threshold`): what
    touched the object, and how many ended at the controller's timeout (never called done).

    Args:
        outcomes: {task: _Outcomes} of the study.
        arm: the arm.

    Returns:
        {"held", "no_closure", "at_timeout", "thumb_opposed" (a thumb segment and a finger's), "palm_no_thumb",
        "fingers_only" (neither thumb nor palm)}: trial counts over every level.
    """
    thumb = np.array([name.startswith("th") for name in SEGMENTS])
    palm = np.array([name == "palm" for name in SEGMENTS])
    finger = ~thumb & ~palm & np.array([name not in ("forearm", "wrist") for name in SEGMENTS])
    params = arm_params(ARMS[arm])
    timeout = None if params is None else params.timeout
    counts: Counter[str] = Counter()
    for o in outcomes.values():
        if arm not in o.held:  # an arm of 0 cm only, on a displaced plan's other levels
            continue
        held = o.held[arm]
        loose = held & ~(o.epsilon[arm] > JUDGING.epsilon_threshold)
        touch = o.touching[arm][loose]
        counts["held"] += int(held.sum())
        counts["no_closure"] += int(loose.sum())
        counts["at_timeout"] += 0 if timeout is None else int((o.seconds[arm][loose] >= timeout - 1e-6).sum())
        opposed = touch[:, thumb].any(axis=1) & touch[:, finger].any(axis=1)
        with_palm = ~touch[:, thumb].any(axis=1) & touch[:, palm].any(axis=1)
        counts["thumb_opposed"] += int(opposed.sum())
        counts["palm_no_thumb"] += int(with_palm.sum())
        counts["fingers_only"] += int((~opposed & ~with_palm).sum())
    return {k: counts[k] for k in ("held", "no_closure", "at_timeout", "thumb_opposed", "palm_no_thumb",
                                   "fingers_only")}


def _reason(fault: str) -> str:
    """A fault's reason without its numbers: "the simulation of the pen scene failed at t = 0.26 s: a contact
    penetrates 6.1 mm (limit 5 mm); ..." -> "pen: a contact penetrates N mm (limit N mm)"."""
    scene = re.search(r"of the (\S+) scene", fault)
    reason = re.sub(r"\d+(\.\d+)?", "N", fault.split(": ", 1)[-1].split(";")[0]).strip()
    return f"{scene.group(1) if scene else '?'}: {reason[:70]}"


def _count(held: np.ndarray, started: np.ndarray) -> tuple[int, int]:
    return int(held[started].sum()), int(started.sum())


def report(info: dict) -> str:
    """The markdown report."""
    arms, levels = info["arms"], info["levels"]
    lines = [f"# {info.get('title', EXECUTION.title)}", "",
             f"Generated by `{info['command']}` ({info['config']}). The design: `graspmanifold.studies.planned_grasps`"
             " (module doc) and `graspmanifold.trials.planned`. Every arm starts from the same state (the hand in "
             "the plan's pregrasp, its palm where the plan puts it for the nominal object), on the same spring "
             f"support, released as the `{PLANNED_PROTOCOL.name}` protocol releases it (the support fading over "
             f"{PLANNED_PROTOCOL.rules.release_seconds:g} s) and judged by the same hold test; a fault is a failure "
             "of its arm.", "", f"**{info['verdict']}**", ""]
    lines += _selection_lines(info)
    lines += ["## The ceiling: every plan at its own palm pose (0 cm)", ""]
    lines += markdown_table(["arm", "held [95 % CI]"] + [name for name in info["ceiling_by_object"]],
                            [[arm, rate_text(*info["ceiling"][arm])] +
                             [f"{h}/{n}" for h, n in (info["ceiling_by_object"][name][arm]
                                                      for name in info["ceiling_by_object"])] for arm in arms])
    lines += ["", "## Hold rate against displacement (the displaced plans)", "",
              "How the displaced plans' trials started, by level (from the pregrasp; from the open hand where the "
              "pregrasp would start inside the object; not at all where the open hand would too):", ""]
    lines += markdown_table(["start"] + [f"{100 * v:.0f} cm" for v in levels],
                            [[kind] + counts for kind, counts in info["starts"].items()])
    lines += [""]
    lines += markdown_table(["arm"] + [f"{100 * v:.0f} cm" for v in levels],
                            [[arm] + [rate_text(*c) for c in info["by_level"][arm]] for arm in arms])
    if info.get("figure"):
        lines += ["", f"![hold rate against displacement]({info['figure']})"]
    lines += _comparison_lines(info)
    if "without_closure" in info:  # a study.json of before the examination has none
        lines += ["", "## Holds without force closure, examined", "",
                  f"A held trial whose grasp has epsilon at most {JUDGING.epsilon_threshold:g} (no force closure in "
                  "the grasp wrench space of its contacts) held the object through the hold test's six gravity "
                  "directions all the same: what touched it, and how many such trials ended at the controller's "
                  f"timeout ({ControllerParams().timeout:g} s, never called done), over every level. A thumb opposed "
                  "to a finger is a pinch (two soft contacts: a torque about the line between them is held by "
                  "friction the epsilon metric does not count); a palm with fingers and no thumb is a hook or a "
                  "wrap against the palm; fingers alone hold the object between them. Each held through the same "
                  "hold test as every other grasp, so each is counted as one (the hold test, not epsilon, is the "
                  "outcome of every arm).", ""]
        lines += markdown_table(["arm", "held", "without closure", "at the timeout", "thumb opposed",
                                 "palm, no thumb", "fingers only"],
                                [[arm, w["held"], w["no_closure"], "–" if ARMS[arm].controller == "open-loop" else
                                  w["at_timeout"], w["thumb_opposed"], w["palm_no_thumb"], w["fingers_only"]]
                                 for arm, w in info["without_closure"].items()])
    if info.get("place_errors"):
        lines += ["", "## Where touch placed the object", "",
                  "At the palm's first re-centring, where the controller's touch placed the object "
                  "(`Trial.object_estimate`) against where it lay (the palm's plane, cm): the median error and the "
                  "share within 1 cm, by level; assuming the object where the plan had it errs by the level itself.",
                  ""]
        lines += markdown_table(["arm"] + [f"{100 * r['level']:.0f} cm: median (within 1 cm), n" for r in next(
            iter(info["place_errors"].values()))],
            [[arm] + [f"{100 * r['median']:.1f} cm ({100 * r['within_1cm']:.0f} %), {r['n']}" for r in rows]
             for arm, rows in info["place_errors"].items()])
    lines += _start_lines(info)
    lines += _design_lines(info)
    lines += ["", "## Faults by arm (each counted as a failure above)", ""]
    lines += markdown_table(["arm", "faults", "object: reason (count)"],
                            [[arm, info["faults"][arm], "; ".join(f"{r} ({n})" for r, n in sorted(
                                info["fault_reasons"][arm].items(), key=lambda item: -item[1])) or "–"]
                             for arm in arms])
    return "\n".join(lines) + "\n"


def share_text(share: dict) -> str:
    """A headroom share as the report writes it.

    Args:
        share: `ClusteredEstimate.to_dict()` of a share.

    Returns:
        '43 % [31, 55]', or what it means that there is none (the ceiling held no more than the floor).
    """
    if not np.isfinite(share["value"]):
        return "no headroom: the ceiling held no more than the floor"
    return f"{100 * share['value']:.0f} % [{100 * share['low']:.0f}, {100 * share['high']:.0f}]"


def _comparison_lines(info: dict) -> list[str]:
    """The report's paired comparisons: McNemar, Holm, the bootstrap over plans, seed by seed, the headroom."""
    lines = ["", "## Paired comparisons (McNemar on the same trials, Holm over the family)", ""]
    if "primary" in info:
        lines += [f"The primary comparison, named before the study ran: **{info['primary']}**. Trials of one plan "
                  "are not independent (a plan one arm cannot execute fails it at every displacement), so McNemar's "
                  "p-values are too small by an unknown design effect; the last column is the 95 % interval of the "
                  "difference from a cluster bootstrap over plans (plans resampled within each seed, their trials "
                  "kept together, 2,000 replicates): a difference is claimed where that interval excludes 0.", ""]
    lines += comparison_table(info["comparisons"], bootstrap="bootstrap" in info["comparisons"][0])
    headroom = FAMILIES[info["config"]["family"]].headroom
    if info.get("headroom") and headroom is not None:
        lines += ["", f"The share of the headroom: {headroom.describe()}, on the same trials, with the "
                  "cluster-bootstrap interval over plans:", ""]
        lines += markdown_table(["arm", "headroom share [95 % CI over plans]", "trials", "plans"],
                                [[arm, share_text(h), h["trials"], h["clusters"]]
                                 for arm, h in info["headroom"].items()])
    if info.get("noise_floor", {}).get("trials"):
        floor = info["noise_floor"]
        arm = FAMILIES[info["config"]["family"]].floor
        lines += ["", f"The noise floor: the `{arm}` arm on the displaced plans against itself with the displacements' "
                  f"yaws drawn again (the same plans, levels and directions): {100 * floor['value']:+.1f} pts "
                  f"[{100 * floor['low']:+.1f}, {100 * floor['high']:+.1f}] over {floor['trials']} paired trials of "
                  f"{floor['clusters']} plans. The physics is deterministic; this is what one draw of the yaws "
                  "moves."]
    lines += ["", "The same differences seed by seed (a difference is claimed only where its sign holds on every seed):",
              ""]
    lines += markdown_table(["comparison"] + [f"seed {s}" for s in info["config"]["seeds"][:len(
        info["comparisons"][0]["by_seed"])]] + ["same sign"],
        [[r["label"]] + [f"{100 * d:+.1f} pts" for d in r["by_seed"]] + ["yes" if r["same_sign"] else "no"]
         for r in info["comparisons"]])
    return lines


def _start_lines(info: dict) -> list[str]:
    """The report's rates by how the displaced trials started, for the floor, the ceilings and fingers only."""
    if not info.get("by_start"):
        return []
    family = FAMILIES[info["config"]["family"]]
    ceiling = () if family.headroom is None else family.headroom.ceiling
    shown = [arm for arm in (family.floor, *ceiling, "oracle-translation", "fingers-only") if arm in info["arms"]]
    levels = info["levels"]
    lines = ["", "## By start", "",
             "The displaced plans' trials by how they started: from the plan's pregrasp, or from the open hand at the "
             "grasp's palm pose where the pregrasp would start inside the displaced object (an oracle that moves the "
             "palm by the displacement fixes the palm's place, not the start the trial was given):", ""]
    lines += markdown_table(["arm", "start"] + [f"{100 * v:.0f} cm" for v in levels],
                            [[arm, start] + [f"{h}/{n}" if n else "–" for h, n in counts]
                             for arm in dict.fromkeys(shown) for start, counts in info["by_start"][arm].items()])
    return lines


def _design_lines(info: dict) -> list[str]:
    """The report's rates by the plans' designs."""
    if not info.get("by_design"):
        return []
    arms = info["arms"]
    lines = ["", "## By design", "",
              "Held at 0 cm (every plan of the design run there) and at 1-5 cm (the design's displaced plans, "
              "when any was drawn), by the generator's design the plan came from: a pooled rate is a mixture of "
              "these.", ""]
    shown = [arm for arm in arms if arm in ("open-loop", "flange-open-loop", "approach-recall", "approach",
                                           "fingers-only", "palm-touch", "palm-experience", "oracle-correction")]
    lines += markdown_table(["object: design", "plans"] + [f"{arm} 0 cm" for arm in shown] +
                            [f"{arm} 1-5 cm" for arm in shown],
                            [[design, cell["plans"]] + [f"{h}/{n}" for h, n in (cell["zero"][a] for a in shown)] +
                             [f"{h}/{n}" if n else "–" for h, n in (cell["displaced"][a] for a in shown)]
                             for design, cell in info["by_design"].items()])
    return lines


def _selection_lines(info: dict) -> list[str]:
    """How the plans were chosen: verified under the study's protocol, the displaced ones drawn."""
    chosen = info.get("selection")
    if not chosen:
        return []
    generated, verified = sum(chosen["generated"].values()), sum(chosen["verified"].values())
    floor = FAMILIES[info["config"]["family"]].floor
    return ["## The plans", "",
            f"The generator verified {generated} grasps on the free, weightless object; the study verified each again "
            f"under its own protocol and physics (`trials.planned.verify_plans`: the `{floor}` arm at its own palm "
            f"pose) and kept the {verified} that held ({100 * verified / max(generated, 1):.0f} %): one meaning of "
            f"verified, so the open loop holds every plan at 0 cm. The displaced plans were drawn at random among "
            f"them (`drawn_plans`, draw seed {info['config'].get('draw', 0)}), not taken in the generator's order "
            "(which emits plans design by design):", "",
            *markdown_table(["object, seed", "verified / generated", "displaced plans (indices)"],
                            [[cell, f"{chosen['verified'][cell]}/{chosen['generated'][cell]}",
                              ", ".join(map(str, chosen["drawn"][cell]))] for cell in chosen["generated"]]), ""]


def figure(info: dict, path: Path) -> str:
    """Hold rate against displacement by arm: pooled, and per object."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(info["by_object_level"])
    columns = min(4, 1 + len(names))
    rows = -(-(1 + len(names)) // columns)
    fig, grid = plt.subplots(rows, columns, figsize=(3.3 * columns, 2.9 * rows + 0.8), sharey=True, sharex=True,
                             layout="constrained", squeeze=False)
    axes = grid.ravel()
    for ax in axes[1 + len(names):]:
        ax.set_visible(False)
    xs = 100 * np.array(info["levels"])
    for ax, title, counts in [(axes[0], "pooled", info["by_level"])] + [
            (ax, name, info["by_object_level"][name]) for ax, name in zip(axes[1:], names)]:
        for k, arm in enumerate(info["arms"]):
            rate_curve(ax, xs + 0.06 * (k - len(info["arms"]) / 2), counts[arm], label=arm, fmt="-o", ms=3,
                       color=_STYLE.get(arm))
        ax.set_title(title)
    for ax in grid[-1]:
        ax.set_xlabel("displacement (cm)")
    for ax in grid[:, 0]:
        ax.set_ylabel("held (%)")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=4, fontsize=8)
    return save_figure(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run: two objects, 6 plans, 2 displaced")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seeds", type=int, nargs="+", default=[2, 3, 4],
                        help="generator, map and trial seeds, one run each (seed 0 chose the approach execution; "
                             "seed 1's plans were looked at while designing it)")
    parser.add_argument("--plans", type=int, default=34, help="grasps per object and seed the generator verifies; "
                        "those the study's verification passes each run at 0 cm")
    parser.add_argument("--displaced", type=int, default=3, help="plans per object and seed also run displaced, drawn "
                        "among the verified ones")
    parser.add_argument("--draw", type=int, default=0, help="seeds the draw of the displaced plans")
    parser.add_argument("--out", default="", help="the study's folder (default study-planned-grasps[-quick])")
    parser.add_argument("--doc", default="", help="the report (default docs/studies/planned_grasps.md, or OUT/ for --quick)")
    args = parser.parse_args(argv)
    config = study_config(lambda: PlannedStudyConfig(args.quick, args.workers, tuple(args.seeds), args.plans,
                                                     args.displaced, draw=args.draw))
    out = Path(args.out or (EXECUTION.default_out + ("-quick" if args.quick else "")))
    doc = Path(args.doc or (out / Path(EXECUTION.default_doc).name if args.quick else EXECUTION.default_doc))

    def body(study: StudyRun) -> None:
        study.check_writable(doc)
        info = run(config, study)
        publish(study, doc, config.quick, info, report, figure)

    run_study(out, args.workers, body, "planned_grasps.log")


if __name__ == "__main__":
    main()
