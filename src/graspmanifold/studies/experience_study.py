"""The experience study: does recalling experience choose better grasps than fixed preshapes, once and with a regrasp?

    python scripts/study_experience.py [--quick] [--workers 2] [--out study] [--doc docs/studies/experience_study.md]
                                       [--config study.toml]

or from Python, configured (`ExperienceStudyConfig`) or extended (a subclass of `ExperienceStudy`):

    from graspmanifold.studies.experience_study import ExperienceStudy, ExperienceStudyConfig
    info = ExperienceStudy(ExperienceStudyConfig(quick=True, out="study-quick")).run()

The benchmark (`graspmanifold.trials.benchmark`): the paper's three objects and four small or flat ones
(marble, pen, disc, cube), each placed near the palm and out at the fingertips; the controller is
never told which object it grasps. The study, in the order a careful reviewer would ask for it:

1. Experience of every grasp type: for each object `--postures` verified postures from the designs of
   every grasp type (`GeneratorParams(designs="grasp_types")`), all objects in one set: one 25 x 25 SOM
   and one database for all of them; each SOM node labelled with the grasp type of its nearest posture.
2. A random split of all the benchmark's poses, stratified by object and placement
   (`benchmark.benchmark_split`): a third to select on, two thirds to test on, touched once.
3. Strategies fixed before any test: the plain heuristic and one constant preshape per grasp type.
4. Headroom on the selection split, before anything is compared: the per-pose oracle over the strategies
   against the best of them, and the chance oracle over as many runs of that best strategy (its own and
   jittered reruns, 1 mm / 0.02 rad): only the headroom beyond chance counts (`stats.headroom`).
5. Selection, on the selection split only: the best shared preshape (one attempt), the SOM controller's
   variant (the paper's literal controller, the blend, the blend restarting its closure, the approach execution
   of issue 65), and the best fixed
   two-attempt sequence of strategies (the best single one first, the best second attempt after it).
6. Test, one attempt: the paper's literal controller, the blend and the selected variant against the best
   shared preshape. Two attempts (`control.regrasp`: a lift probe reads touch only; a failing grasp is let
   go and grasped again from where the object lies): regrasp with experience (the SOM's best match for what
   the failed attempt sensed, of another grasp type) against the best fixed sequence and the heuristic
   retried. Paired (McNemar), Holm within each family, pooled and per object; rates with Wilson intervals.
7. Experience content (issue 65): the selected controller and its regrasp again with the null experience (the same
   map trained on the postures with each joint column permuted: `manifold.experience.scrambled`); an experience
   claim is a claim against it. Coverage: the test poses where a verified grasp of the experience holds the object
   within 1 cm of where the pose puts it (`grid.covered`), every method's rate and the main comparisons also there.
8. Seeds (`--seeds`, default 3): the experience made anew from seeds 1, 2 (generator, map, null map, trials) and the
   claims of `REPLICATED` run again on the test split with the choices of step 5; a claim needs its sign on every seed.

Every finished evaluation is kept in --out under the key of what made it, so an interrupted study resumes
and a changed one recomputes only what changed; the configuration used is written to --out/config.toml. Writes `--out/study.json`
and the markdown report `--doc` (with `--quick`: a smoke run of two objects and a sixth of the poses into
`study-quick/`, too small to be evidence). The first study, on the paper's grids, is
`scripts/study_experience_paper_grids.py`; its verdict is quoted in the report.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..base.checkpoints import result_key
from ..base.config_files import read_config, to_toml
from ..base.errors import InvalidInput
from ..base.io import json_text, markdown_table, read_json, write_text_atomic
from ..base.validation import check_int
from ..control.controller import APPROACH, BLEND, ControllerParams
from ..control.recall import BlendRecall
from ..control.regrasp import Regrasp, grasp_types_of, reference_grasp_types
from ..manifold.experience import Experience, scrambled
from ..manifold.som import SOM
from ..manifold.postureset import PostureSet
from ..sim.hand import N_FINGER_JOINTS
from ..synthesis.generator import MAX_POSTURES, GeneratorParams, generate_postures
from ..trials.benchmark import OBJECTS, PLACEMENTS, benchmark_split, cells, compare_pooled, pooled, run_benchmark
from ..trials.experience_pays import train_experience_map
from ..trials.grid import COVERED_ANGLE, COVERED_WITHIN, covered
from ..trials.stats import MIN_HEADROOM_BEYOND_CHANCE, headroom, rate_text
from ..trials.strategy_selector import StrategySelector, choose_cross_validated
from ..trials.setup import Noise
from .runner import StudyRun, comparison_table, holm_family, publish, run_command, study_config

#: the target (issue 38), pooled over the test split: two attempts each, regrasp with experience against the best
#: fixed sequence of strategies
TARGET_POINTS, TARGET_P, TARGET_POSES = 0.08, 0.01, 600
#: the pose noise of the best strategy's reruns that measure how much of the headroom is chance
JITTER = Noise(position=0.001, yaw=0.02)
#: the share of every (object, placement) that the selection split takes, and the split's seed
SELECTION_SHARE, SPLIT_SEED = 1 / 3, 0
#: the sensitivity family's comparisons: the trials whose physics failed counted as failed grasps, not left out
REGRASP_AS_FAILURES = "regrasp with experience against the best fixed sequence, failed physics as failed grasps"
PAPER_AS_FAILURES = "the paper's controller against the shared preshape, failed physics as failed grasps"
QUICK_OBJECTS = ("box", "marble")
#: the SOM controller's variants, one of which the selection split picks: the paper's literal controller
#: (recall='target'), the blend (BLEND), the blend restarting the closure at the first trusted match, and the paper's
#: reading executed as a verified grasp is (APPROACH, issue 65)
SOM_VARIANTS = {"som_paper": ControllerParams(), "som_blend": BLEND,
                "som_restart": replace(BLEND, recall=BlendRecall(restart_closure=True)), "som_approach": APPROACH}
SOM_DESCRIPTIONS = {"som_paper": "the paper's controller (ControllerParams())", "som_blend": "the blend (BLEND)",
                    "som_restart": "replace(BLEND, recall=BlendRecall(restart_closure=True))",
                    "som_approach": "the approach execution (APPROACH)"}
#: the null experience's map: the same training on the union's postures with each joint column permuted
NULL_SEED = 0
#: the experience-content family's comparisons: the selected controller with the map against with the null map
NULL_ONCE = "the selected SOM controller against itself with the null map"
NULL_REGRASP = "regrasp with experience against regrasp with the null map"
#: the attempts of the regrasp methods and their controls
ATTEMPTS = 2
#: the family of the further seeds' comparisons
REPLICATIONS = "further seeds: the claims again with the experience and the trials seeded anew, pooled"
#: the primary comparison's label in the replications
PRIMARY = "regrasp with experience against the best fixed sequence"
#: the claims every further seed runs again (generator, map, null map and trials seeded anew; the choices the selection
#: split made kept): {label: (method, method)} of the test runs
REPLICATED = {PRIMARY: ("regrasp_experience", "best_sequence"), NULL_ONCE: ("som", "som_null"),
              NULL_REGRASP: ("regrasp_experience", "regrasp_null")}


@dataclass(frozen=True)
class ExperienceStudyConfig:
    """How the experience study runs (a TOML file of these keys: `--config`).

    Args:
        quick: a smoke run: two objects, a sixth of the poses, 7 postures per object (too small to be evidence).
        workers: worker processes.
        out: the folder of kept results ('' : study, or study-quick).
        doc: the markdown report ('': docs/studies/experience_study.md, or OUT/experience_study.md for a quick run).
        postures: verified postures per object (0: 48, or 7 for a quick run).
        seeds: seeds of the whole experience (generator, map, null map, trials): seed 0 runs the study, every
            further seed the test split's claims again (`REPLICATED`) with the choices seed 0's selection split made;
            a claim needs its sign on every seed (0: 3, or 2 for a quick run).
    """

    #: the folder of kept results (with '-quick' for a quick run) and the report's name, when not given
    FOLDER: ClassVar[str] = "study"
    REPORT: ClassVar[str] = "experience_study"

    quick: bool = False
    workers: int = 2
    out: str = ""
    doc: str = ""
    postures: int = 0
    seeds: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.quick, bool):
            raise InvalidInput(f"quick must be true or false, got {self.quick!r}")
        check_int(self.workers, "workers")
        if self.seeds != 0:
            check_int(self.seeds, "seeds", high=10)
        if self.postures != 0:
            check_int(self.postures, "postures", high=MAX_POSTURES)
        for name in ("out", "doc"):
            if not isinstance(getattr(self, name), str):
                raise InvalidInput(f"{name} must be a path (a string), got {getattr(self, name)!r}")

    @property
    def out_dir(self) -> Path:
        """The folder of kept results."""
        return Path(self.out or (f"{self.FOLDER}-quick" if self.quick else self.FOLDER))

    @property
    def doc_path(self) -> Path:
        """The markdown report."""
        return Path(self.doc or (self.out_dir / f"{self.REPORT}.md" if self.quick else f"docs/studies/{self.REPORT}.md"))

    @property
    def postures_per_object(self) -> int:
        """Verified postures per object."""
        return self.postures or (7 if self.quick else 48)

    @property
    def seed_count(self) -> int:
        """Seeds of the experience and the trials."""
        return self.seeds or (2 if self.quick else 3)


class ExperienceStudy(StudyRun):
    """The experience study (the module's docstring says what it measures); `run` runs it and returns what its
    report shows. Extend it by subclassing: `strategies` (the fixed strategies) and `objects` are its choices.

    Args:
        config: how it runs.
    """

    def __init__(self, config: ExperienceStudyConfig = ExperienceStudyConfig()):
        super().__init__(config.out_dir, config.workers)
        self.config = config
        self.objects = QUICK_OBJECTS if config.quick else tuple(OBJECTS)
        self.split = benchmark_split(SELECTION_SHARE, SPLIT_SEED)
        self.results: dict[tuple[str, str], dict] = {}  # (split, method) -> {(object, placement): EvaluationResult}
        self.evaluations, self.reused_evaluations = 0, 0  # (object, placement) evaluations, and those taken from OUT
        self.evaluation_seconds = 0.0  # of the evaluations run now
        self.made_seconds: dict[str, float] = {}  # each evaluation's seconds when it ran, now or in an earlier run

    def evaluate(self, split: str, method: str, experience: Experience | None = None, *, seed: int = 0,
                 poses: dict | None = None, **setup: object) -> dict:
        """One method on every cell of a split, kept in OUT/evaluation under its key (`run_benchmark`).

        Args:
            split: 'selection' or 'test' (or a name for `poses`).
            method: the method's label, which names its files.
            experience: the experience base (None: the plain controller).
            seed: the trials' seed.
            poses: {(object, placement): grid poses} to run instead of the split's own (every one of them, also in
                a quick run); `split` then names the files.
            **setup: the trials' `TrialSetup` fields beside the experience (params, preshape, noise, regrasp).

        Returns:
            {(object, placement): EvaluationResult}.
        """
        start = time.perf_counter()
        stored = self.out / "evaluation"
        ours = [key for key in cells() if key[0] in self.objects]
        files = [stored / f"{method}_{split}_{o}_{p}.npz" for o, p in ours]
        existed = {path: path.stat().st_mtime_ns for path in files if path.exists()}
        chosen = {key: grid for key, grid in (self.split[split] if poses is None else poses).items()
                  if key[0] in self.objects}
        results = run_benchmark(experience, split="test" if split == "test" else "selection", objects=chosen,
                                every=6 if self.config.quick and poses is None else 1,
                                workers=self.executor or self.workers, seed=seed, store=stored, method=method,
                                **setup)
        kept = sum(path.exists() and path.stat().st_mtime_ns == mtime for path, mtime in existed.items())
        self.reused_evaluations += kept  # a file stored by another configuration or code is made again, not reused
        self.evaluations += len(ours)
        ledger = stored / "seconds.json"  # how long each evaluation took when it ran, for a report made from reuse
        made = json.loads(ledger.read_text()) if ledger.exists() else {}
        if kept < len(ours):
            self.evaluation_seconds += time.perf_counter() - start
            made[f"{method}_{split}"] = time.perf_counter() - start
            write_text_atomic(ledger, json_text(made))
        if f"{method}_{split}" in made:  # not for evaluations kept before the ledger was
            self.made_seconds[f"{method}_{split}"] = made[f"{method}_{split}"]
        self.results[(split, method)] = results
        outcomes, valid = pooled(results)
        self.log(f"{split:9s} {method:34s} hold {rate_text(int(outcomes[valid].sum()), int(valid.sum()))} "
                 f"({time.perf_counter() - start:.0f} s)")
        return results

    def experience(self, seed: int = 0) -> tuple[PostureSet, dict[str, PostureSet]]:
        """Verified postures of every grasp type per object, kept in OUT under the key of what made them (the
        object, the number of postures, the seed, the generator's parameters and the code), and their union.

        Args:
            seed: the generator's seed (the files of a seed other than 0 are named `experience_<object>_seed<k>`).
        """
        sets = {}
        n = self.config.postures_per_object
        params = GeneratorParams(designs="grasp_types", max_candidates_per_posture=10 if self.config.quick else 50)
        for name in self.objects:
            obj = OBJECTS[name].object
            key = result_key({"object": obj.params(), "n": n, "seed": seed, "params": asdict(params)})

            def make(parts: Path, obj=obj, name=name) -> PostureSet:
                start = time.perf_counter()
                postures = generate_postures(obj, n, seed=seed, workers=self.executor or self.workers,
                                             params=params, checkpoint_dir=parts)
                self.log(f"experience {name}: {len(postures)} postures from {postures.metadata['candidates']} "
                         f"candidates ({time.perf_counter() - start:.0f} s)")
                return postures

            sets[name] = self.postures(f"experience_{name}" + (f"_seed{seed}" if seed else ""), key, make)
        return PostureSet.concatenate(list(sets.values())), sets

    def strategies(self, preshapes: dict[str, np.ndarray]) -> dict[str, np.ndarray | None]:
        """The fixed strategies the headroom and the controls are made of: the plain heuristic (None) and one
        constant preshape per grasp type.

        Args:
            preshapes: {name: posture (22,), rad}, one per grasp type (`grasp_type_preshapes`).

        Returns:
            {name: preshape or None}.
        """
        return {"none": None, **preshapes}

    def measure(self) -> dict:
        """Every step of the study, in order; what its report shows (a subclass that asks another question
        measures its own)."""
        return measure(self)

    def report(self, info: dict) -> str:
        """The markdown report of what `measure` returned."""
        return report(self.config, info)

    #: draws the report's figure beside it (`runner.publish`: `figure(info, path)` -> the file's name), or None: this
    #: study's report has none
    figure: Callable[[dict, Path], str] | None = None

    def run(self) -> dict:
        """The whole study, with OUT locked and one pool of workers; writes the report (and its figure),
        OUT/study.json and OUT/config.toml.

        Returns:
            What the report shows (the content of study.json).
        """
        self.check_writable(self.config.doc_path)
        with self.session():
            write_text_atomic(self.out / "config.toml", to_toml(self.config))
            info = self.measure()
            publish(self, self.config.doc_path, self.config.quick, info, self.report, self.figure)
        return info


def grasp_type_preshapes(sets: dict[str, PostureSet]) -> dict[str, np.ndarray]:
    """One constant preshape per grasp type: the mean of the experience's postures of that type."""
    by_type: dict[str, list[np.ndarray]] = {}
    for postures in sets.values():
        types = postures.metadata["grasp_types"]
        for i, name in enumerate(postures.start_names):
            rows = postures.postures[postures.start_ids == i]
            if len(rows):
                by_type.setdefault(types[name.split(":", 1)[1]], []).append(rows)
    return {f"preshape_{t}": np.concatenate(rows).mean(axis=0) for t, rows in sorted(by_type.items())}


def sequence(strategies: dict[str, np.ndarray | None], second: str) -> Regrasp:
    """Two attempts, the second with the strategy `second` (the plain heuristic where it is None)."""
    chosen = strategies[second]
    row = np.full(N_FINGER_JOINTS, np.nan) if chosen is None else chosen
    return Regrasp(ATTEMPTS, preshapes=row[None])


def replicate(study: ExperienceStudy, seed: int, best: str, tuned: str, second: str) -> dict[str, dict]:
    """The test split's runs of the replicated claims (`REPLICATED`) with the experience made again from `seed`: the
    generator, the map, the null map and the trials seeded with it; the strategy, SOM variant and sequence that seed
    0's selection split chose kept.

    Args:
        study: the study (its folder keeps the runs, named `<method>_seed<k>`).
        seed: the seed (>= 1).
        best: the best single strategy; tuned: the SOM variant; second: the sequence's second strategy.

    Returns:
        {"best_sequence" | "som" | "som_null" | "regrasp_experience" | "regrasp_null": {cell: EvaluationResult}}.
    """
    union, sets = study.experience(seed)
    som, null = train_experience_map(union.postures, seed), train_experience_map(scrambled(union.postures, seed), seed)
    types = np.concatenate([grasp_types_of(s) for s in sets.values()])
    strategies = study.strategies(grasp_type_preshapes(sets))
    params, tag = SOM_VARIANTS[tuned], f"_seed{seed}"
    return {"best_sequence": study.evaluate("test", f"sequence_{best}_{second}{tag}", preshape=strategies[best],
                                            regrasp=sequence(strategies, second), seed=seed),
            "som": study.evaluate("test", f"{tuned}{tag}", som, params=params, seed=seed),
            "som_null": study.evaluate("test", f"{tuned}_null{tag}", null, params=params, seed=seed),
            "regrasp_experience": study.evaluate(
                "test", f"regrasp_{tuned}{tag}", som, params=params, seed=seed,
                regrasp=Regrasp(ATTEMPTS, grasp_types=reference_grasp_types(som, union.postures, types))),
            "regrasp_null": study.evaluate(
                "test", f"regrasp_{tuned}_null{tag}", null, params=params, seed=seed,
                regrasp=Regrasp(ATTEMPTS, grasp_types=reference_grasp_types(null, union.postures, types)))}


def rate(results: dict, rows: list | None = None) -> float:
    outcomes, valid = pooled(results, rows=rows)
    return float(outcomes[valid].mean())


def object_rows(name: str) -> list[tuple[str, str]]:
    return [(name, p) for p in PLACEMENTS]


def _trials(results: dict) -> list:
    return [t for key in cells() if key in results for t in results[key].trials]


def _features(results: dict, kind: str) -> np.ndarray:
    """What the controller sensed on each pose, pooled: `Trial.first_contact` or `Trial.failure`."""
    return np.array([getattr(t, kind) for t in _trials(results)])


def _outcomes(runs: dict[str, dict], names: list[str]) -> np.ndarray:
    return np.column_stack([pooled(runs[m])[0] for m in names])


def _valid(runs: dict[str, dict], names: list[str]) -> np.ndarray:
    return np.column_stack([pooled(runs[m])[1] for m in names])


def _failed_poses(results: dict) -> np.ndarray:
    """The poses whose first attempt failed its lift probe."""
    return np.array([t.attempts > 1 for t in _trials(results)], dtype=bool)


def information_ceiling(runs: dict[str, dict], names: list[str], kind: str, room: dict | None) -> dict:
    """A selector's cross-validated picks (5 folds) over the strategies' runs from what was sensed (`kind`), on the
    poses valid for every strategy (for `failure`: those whose first attempt failed the probe), against the best
    single strategy, the oracle and, given the headroom row, the chance oracle."""
    keep = _valid(runs, names).all(axis=1)
    if kind == "failure":
        keep &= _failed_poses(runs[names[0]])
    held, features = _outcomes(runs, names)[keep], _features(runs[names[0]], kind)[keep]
    folds = min(5, len(held))
    picked = choose_cross_validated(features, held, names, folds=folds, seed=0) if folds >= 2 else \
        np.zeros(len(held), dtype=int)
    counts = held.sum(axis=0)
    return {"n": int(len(held)), "selector": int(held[np.arange(len(held)), picked].sum()),
            "best": int(counts.max()) if len(held) else 0, "oracle": int(held.any(axis=1).sum()),
            "chance_oracle": None if room is None else room["chance_oracle"],
            "picked": {m: int((picked == k).sum()) for k, m in enumerate(names)}}


def main(argv: list[str] | None = None) -> None:
    """The study's command: `python scripts/study_experience.py --help`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=None, help="a TOML file of ExperienceStudyConfig's keys (the flags "
                        "below override it)")
    parser.add_argument("--quick", action="store_true", default=None, help="a smoke run: two objects, a sixth of "
                        "the poses")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default 2)")
    parser.add_argument("--out", default=None, help="data directory (default: study or study-quick)")
    parser.add_argument("--doc", default=None, help="markdown report (default: docs/studies/experience_study.md; with "
                        "--quick: OUT/experience_study.md)")
    parser.add_argument("--postures", type=int, default=None, help="verified postures per object (default 48; "
                        "quick: 7)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds of the experience and the trials: seed 0 runs "
                        "the study, every further seed its claims again (default 3; quick: 2)")
    parser.add_argument("--render", action="store_true", help="only write the report again from OUT/study.json "
                        "(the run that made it is the one it reports)")
    args = parser.parse_args(argv)
    flags = {k: getattr(args, k) for k in ("quick", "workers", "out", "doc", "postures", "seeds") if getattr(args, k) is not None}
    config = study_config(lambda: replace(read_config(args.config, ExperienceStudyConfig()) if args.config
                                          else ExperienceStudyConfig(), **flags))  # checked before OUT is made
    if args.render:
        stored = config.out_dir / "study.json"
        if not stored.exists():
            raise SystemExit(f"error: --render needs {stored}, written by a run of the study")
        write_text_atomic(config.doc_path, report(config, read_json(stored, "the study's JSON")))
        print(f"wrote {config.doc_path} from {stored}")
        return
    run_command(config.out_dir, lambda: ExperienceStudy(config).run())


@dataclass
class _Choices:
    """What the selection split chose (the test split never does): the strategies' runs there, the best single
    strategy, the shared preshape, the SOM's variant, the best two-attempt sequence, the headroom and the ceiling."""

    selection: dict
    best: str
    shared: str
    tuned: str
    sequences: dict[str, str]
    best_sequence: str
    headroom_rows: list[dict]
    ceiling: dict
    names: list[str]
    selector: StrategySelector


def measure(study: ExperienceStudy) -> dict:
    """Every step of the study, in order (the module's docstring); what the report shows."""
    union, sets = study.experience()
    som = train_experience_map(union.postures)
    types = np.concatenate([grasp_types_of(s) for s in sets.values()])
    som_types = reference_grasp_types(som, union.postures, types)
    preshapes = grasp_type_preshapes(sets)
    strategies = study.strategies(preshapes)
    chosen = _choose(study, strategies, preshapes, som)
    test, kept = _test_split(study, chosen, strategies, preshapes, som, (som_types, union, types, sets))
    # the claims again with the experience and the trials seeded anew, the choices of the selection split kept
    seeds = {0: {"best_sequence": test["best_sequence"], "som": test[chosen.tuned], "som_null": test["som_null"],
                 "regrasp_experience": test["regrasp_experience"], "regrasp_null": test["regrasp_null"]}}
    for k in range(1, study.config.seed_count):
        seeds[k] = replicate(study, k, chosen.best, chosen.tuned, chosen.sequences[chosen.best_sequence])
    comparisons, replication = _comparisons(study, test, seeds, chosen.tuned, kept)
    checks, verdict = _target(comparisons, test, chosen, replication)
    return _results(study, sets, som_types, chosen, test, kept, comparisons, checks, verdict, replication)


def _choose(study: ExperienceStudy, strategies: dict, preshapes: dict, som: SOM) -> _Choices:
    """The selection split: headroom before anything is compared, then the shared preshape, the SOM's variant, the
    best fixed two-attempt sequence, and the information ceiling of a selector."""
    selection = {m: study.evaluate("selection", m, preshape=p) for m, p in strategies.items()}
    best = max(strategies, key=lambda m: (rate(selection[m]), m))
    reruns = [study.evaluate("selection", f"{best}_rerun{k}", preshape=strategies[best], noise=JITTER, seed=k)
              for k in range(1, len(strategies))]

    def room(rows=None):
        outcomes = {m: pooled(selection[m], rows=rows) for m in strategies}
        return headroom({m: o for m, (o, _) in outcomes.items()}, {m: v for m, (_, v) in outcomes.items()},
                        reruns=[pooled(r, rows=rows)[0] for r in reruns])

    headroom_rows = []
    for rows, label in [(object_rows(o), o) for o in study.objects] + [(None, "pooled")]:
        h = room(rows)
        headroom_rows.append({"object": label, "n": h.n, "oracle": h.oracle, "best": h.best,
                              "best_successes": h.best_successes, "gain": h.gain, "neither": h.neither,
                              "chance_oracle": h.chance_oracle, "chance": h.chance, "beyond_chance": h.beyond_chance,
                              "sufficient": h.sufficient})
    shared = max(preshapes, key=lambda m: (rate(selection[m]), m))
    for name, params in SOM_VARIANTS.items():
        study.evaluate("selection", name, som, params=params)
    order = list(SOM_VARIANTS)  # on a tie the earlier variant wins
    tuned = max(order, key=lambda m: (rate(study.results[("selection", m)]), -order.index(m)))
    sequences = {f"sequence_{best}_{m}": m for m in strategies}
    for name, second in sequences.items():
        study.evaluate("selection", name, preshape=strategies[best], regrasp=sequence(strategies, second))
    best_sequence = max(sequences, key=lambda m: (rate(study.results[("selection", m)]), m))
    study.log(f"selected: best strategy {best}; shared preshape {shared}; SOM {tuned}; sequence {best_sequence}")
    # the information ceiling on the selection split: a cross-validated selector from the heuristic's first contact
    # (one attempt) and from what the best strategy's failed attempt sensed (the second attempt)
    names = [best] + [m for m in strategies if m != best]  # a tie goes to the best single strategy
    postures = np.array([np.full(N_FINGER_JOINTS, np.nan) if strategies[m] is None else strategies[m] for m in names])
    ceiling = {"once": information_ceiling(selection, names, "first_contact", headroom_rows[-1])}
    second = {m: study.results[("selection", f"sequence_{best}_{m}")] for m in names}
    ceiling["second attempt"] = information_ceiling(second, names, "failure", None)
    failed = _failed_poses(second[best])
    selector = StrategySelector(names, postures, seed=0).fit(_features(second[best], "failure")[failed],
                                                              _outcomes(second, names)[failed])
    return _Choices(selection, best, shared, tuned, sequences, best_sequence, headroom_rows, ceiling, names, selector)


def _test_split(study: ExperienceStudy, chosen: _Choices, strategies: dict, preshapes: dict, som: SOM,
                experience: tuple) -> tuple[dict, dict]:
    """The test split, touched once: every method chosen, the null experience, the covered poses, and the selector
    trained on the selection split picking per test pose (into `chosen.ceiling`) -> (runs by method, covered poses)."""
    som_types, union, types, sets = experience
    best, shared, tuned = chosen.best, chosen.shared, chosen.tuned
    test = {"none": study.evaluate("test", "none"), "shared_preshape": study.evaluate("test", shared, preshape=preshapes[shared])}
    for name, params in SOM_VARIANTS.items():
        test[name] = study.evaluate("test", name, som, params=params)
    test["heuristic_retried"] = study.evaluate("test", "heuristic_retried", regrasp=Regrasp(ATTEMPTS))
    test["best_sequence"] = study.evaluate("test", chosen.best_sequence, preshape=strategies[best],
                                           regrasp=sequence(strategies, chosen.sequences[chosen.best_sequence]))
    test["regrasp_experience"] = study.evaluate("test", f"regrasp_{tuned}", som, params=SOM_VARIANTS[tuned],
                                                regrasp=Regrasp(ATTEMPTS, grasp_types=som_types))
    test["regrasp_selector"] = study.evaluate("test", f"regrasp_selector_{best}", preshape=strategies[best],
                                              regrasp=Regrasp(ATTEMPTS, chooser=chosen.selector))
    # the null experience: the same map trained on the postures scrambled (no grasp left in it), the same controller
    null = train_experience_map(scrambled(union.postures, NULL_SEED))
    test["som_null"] = study.evaluate("test", f"{tuned}_null", null, params=SOM_VARIANTS[tuned])
    test["regrasp_null"] = study.evaluate("test", f"regrasp_{tuned}_null", null, params=SOM_VARIANTS[tuned],
                                          regrasp=Regrasp(ATTEMPTS, grasp_types=reference_grasp_types(
                                              null, union.postures, types)))
    # the paper's grid read honestly: the test poses a verified grasp of the experience holds the object near
    kept = {key: covered(OBJECTS[key[0]].object, np.array([t.grid_pose for t in result.trials]),
                         sets[key[0]].hand_poses) for key, result in test["none"].items()}
    # one attempt: the selector trained on the selection split picks per test pose from the heuristic's first contact
    for m in strategies:
        if m not in ("none", shared):
            test[m] = study.evaluate("test", m, preshape=strategies[m])
    names, selection = chosen.names, chosen.selection
    runs = {m: test["none"] if m == "none" else test["shared_preshape"] if m == shared else test[m] for m in names}
    once = StrategySelector(names, seed=0).fit(_features(selection["none"], "first_contact"), _outcomes(selection, names))
    picked = once.predict(_features(runs["none"], "first_contact"))
    held, valid = _outcomes(runs, names), _valid(runs, names).all(axis=1)
    chosen.ceiling["once, trained on the selection split, on the test split"] = {
        "n": int(valid.sum()), "selector": int(held[np.arange(len(held)), picked][valid].sum()),
        "best": int(held[valid].sum(axis=0).max()), "oracle": int(held[valid].any(axis=1).sum()), "chance_oracle": None,
        "picked": {m: int((picked[valid] == k).sum()) for k, m in enumerate(names)}}
    return test, kept


def _comparisons(study: ExperienceStudy, test: dict, seeds: dict, tuned: str, kept: dict) -> tuple[list, dict]:
    """The comparisons, each family corrected by Holm, and whether each replicated claim keeps its sign."""
    def family(a: str, b: str) -> list:
        return [("pooled", compare_pooled(test[a], test[b]))] + [(o, compare_pooled(test[a], test[b], object_rows(o)))
                                                          for o in study.objects]

    families = {
        "two attempts: regrasp with experience against the best fixed sequence (primary)":
            family("regrasp_experience", "best_sequence"),
        "one attempt: the paper's controller against the shared preshape": family("som_paper", "shared_preshape"),
        "other comparisons, pooled": [
            ("regrasp with experience against the regrasp selector",
             compare_pooled(test["regrasp_experience"], test["regrasp_selector"])),
            ("the regrasp selector against the best fixed sequence",
             compare_pooled(test["regrasp_selector"], test["best_sequence"])),
            ("regrasp with experience against the heuristic retried",
             compare_pooled(test["regrasp_experience"], test["heuristic_retried"])),
            ("the best fixed sequence against the heuristic retried",
             compare_pooled(test["best_sequence"], test["heuristic_retried"])),
            (f"regrasp with experience against its one attempt ({tuned})",
             compare_pooled(test["regrasp_experience"], test[tuned])),
            ("the heuristic retried against once", compare_pooled(test["heuristic_retried"], test["none"])),
            *((f"{m} against the shared preshape", compare_pooled(test[m], test["shared_preshape"]))
              for m in SOM_VARIANTS if m != "som_paper")],
        "sensitivity: every trial whose physics failed counted as a failed grasp, pooled": [
            (REGRASP_AS_FAILURES,
             compare_pooled(test["regrasp_experience"], test["best_sequence"], invalid="fail")),
            (PAPER_AS_FAILURES,
             compare_pooled(test["som_paper"], test["shared_preshape"], invalid="fail"))],
        "experience content: the map against the null map (the same controller), pooled": [
            (NULL_ONCE, compare_pooled(test[tuned], test["som_null"])),
            (NULL_REGRASP, compare_pooled(test["regrasp_experience"], test["regrasp_null"]))],
        "on the covered test poses only (a verified grasp holds the object near there), pooled": [
            (f"{label}, covered poses", compare_pooled(test[a], test[b], keep=kept)) for label, a, b in (
                ("regrasp with experience against the best fixed sequence", "regrasp_experience", "best_sequence"),
                ("the paper's controller against the shared preshape", "som_paper", "shared_preshape"),
                (NULL_ONCE, tuned, "som_null"), (NULL_REGRASP, "regrasp_experience", "regrasp_null"))]}
    if len(seeds) > 1:
        families[REPLICATIONS] = [(f"seed {k}: {label}", compare_pooled(runs[a], runs[b]))
                                  for k, runs in seeds.items() if k for label, (a, b) in REPLICATED.items()]
    comparisons = [row for name, tests in families.items() for row in holm_family(tests, name)]
    by_label = {c["label"]: c for c in comparisons}
    at_seed = {k: {label: by_label[f"seed {k}: {label}" if k else label] for label in REPLICATED if label != PRIMARY}
               for k in seeds}
    for k in seeds:
        at_seed[k][PRIMARY] = by_label[f"seed {k}: {PRIMARY}"] if k else next(
            c for c in comparisons if c["family"].endswith("(primary)") and c["label"] == "pooled")
    replication = {label: {"seeds": [at_seed[k][label] for k in seeds],
                           "sign_holds": len({np.sign(at_seed[k][label]["difference"]) for k in seeds} - {0.0}) == 1
                           and all(at_seed[k][label]["difference"] for k in seeds)}
                   for label in REPLICATED}
    return comparisons, replication


def _target(comparisons: list, test: dict, chosen: _Choices, replication: dict) -> tuple[dict, str]:
    """The target's checks and the verdict in words."""
    primary = [c for c in comparisons if c["family"].endswith("(primary)")]
    main = next(c for c in primary if c["label"] == "pooled")
    worse = [c["label"] for c in primary if c["label"] != "pooled" and c["p_holm"] < 0.05 and c["only_a"] < c["only_b"]]
    once = [c for c in comparisons if c["family"].startswith("one attempt")]
    once_main = next(c for c in once if c["label"] == "pooled")
    pooled_room = chosen.headroom_rows[-1]
    checks = {"headroom beyond chance": pooled_room["sufficient"], "poses": main["n"] >= TARGET_POSES,
              "points": main["difference"] >= TARGET_POINTS,
              "significant": main["p_holm"] < TARGET_P and main["only_a"] > main["only_b"],
              "no object worse": not worse}
    met = all(checks.values())
    rates = {m: rate(r) for m, r in test.items()}
    verdict = (f"Target {'met' if met else 'not met'}: with {ATTEMPTS} attempts, regrasp with experience holds "
               f"{rates['regrasp_experience']:.1%} on {main['n']} paired test poses against the best fixed sequence's "
               f"({chosen.best_sequence}) {rates['best_sequence']:.1%}, {100 * main['difference']:+.1f} points "
               f"(+{main['only_a']} / -{main['only_b']}, McNemar p = {main['p_value']:.2g}, Holm {main['p_holm']:.2g})"
               + (f", significantly worse on {', '.join(worse)}" if worse else ", significantly worse on no object")
               + f"; the heuristic retried holds {rates['heuristic_retried']:.1%}, once {rates['none']:.1%}. With one "
               f"attempt the paper's controller holds {rates['som_paper']:.1%} against the best shared preshape's "
               f"({chosen.shared}) {rates['shared_preshape']:.1%}, {100 * once_main['difference']:+.1f} points (McNemar "
               f"p = {once_main['p_value']:.2g}, Holm {once_main['p_holm']:.2g}). Headroom beyond chance on the "
               f"selection split {100 * pooled_room['beyond_chance']:.1f} points ("
               + ("enough for" if pooled_room["sufficient"] else "below")
               + f" the {100 * MIN_HEADROOM_BEYOND_CHANCE:.0f}-point gate)." + seeds_verdict(replication))
    return checks, verdict


def _results(study: ExperienceStudy, sets: dict, som_types: np.ndarray, chosen: _Choices, test: dict, kept: dict,
             comparisons: list, checks: dict, verdict: str, replication: dict) -> dict:
    """What the report shows, and study.json keeps."""
    by_placement = {m: {p: rate(test[m], [(o, p) for o in study.objects]) for p in PLACEMENTS}
                    for m in ("none", "shared_preshape", chosen.tuned, "heuristic_retried", "best_sequence",
                              "regrasp_experience")}
    attempts = {m: float(np.mean([t.attempts for r in test[m].values() for t in r.trials]))
                for m in ("heuristic_retried", "best_sequence", "regrasp_experience", "regrasp_selector")}
    return {"objects": list(study.objects), "quick": study.config.quick,
            "postures_per_object": study.config.postures_per_object,
            "split": {"selection_share": SELECTION_SHARE, "seed": SPLIT_SEED,
                      "poses": {k: sum(len(v) for key, v in d.items() if key[0] in study.objects)
                                for k, d in study.split.items()}},
            "experience": {n: {"postures": len(s), "candidates": s.metadata["candidates"],
                               "verified_by_start": s.metadata["verified_by_start"],
                               "kept_by_start": s.metadata["kept_by_start"],
                               "grasp_types": s.metadata["grasp_types"]} for n, s in sets.items()},
            "som_node_types": {t: int((som_types == t).sum()) for t in sorted(set(som_types))},
            "selected": {"best": chosen.best, "shared": chosen.shared, "som": chosen.tuned,
                         "sequence": chosen.best_sequence},
            "selection_rates": {m: rate(r) for (split, m), r in study.results.items() if split == "selection"},
            "headroom": chosen.headroom_rows, "ceiling": chosen.ceiling, "comparisons": comparisons, "checks": checks,
            "target_met": all(checks.values()), "verdict": verdict, "by_placement": by_placement,
            "mean_attempts": attempts,
            "counts": {m: {f"{o}/{p}": [int(r[(o, p)].outcomes()[r[(o, p)].valid].sum()), int(r[(o, p)].valid.sum())]
                           for (o, p) in r} for m, r in test.items()},
            "coverage": {"within": COVERED_WITHIN, "angle": COVERED_ANGLE,
                         "by_object": {o: [int(sum(kept[key].sum() for key in object_rows(o) if key in kept)),
                                           int(sum(len(kept[key]) for key in object_rows(o) if key in kept))]
                                       for o in study.objects}},
            "covered_counts": {m: [int(h[v].sum()), int(v.sum())] for m, (h, v) in
                               ((m, pooled(r, keep=kept)) for m, r in test.items())},
            "replication": replication,
            "seconds": study.evaluation_seconds, "wall_seconds": time.perf_counter() - study.started,
            "workers": study.workers, "reused": study.reused_evaluations, "evaluations": study.evaluations,
            "made_seconds": sum(study.made_seconds.values())}


def seeds_verdict(replication: dict) -> str:
    """The verdict's sentence on the seeds: each replicated claim's difference per seed and whether its sign held on
    every one ('' for a run of one seed)."""
    if not replication or len(next(iter(replication.values()))["seeds"]) < 2:
        return ""
    count = len(next(iter(replication.values()))["seeds"])
    return f" Over {count} seeds of the experience and the trials (a claim needs its sign on every one): " + "; ".join(
        f"{label} " + " / ".join(f"{100 * c['difference']:+.1f}" for c in r["seeds"]) + " points ("
        + ("the sign holds" if r["sign_holds"] else "the sign does not hold") + ", Holm p "
        + " / ".join(f"{c['p_holm']:.2g}" for c in r["seeds"]) + ")" for label, r in replication.items()) + "."


def reading(info: dict) -> list[str]:
    """What the numbers say, one point each, from the study's comparisons and ceiling."""
    by_label = {c["label"]: c for c in info["comparisons"]}

    def said(label: str) -> str:
        c = by_label[label]
        return (f"{100 * c['difference']:+.1f} points (n = {c['n']}, +{c['only_a']} / -{c['only_b']}, Holm p = "
                f"{c['p_holm']:.2g})")

    once = info["ceiling"]["once"]
    top = once["oracle"] - once["chance_oracle"] if once["chance_oracle"] is not None else 0
    invalid = {m: sum(c[1] for c in counts.values()) for m, counts in info["counts"].items()}
    # every test pose run (a quick run runs a sixth); a study.json from before the sensitivity family has no such row
    sensitivity = REGRASP_AS_FAILURES in by_label
    poses = by_label[REGRASP_AS_FAILURES]["n"] if sensitivity else info["split"]["poses"]["test"]
    content = ([f"- Experience content: the selected SOM controller with its map against the same controller with "
                f"the null map (each joint column permuted, no grasp left) {said(NULL_ONCE)}; regrasp with experience "
                f"against regrasp with the null map {said(NULL_REGRASP)}."] if NULL_ONCE in by_label else [])
    return content + [
        f"- A second attempt is what pays: the heuristic retried against once {said('the heuristic retried against once')}"
        f"; regrasp with experience against its own first attempt "
        f"{said(next(k for k in by_label if k.startswith('regrasp with experience against its one attempt')))}.",
        f"- What experience adds to the retry is small: regrasp with experience against the heuristic retried "
        f"{said('regrasp with experience against the heuristic retried')}; against the regrasp selector "
        f"{said('regrasp with experience against the regrasp selector')}; the best fixed sequence against the "
        f"heuristic retried {said('the best fixed sequence against the heuristic retried')}.",
        f"- Little of the headroom is predictable from what the controller senses: from the first contact the "
        f"cross-validated selector holds {once['selector']} of {once['n']} selection poses against the best single "
        f"strategy's {once['best']}" + (f", {(once['selector'] - once['best']) / top:.0%} of the headroom beyond chance"
                                       if top > 0 else "") + "; from a failed attempt it does no better than the "
        "best second strategy (the ceiling table).",
        ("- No trial's physics failed." if not any(poses - v for v in invalid.values()) else
         f"- Trials whose physics failed (a contact deeper than 5 mm) are left out of every pair: at most "
         f"{max(poses - v for v in invalid.values())} of {poses} test poses for a method ("
         + ", ".join(f"{m} {poses - v}" for m, v in invalid.items() if poses - v) + ")."
         ) + (" Counted as failed grasps (the sensitivity family), regrasp with experience against the best fixed "
              f"sequence {said(REGRASP_AS_FAILURES)}; the paper's controller against the shared preshape "
              f"{said(PAPER_AS_FAILURES)}." if sensitivity else ""),
    ]


def report(config: ExperienceStudyConfig, info: dict) -> str:
    """The markdown report of a run (`info`: what `measure` returned, or study.json)."""
    lines = [*_report_opening(config, info), *_report_seeds(info), *_report_split_and_headroom(config, info),
             *_report_ceiling_and_selection(info), *_report_rates(info), *_report_benchmark(info),
             *_report_later_studies()]
    return "\n".join(lines) + "\n"


def _report_opening(config: ExperienceStudyConfig, info: dict) -> list[str]:
    """The title, what made the run, the verdict, the target and the reading."""
    lines = ["# Does experience pay where grasp choice matters? The experience study", ""]
    if config.quick:
        lines += ["**A smoke run: too small to be evidence.** Two objects and a sixth of the poses, to check that the "
                  "study runs; its rates and tests say nothing about the methods.", ""]
    lines += [f"Generated by `python scripts/study_experience.py{' --quick' if config.quick else ''} --workers "
              f"{info.get('workers', config.workers)}`: " + (
                  f"the run took {info['wall_seconds']:.0f} s, {info['seconds']:.0f} s of it evaluations ("
                  f"{info['reused']} of {info['evaluations']} evaluations were taken from an earlier run in --out, "
                  "their time not counted)" if "made_seconds" not in info or not info["reused"] else
                  f"its evaluations took {info['made_seconds']:.0f} s when they ran ({info['reused']} of "
                  f"{info['evaluations']} of them in an earlier run, kept in --out); this run took "
                  f"{info['wall_seconds']:.0f} s") + ". Every "
              "rate is the hold test (gravity along six directions, the object within 2 cm) with its 95 % Wilson "
              "interval; comparisons are paired on the same poses (McNemar's exact test) and corrected within their "
              "family (Holm).", "", "## Verdict", "", info["verdict"], "",
              f"Target (issue 38): with a budget of {ATTEMPTS} attempts, regrasp with experience holds at least "
              f"{100 * TARGET_POINTS:.0f} points more than the best fixed {ATTEMPTS}-attempt sequence chosen on the "
              f"selection split, pooled over at least {TARGET_POSES} paired test poses, Holm-adjusted McNemar p < "
              f"{TARGET_P}, and significantly worse on no object; on a benchmark with at least "
              f"{100 * MIN_HEADROOM_BEYOND_CHANCE:.0f} points of headroom beyond chance. Checks: " + ", ".join(
                  f"{k} {'yes' if v else 'no'}" for k, v in info["checks"].items()) + ".", ""]
    lines += ["## Reading", "", *reading(info), ""]
    return lines


def _report_seeds(info: dict) -> list[str]:
    """The claims at every seed (none for one seed)."""
    lines: list[str] = []
    if len(next(iter(info.get("replication", {}).values()), {"seeds": []})["seeds"]) > 1:
        count = len(next(iter(info["replication"].values()))["seeds"])
        lines += ["## Seeds", "",
                  "The claims again with the whole experience made anew ("
                  + ("seed 1" if count == 2 else f"seeds 1 ... {count - 1}") + " of the generator, the "
                  "map, the null map's permutation and the trials; seed 0 is the study above), the choices seed 0's "
                  "selection split made kept, on the same test poses. A claim is made only where its sign holds on "
                  "every seed. Difference in points (+ / - pairs, Holm p within the family of the further seeds; "
                  "seed 0's within its own family).", ""]
        lines += markdown_table(["claim", *(f"seed {k}" for k in range(count)), "sign holds"], [
            [label, *(f"{100 * c['difference']:+.1f} (+{c['only_a']} / -{c['only_b']}, {c['p_holm']:.2g})"
                      for c in r["seeds"]), "yes" if r["sign_holds"] else "no"]
            for label, r in info["replication"].items()])
        lines += [""]
    return lines


def _report_split_and_headroom(config: ExperienceStudyConfig, info: dict) -> list[str]:
    """The split and the headroom on the selection split."""
    lines: list[str] = []
    split = info["split"]
    lines += ["## The split", "",
              f"All the benchmark's poses (the lattice and its midpoints), split at random, stratified by object and "
              f"placement (`benchmark.benchmark_split({split['selection_share']:.3g}, seed={split['seed']})`): "
              f"{split['poses']['selection']} selection poses, {split['poses']['test']} test poses"
              + (" (every sixth of them run here)" if config.quick else "") + ". Every choice below was made on the "
              "selection split; the test split ran once.", ""]
    lines += ["## Headroom (selection split)", "",
              "The per-pose oracle over the strategies (the plain heuristic and one constant preshape per grasp type) "
              "against the best single one, and the chance oracle over as many runs of the best strategy (its own and "
              "reruns with 1 mm / 0.02 rad pose noise): what that many draws of noise give. The reruns are of the "
              "pooled best strategy, so an object whose own best is another has no chance oracle (-). Only the headroom "
              "beyond chance can be reached by choosing (`stats.headroom`).", ""]
    rerun = info["headroom"][-1]["best"]

    def room_row(h: dict) -> list:
        chance, beyond = ((rate_text(h["chance_oracle"], h["n"]), f"**{100 * h['beyond_chance']:+.1f} pts**")
                          if h["best"] == rerun else ("-", "-"))
        return [h["object"], h["n"], rate_text(h["oracle"], h["n"]), f"{h['best']} {rate_text(h['best_successes'], h['n'])}",
                rate_text(h["gain"], h["n"]), chance, beyond, h["neither"]]

    lines += markdown_table(["object", "n", "oracle", "best strategy", "headroom", "chance oracle", "beyond chance",
                             "held by none"], [room_row(h) for h in info["headroom"]])
    return lines


def _report_ceiling_and_selection(info: dict) -> list[str]:
    """The information ceiling and what the selection split chose."""
    lines: list[str] = []
    selected = info["selected"]
    lines += ["", "## The information ceiling", "",
              "How much of the headroom can what the controller senses predict? A selector (`trials.selector`: a "
              "random forest per strategy's success, scikit-learn) picks a strategy per pose from the heuristic's "
              "first contact (time, joints, segment forces: `Trial.first_contact`), or, for the second attempt, from "
              "what the best strategy's failed attempt sensed when its probe failed (joints, segment forces: "
              "`Trial.failure`); on the selection split each pose is picked by a model trained on the other four "
              "folds; on the test split by the model trained on the selection split. The pick's outcome is that "
              "strategy's run from the start on the pose (for the first contact an upper estimate: a controller "
              "switching at the first contact would start the heuristic's way). Captured: (selector - best) / "
              "(oracle - chance oracle), the share of the headroom beyond chance; without a chance oracle, of the "
              "headroom.", ""]

    def ceiling_row(label: str, c: dict) -> list:
        top = c["oracle"] - (c["chance_oracle"] if c["chance_oracle"] is not None else c["best"])
        return [label, c["n"], rate_text(c["best"], c["n"]), rate_text(c["selector"], c["n"]),
                rate_text(c["oracle"], c["n"]), "-" if c["chance_oracle"] is None else rate_text(c["chance_oracle"], c["n"]),
                f"{(c['selector'] - c['best']) / top:.0%}" if top > 0 else "no headroom"]

    lines += markdown_table(["information", "n", "best single", "selector", "oracle", "chance oracle", "captured"],
                            [ceiling_row(label, c) for label, c in info["ceiling"].items()])
    lines += ["", "## Selection (selection split only)", ""]
    lines += markdown_table(["method", "pooled hold on the selection split"],
                            [[m, f"{r:.1%}"] for m, r in info["selection_rates"].items()])
    lines += ["", f"Chosen before the test: best single strategy **{selected['best']}**; shared preshape "
              f"**{selected['shared']}**; SOM controller **{selected['som']}** ({SOM_DESCRIPTIONS[selected['som']]}); "
              f"best fixed sequence **{selected['sequence']}** (the best strategy first, then the best second attempt "
              "after it: a greedy choice among the strategies, not all pairs).", ""]
    return lines


def _report_rates(info: dict) -> list[str]:
    """The hold rates on the test split, the coverage, and the paired comparisons."""
    lines: list[str] = []
    lines += ["## Hold rate per method (test split)", ""]
    keys = list(info["counts"]["none"])
    lines += markdown_table(["method", *keys, "pooled"], [
        [m, *(rate_text(*counts[k]) for k in keys),
         rate_text(sum(c[0] for c in counts.values()), sum(c[1] for c in counts.values()))]
        for m, counts in info["counts"].items()])
    lines += ["", "Mean attempts made: " + ", ".join(f"{m} {a:.2f}" for m, a in info["mean_attempts"].items())
              + ". Hold rate by placement, pooled over the objects: " + "; ".join(
                  f"{m} " + " / ".join(f"{p} {r:.0%}" for p, r in v.items()) for m, v in info["by_placement"].items())
              + ".", ""]
    if "coverage" in info:  # a study.json from before issue 65 has none
        cover = info["coverage"]
        total = [sum(c[k] for c in cover["by_object"].values()) for k in (0, 1)]
        lines += ["## Coverage: the test poses a verified grasp holds the object near", "",
                  f"A test pose is covered where one of its object's verified grasps of the experience holds the "
                  f"object's centre within {100 * cover['within']:.0f} cm of where the pose puts it, seen from the "
                  f"palm, its long axis within {np.degrees(cover['angle']):.0f} degrees (`grid.covered`): there a "
                  "recall can place a verified grasp without the palm moving; elsewhere no finger posture alone can. "
                  f"Covered: {total[0]} of {total[1]} test poses (" + ", ".join(
                      f"{o} {c[0]}/{c[1]}" for o, c in cover["by_object"].items()) + ").", ""]
        lines += markdown_table(["method", "all test poses", "covered poses"], [
            [m, rate_text(sum(c[0] for c in info["counts"][m].values()), sum(c[1] for c in info["counts"][m].values())),
             rate_text(*info["covered_counts"][m])] for m in info["counts"]])
        lines += ["", "Their paired comparisons are the family \"on the covered test poses only\" below.", ""]
    lines += ["## Paired comparisons (test split)", "",
              "`+` / `-`: poses where only the first / only the second method held. Holm's correction within each "
              "family.", "", *comparison_table(info["comparisons"], family=True)]
    return lines


def _report_benchmark(info: dict) -> list[str]:
    """The benchmark's objects and the experience made on them."""
    lines: list[str] = []
    lines += ["", "## The benchmark and its experience", "",
              "Objects (`graspmanifold.trials.benchmark.OBJECTS`), each chosen for a reason stated before any method "
              "ran on it; the controller is never told the object.", ""]
    lines += markdown_table(["object", "size", "mass", "asks for", "why"], [
        [name, " x ".join(f"{100 * 2 * h:.1f}" for h in OBJECTS[name].object.half_extents) + " cm",
         f"{OBJECTS[name].object.mass * 1000:.0f} g", OBJECTS[name].grasp, OBJECTS[name].reason]
        for name in info["objects"]])
    lines += ["", f"{info['postures_per_object']} verified postures per object (`generate_postures(obj, n)`, the "
              "defaults: every grasp type), all objects in one set, one 25 x 25 SOM; its nodes by grasp type (of the "
              "nearest posture): " + ", ".join(f"{t} {k}" for t, k in info["som_node_types"].items()) + ". Verified "
              "share of the candidates per starting design (kept postures in brackets):", ""]
    lines += markdown_table(["object", "candidates", "verified share by design (kept)"], [
        [name, e["candidates"], ", ".join(f"{d} ({e['grasp_types'][d]}) {v:.0%} ({e['kept_by_start'].get(d, 0)})"
                                          for d, v in e["verified_by_start"].items())]
        for name, e in info["experience"].items()])
    return lines


def _report_later_studies() -> list[str]:
    """The later studies' verdicts and the first study's, quoted from their reports."""
    lines: list[str] = []
    lines += ["", "## Under pose error, and with more experience", ""]
    for name, command, what in (("uncertainty_study", "study_uncertainty.py", "the object off the pose the plan "
                                 "assumed: the tactile controllers against the open-loop replay of the nominal grasp"),
                                ("learning_curve", "study_learning_curve.py", "hold rate against the experience's size "
                                 "and against rounds of the controller's own grasps")):
        later = Path(f"docs/studies/{name}.md")
        if later.exists():  # its verdict and its figure, quoted from its report
            verdict = later.read_text().split("## Verdict", 1)[-1].split("\n## ", 1)[0].strip()
            lines += [f"`python scripts/{command}` ([its report]({name}.md)): {what}.", "", verdict.split("\n\n")[0],
                      "", f"![{name}]({name}.png)", ""]
        else:
            lines += [f"`python scripts/{command}` ({what}) has not been run here.", ""]
    lines += ["## The first study, on the paper's grids", ""]
    old = Path("docs/studies/experience_study_paper_grids.md")
    if old.exists():  # its verdict and its headroom table, quoted from its report
        text = old.read_text()
        sections = {part.split("\n", 1)[0]: part.split("\n", 1)[1].strip() for part in text.split("\n## ")[1:]}
        lines += ["`python scripts/study_experience_paper_grids.py` ([its report](experience_study_paper_grids.md)), on "
                  "the paper's three objects and its grids (paper, far, hard, paper with pose noise), each object "
                  "with its own experience. Its verdict:", "", sections.get("Verdict", "(none)"), ""]
        if "Headroom" in sections:
            lines += ["Its headroom (added when the study was rerun for this report):", "", sections["Headroom"], ""]
    else:
        lines += ["Not run here (`python scripts/study_experience_paper_grids.py` writes "
                  "`docs/studies/experience_study_paper_grids.md`).", ""]
    return lines


if __name__ == "__main__":
    main()
