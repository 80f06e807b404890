"""The learning curve: does the hold rate grow with the experience, generated and the controller's own?

    python scripts/study_learning_curve.py [--quick] [--workers 2] [--seeds 3] [--sizes 12 36 108] [--rounds 1]
                                           [--controllers som_paper som_approach] [--out study-learning]
                                           [--doc docs/studies/learning_curve.md]

On the experience study's benchmark and split (`studies.experience`), once per seed (`--seeds`, default 3: seeds 0,
1, 2 of the generator, the maps, the subsets and the trials): the experience of every grasp type is generated at the
largest size (`--sizes`, verified postures per object, default 12, 36 and 108); an experience of a smaller size is a
random subset of it (seeded, the same objects' shares). For each size, one SOM is trained on all objects' postures and
the controllers (`--controllers`, default the paper's literal controller and the approach execution of issue 65, whose
ceiling the planned-grasp study measures; `CONTROLLERS` has the blend and regrasp with experience too) run on the test
split; at the largest size each also with the null experience (the postures scrambled, each joint column permuted),
and at every size on the test poses it covers (`grid.covered`). Then the paper's resumed learning, from the smallest
experience: each round the blend grasps every pose of the selection split, the final postures of the grasps that held
(the sensed joints when the grasp was done: `EvaluationResult.successful_postures`) join the experience, and the map
is trained again; after every round the controllers run on the test split. Nothing of the test split ever joins the
experience.

The comparisons (McNemar on the trials of every seed pooled, Holm within the family), per controller: the largest
experience against the smallest, against the null map of as many, and the last round against the smallest; each also
per seed, and a difference is claimed only where its sign holds on every seed. Writes `--out/study.json`, the report
`--doc` and its figure beside it. The default (three seeds, sizes to 108) keeps the study within 45 minutes on two
cores; `--sizes 48 200 1000 --rounds 2 --seeds 1 --controllers som_paper som_blend regrasp_som_blend som_approach`
is the one-seed curve of issues 51 and 65 (about an hour).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..base.config_files import read_config
from ..base.errors import InvalidInput
from ..base.io import markdown_table, read_json, write_text_atomic
from ..base.validation import check_int
from ..control.controller import APPROACH, BLEND, ControllerParams
from ..control.regrasp import Regrasp, grasp_types_of, reference_grasp_types
from ..manifold.experience import scrambled
from ..manifold.postureset import PostureSet
from ..synthesis.generator import MAX_POSTURES
from ..trials.benchmark import OBJECTS, cells, compare_pooled, pooled
from ..trials.experience_pays import train_experience_map
from ..trials.grid import covered
from ..trials.stats import mcnemar, rate_text
from .experience_study import ATTEMPTS, ExperienceStudy, ExperienceStudyConfig
from .runner import comparison_table, holm_family, rate_curve, run_command, save_figure, study_config

#: the target (issue 51): the largest experience holds significantly more than the smallest for some controller
TARGET_P = 0.01
#: the planned-grasp study's report, whose perfect recall is the curve's ceiling (`ceiling`)
PLANNED_REPORT = Path("docs/studies/planned_grasps.json")
#: the arms of the planned-grasp study the ceiling quotes: a perfect recall with the approach execution (the
#: curve's som_approach told the very verified grasp), and the plan replayed open loop
CEILING_ARMS = ("approach-recall", "open-loop")
#: the displacements the ceiling quotes (m): every plan at its own palm pose, and the plans 1 cm off it (a covered
#: pose's reach)
CEILING_LEVELS = (0.0, 0.01)
#: the controllers the curve can run: label -> (parameters, with a regrasp of two attempts)
CONTROLLERS: dict[str, tuple[ControllerParams, bool]] = {
    "som_paper": (ControllerParams(), False), "som_blend": (BLEND, False), "regrasp_som_blend": (BLEND, True),
    "som_approach": (APPROACH, False)}
#: the controllers run by default: the paper's literal one, and the approach execution whose perfect recall is the
#: curve's ceiling (the blend and regrasp with experience are the experience study's)
DEFAULT_CONTROLLERS = ("som_paper", "som_approach")


@dataclass(frozen=True)
class LearningCurveConfig(ExperienceStudyConfig):
    """How the learning-curve study runs (a TOML file of these keys: `--config`).

    Args:
        quick: a smoke run: two objects, a sixth of the poses, sizes 3 and 7, one round, two seeds (too small to be
            evidence).
        workers: worker processes.
        out: the folder of kept results ('': study-learning, or study-learning-quick).
        doc: the markdown report ('': docs/studies/learning_curve.md, or OUT/learning_curve.md for a quick run).
        postures: unused (the largest of `sizes` is generated).
        seeds: seeds of the whole curve (generator, maps, subsets, trials): the study runs once per seed 0 ... seeds-1
            (0: 3, or 2 for a quick run).
        sizes: verified postures per object, ascending (empty: 12, 36, 108; quick: 3, 7).
        rounds: rounds of the controller's own grasps on the selection split (-1: 1).
        controllers: the curve's controllers, names of `CONTROLLERS` (empty: `DEFAULT_CONTROLLERS`).
    """

    FOLDER: ClassVar[str] = "study-learning"
    REPORT: ClassVar[str] = "learning_curve"

    sizes: tuple[int, ...] = field(default_factory=tuple)
    rounds: int = -1
    controllers: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        super().__post_init__()
        sizes = tuple(self.sizes)
        if any(isinstance(n, bool) or not isinstance(n, int) or not 0 < n <= MAX_POSTURES for n in sizes) \
                or list(sizes) != sorted(set(sizes)):
            raise InvalidInput(f"sizes must be ascending postures per object in 1 ... {MAX_POSTURES}, got {self.sizes!r}")
        object.__setattr__(self, "sizes", sizes)
        if self.rounds != -1:
            check_int(self.rounds, "rounds", low=0)
        names = tuple(self.controllers)
        if any(name not in CONTROLLERS for name in names) or len(set(names)) != len(names):
            raise InvalidInput(f"controllers must be distinct names of {sorted(CONTROLLERS)}, got {self.controllers!r}")
        object.__setattr__(self, "controllers", names)

    @property
    def experience_sizes(self) -> tuple[int, ...]:
        """Verified postures per object of each experience."""
        return self.sizes or ((3, 7) if self.quick else (12, 36, 108))

    @property
    def postures_per_object(self) -> int:
        """The largest size: what is generated."""
        return self.experience_sizes[-1]

    @property
    def own_rounds(self) -> int:
        """Rounds of the controller's own grasps."""
        return self.rounds if self.rounds != -1 else 1

    @property
    def curve_controllers(self) -> tuple[str, ...]:
        """The controllers run."""
        return self.controllers or DEFAULT_CONTROLLERS


def subset(sets: dict[str, PostureSet], n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """n postures of each object's set, drawn at random (seeded by the seed and n), and their grasp types.

    Args:
        sets: {object: verified postures}, each of at least n.
        n: postures per object.
        seed: the curve's seed.

    Returns:
        (postures (m, 22) rad, grasp types (m,)), objects in the order of `sets`.
    """
    rows, types = [], []
    for postures in sets.values():
        keep = _drawn(postures, n, seed)
        rows.append(postures.postures[keep])
        types.append(grasp_types_of(postures)[keep])
    return np.concatenate(rows), np.concatenate(types)


def _drawn(postures: PostureSet, n: int, seed: int) -> np.ndarray:
    """The rows of a set an experience of n postures per object keeps (seeded by the seed and n), in order."""
    return np.sort(np.random.default_rng([seed, n]).choice(len(postures), size=min(n, len(postures)), replace=False))


def covered_poses(sets: dict[str, PostureSet], n: int, results: dict,
                  seed: int = 0) -> dict[tuple[str, str], np.ndarray]:
    """Which trials of a benchmark run the experience of n postures per object covers (`grid.covered`: one of the
    object's verified grasps kept holds it within 1 cm of where the pose puts it).

    Args:
        sets: {object: verified postures}.
        n: postures per object (`subset`'s draw).
        results: {(object, placement): EvaluationResult}.
        seed: the curve's seed (`subset`'s draw).

    Returns:
        {(object, placement): (trials,) bool}.
    """
    return {key: covered(OBJECTS[key[0]].object, np.array([t.grid_pose for t in result.trials]),
                         sets[key[0]].hand_poses[_drawn(sets[key[0]], n, seed)]) for key, result in results.items()}


def own_grasps(results: dict) -> np.ndarray:
    """The held final grasps of a benchmark run: what a round adds to the experience.

    Args:
        results: {(object, placement): EvaluationResult}.

    Returns:
        (m, 22) rad, in `cells()` order.
    """
    return np.concatenate([results[key].successful_postures() for key in cells() if key in results])


class LearningCurveStudy(ExperienceStudy):
    """The learning-curve study (the module's docstring says what it measures); `run` runs it.

    Args:
        config: how it runs.
    """

    def __init__(self, config: LearningCurveConfig = LearningCurveConfig()):
        super().__init__(config)
        self.config: LearningCurveConfig = config

    def test(self, tag: str, postures: np.ndarray, types: np.ndarray, seed: int = 0,
             trained_on: np.ndarray | None = None) -> dict[str, dict]:
        """The curve's controllers on the test split with one experience.

        Args:
            tag: names the runs' files (`<controller>_<tag>`).
            postures: the experience (m, 22) rad; its first len(types) rows are the generated ones.
            types: the grasp types of the generated rows (own grasps carry no design's type).
            seed: the map's and the trials' seed.
            trained_on: the postures the SOM is trained on instead of `postures` (the null map's scrambled ones).

        Returns:
            {controller: {(object, placement): EvaluationResult}}.
        """
        som = train_experience_map(postures if trained_on is None else trained_on, seed)
        som_types = reference_grasp_types(som, postures[:len(types)], types)
        runs = {}
        for name in self.config.curve_controllers:
            params, retry = CONTROLLERS[name]
            runs[name] = self.evaluate("test", f"{name}_{tag}", som, params=params, seed=seed,
                                       regrasp=Regrasp(ATTEMPTS, grasp_types=som_types) if retry else None)
        return runs

    def measure(self) -> dict:
        """Every step of the study, in order (the module's docstring)."""
        return measure(self)

    def report(self, info: dict) -> str:
        """The markdown report of what `measure` returned."""
        return report(self.config, info)

    def figure(self, info: dict, path: Path) -> str:
        """Draws the report's figure (`plot`); returns its file's name."""
        return plot(info, path)


def measure_seed(study: LearningCurveStudy, seed: int) -> dict:
    """The curve of one seed: the generator, the maps, the subsets and the trials seeded with it.

    Args:
        study: the study (its folder keeps the runs; a seed other than 0 names them `..._seed<k>`).
        seed: the seed.

    Returns:
        {"by_size": {n: runs}, "by_round": {round: runs}, "null": runs, "covered": {n: {cell: (trials,) bool}},
        "added": [held grasps per round]}, each runs {controller: {(object, placement): EvaluationResult}}.
    """
    tag = f"_seed{seed}" if seed else ""
    _, sets = study.experience(seed)
    sizes = study.config.experience_sizes
    by_size = {n: study.test(f"n{n}{tag}", *subset(sets, n, seed), seed) for n in sizes}
    grown, types = subset(sets, sizes[0], seed)
    by_round, added = {0: by_size[sizes[0]]}, []
    for r in range(1, study.config.own_rounds + 1):
        selection = study.evaluate("selection", f"own_round{r}{tag}", train_experience_map(grown, seed), params=BLEND,
                                   seed=seed)
        held = own_grasps(selection)
        added.append(len(held))
        grown = np.concatenate([grown, held])
        study.log(f"seed {seed}, round {r}: {len(held)} held grasps of the selection split join the experience "
                  f"({len(grown)})")
        by_round[r] = study.test(f"n{sizes[0]}_round{r}{tag}", grown, types, seed)
    largest, largest_types = subset(sets, sizes[-1], seed)  # the null experience: scrambled, the same training
    null = study.test(f"n{sizes[-1]}_null{tag}", largest, largest_types, seed, trained_on=scrambled(largest, seed))
    first = study.config.curve_controllers[0]
    return {"by_size": by_size, "by_round": by_round, "null": null, "added": added,
            "covered": {n: covered_poses(sets, n, by_size[n][first], seed) for n in sizes}}


def _pooled(runs: list[dict], keeps: list[dict] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(held, valid) of the trials of one controller's runs of every seed, concatenated."""
    parts = ([pooled(r) for r in runs] if keeps is None else
             [pooled(r, keep=k) for r, k in zip(runs, keeps)])
    return np.concatenate([h for h, _ in parts]), np.concatenate([v for _, v in parts])


def _counts(runs: list[dict], keeps: list[dict] | None = None) -> list[int]:
    """[held, valid trials] of one controller's runs of every seed."""
    held, valid = _pooled(runs, keeps)
    return [int(held[valid].sum()), int(valid.sum())]


def measure(study: LearningCurveStudy) -> dict:
    """Every step of the study, in order (the module's docstring); what the report shows."""
    config = study.config
    seeds = list(range(config.seed_count))
    curves = [measure_seed(study, seed) for seed in seeds]
    sizes, names, last = config.experience_sizes, config.curve_controllers, config.own_rounds

    def runs(part: str, key: object, name: str) -> list[dict]:
        return [c[part][name] if key is None else c[part][key][name] for c in curves]

    claims = []  # (label, a's runs per seed, b's runs per seed)
    for name in names:
        claims.append((f"{name}: {sizes[-1]} against {sizes[0]} per object",
                       runs("by_size", sizes[-1], name), runs("by_size", sizes[0], name)))
        claims.append((f"{name}: {sizes[-1]} per object against the null map of as many",
                       runs("by_size", sizes[-1], name), runs("null", None, name)))
        if last:
            claims.append((f"{name}: round {last} of own grasps against {sizes[0]} per object",
                           runs("by_round", last, name), runs("by_size", sizes[0], name)))
    family = []
    for label, a, b in claims:
        (held_a, valid_a), (held_b, valid_b) = _pooled(a), _pooled(b)
        family.append((label, mcnemar(held_a, held_b, valid=valid_a & valid_b)))
    comparisons = holm_family(family, f"the largest experience, the null map and the grown one, {len(seeds)} seeds "
                                      "pooled")
    for row, (_, a, b) in zip(comparisons, claims):
        row["seeds"] = [compare_pooled(x, y).difference for x, y in zip(a, b)]
        row["sign_holds"] = len(set(np.sign(row["seeds"])) - {0.0}) == 1 and all(row["seeds"])

    def claimed(row: dict, level: float) -> bool:
        return row["p_holm"] < level and row["difference"] > 0 and row["sign_holds"]

    rises = [c for c in comparisons if " per object" in c["label"] and "round" not in c["label"]
             and "null" not in c["label"] and claimed(c, TARGET_P)]
    own = [c for c in comparisons if "round" in c["label"] and claimed(c, 0.05)]
    verdict = (f"Target {'met' if rises else 'not met'} (a rise needs Holm p < {TARGET_P} pooled over the "
               f"{len(seeds)} seeds and its sign on every seed): " + "; ".join(
                   f"{c['label']} {100 * c['difference']:+.1f} points (n = {c['n']}, Holm p = {c['p_holm']:.2g}; by "
                   "seed " + " / ".join(f"{100 * d:+.1f}" for d in c["seeds"]) + ")" for c in comparisons)
               + f". Own grasps add significantly for {len(own)} of {len(names)} controllers.")
    kept = {n: [c["covered"][n] for c in curves] for n in sizes}
    return {"objects": list(study.objects), "quick": config.quick, "seeds": seeds, "sizes": list(sizes),
            "rounds": last, "controllers": list(names), "added": [c["added"] for c in curves],
            "by_size": {str(n): {m: _counts(runs("by_size", n, m)) for m in names} for n in sizes},
            "by_round": {str(r): {m: _counts(runs("by_round", r, m)) for m in names} for r in range(last + 1)},
            "null": {m: _counts(runs("null", None, m)) for m in names},
            "covered": {str(n): {"poses": [int(sum(k.sum() for keep in kept[n] for k in keep.values())),
                                           int(sum(len(k) for keep in kept[n] for k in keep.values()))],
                                 **{m: _counts(runs("by_size", n, m), kept[n]) for m in names}} for n in sizes},
            "comparisons": comparisons, "target_met": bool(rises), "verdict": verdict,
            "wall_seconds": time.perf_counter() - study.started, "workers": study.workers}


def ceiling(path: Path = PLANNED_REPORT) -> dict | None:
    """What no experience can beat: the planned-grasp study's perfect recall (the approach execution told the very
    verified grasp, the palm where the grasp puts it) and the open loop, at 0 and 1 cm, quoted from its report.

    Args:
        path: the planned-grasp study's JSON (`scripts/study_planned_grasps.py` writes it).

    Returns:
        {"levels": [m], arm: [[held, trials] per level]} or None where that study has not run.
    """
    if not path.exists():
        return None
    planned = read_json(path, "the planned-grasp study's JSON")
    index = planned["levels"].index(CEILING_LEVELS[1])  # at 0 cm every plan ran (its ceiling), displaced a few
    return {"levels": list(CEILING_LEVELS), "seeds": planned["config"]["seeds"],
            **{arm: [planned["ceiling"][arm], planned["by_level"][arm][index]] for arm in CEILING_ARMS}}


def plot(info: dict, path: Path) -> str:
    """Hold rate against experience size and against rounds, per controller, 95 % Wilson intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(9, 3.8), sharey=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (key, xlabel) in zip(axes, (("by_size", "verified postures per object"), ("by_round", "rounds of own grasps"))):
        xs = list(info[key])
        for color, name in zip(colors, info["controllers"]):
            rate_curve(ax, [float(x) for x in xs], [info[key][x][name] for x in xs], fmt="o-", label=name, color=color)
            if key == "by_size":  # the null map at the largest size, beside it
                rate_curve(ax, [1.08 * float(xs[-1])], [info["null"][name]], fmt="x", color=color,
                           label=f"{name}, scrambled")
        ax.set_xlabel(xlabel)
        top = ceiling()
        if top is not None:  # the perfect recall of the planned-grasp study, at 0 and 1 cm
            for (held, n), style in zip(top[CEILING_ARMS[0]], ("--", ":")):
                ax.axhline(100 * held / n, color="k", linestyle=style, linewidth=1)
        if key == "by_size":
            ax.set_xscale("log")
            ax.minorticks_off()
        ax.set_xticks([float(x) for x in xs], xs)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(f"hold rate, test split, {len(info['seeds'])} seeds (%)")
    axes[0].legend(fontsize=8)
    if ceiling() is not None:
        axes[1].set_title("dashed / dotted: a perfect recall at 0 / 1 cm (planned-grasp study)", fontsize=8)
    figure.tight_layout()
    return save_figure(figure, path)


def report(config: LearningCurveConfig, info: dict) -> str:
    """The markdown report of a run (`info`: what `measure` returned, or study.json)."""
    lines = ["# Does more experience hold more? The learning curve", ""]
    if config.quick:
        lines += ["**A smoke run: too small to be evidence.**", ""]
    names, seeds, largest = info["controllers"], info["seeds"], str(info["sizes"][-1])
    command = (f"python scripts/study_learning_curve.py{' --quick' if config.quick else ''} --workers {info['workers']} "
               f"--seeds {len(seeds)} --sizes {' '.join(map(str, info['sizes']))} --rounds {info['rounds']} "
               f"--controllers {' '.join(names)}")
    lines += [f"Generated by `{command}`: {info['wall_seconds']:.0f} s. Seeds {', '.join(map(str, seeds))} of the "
              "generator, the maps, the subsets and the trials, each a whole curve; every rate pools the seeds' trials "
              "on the test split, with its 95 % Wilson interval; paired comparisons (McNemar) on the pooled trials, "
              "Holm within the family, and a difference claimed only where its sign holds on every seed.", "",
              "## Verdict", "", info["verdict"], "", f"![learning curve]({info['figure']})", "",
              "## Hold rate by experience size (test split)", ""]
    lines += markdown_table(["postures per object", *names],
                            [[n, *(rate_text(*info["by_size"][n][m]) for m in names)] for n in info["by_size"]])
    lines += ["", f"With the null experience ({largest} per object, each joint column permuted, the same training):", ""]
    lines += markdown_table(["experience", *names], [
        [f"{largest} per object", *(rate_text(*info["by_size"][largest][m]) for m in names)],
        [f"{largest} per object, scrambled", *(rate_text(*info["null"][m]) for m in names)]])
    lines += ["", "## Coverage by experience size", "",
              "The test poses where a verified grasp of the experience holds the object within 1 cm of where the "
              "pose puts it (`grid.covered`), over every seed, and every controller's rate there:", ""]
    lines += markdown_table(["postures per object", "covered test poses", *names], [
        [n, f"{c['poses'][0]} of {c['poses'][1]}", *(rate_text(*c[m]) for m in names)]
        for n, c in info["covered"].items()])
    top = ceiling()
    if top is not None:
        lines += ["", "## The ceiling: a perfect recall", "",
                  "What no experience can beat: the planned-grasp study (`docs/studies/planned_grasps.md`, seeds "
                  f"{', '.join(map(str, top['seeds']))}) tells som_approach's execution the very verified grasp and "
                  "puts the palm where that grasp puts it (a perfect recall), and replays the grasp open loop; at 0 cm "
                  "and with the object 1 cm off, the reach of a covered pose here. Quoted from its report when this one "
                  "was written; its plans are another benchmark's poses, so the ceiling bounds, it is not paired.", ""]
        lines += markdown_table(["", *(f"{100 * level:.0f} cm" for level in top["levels"])], [
            [f"{arm} (planned-grasp study)", *(rate_text(*c) for c in top[arm])] for arm in CEILING_ARMS] + ([
            [f"som_approach, {largest} per object, covered test poses (within 1 cm)",
             "", rate_text(*info["covered"][largest]["som_approach"])]] if "som_approach" in names else []))
    lines += ["", f"## Rounds of own grasps (from {info['sizes'][0]} per object)", "",
              "Held grasps of the selection split added per round, by seed: "
              + "; ".join(f"seed {s}: {added}" for s, added in zip(seeds, info["added"])) + ".", ""]
    lines += markdown_table(["round", *names],
                            [[r, *(rate_text(*info["by_round"][r][m]) for m in names)] for r in info["by_round"]])
    lines += ["", "## Paired comparisons (test split, seeds pooled)", "",
              *comparison_table(info["comparisons"], family=False), "", "By seed (difference in points; a claim "
              "needs its sign on every seed):", ""]
    lines += markdown_table(["comparison", *(f"seed {s}" for s in seeds), "sign on every seed"], [
        [c["label"], *(f"{100 * d:+.1f}" for d in c["seeds"]), "yes" if c["sign_holds"] else "no"]
        for c in info["comparisons"]])
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    """The study's command: `python scripts/study_learning_curve.py --help`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=None, help="a TOML file of LearningCurveConfig's keys")
    parser.add_argument("--quick", action="store_true", default=None, help="a smoke run")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (default 2)")
    parser.add_argument("--out", default=None, help="data directory (default: study-learning[-quick])")
    parser.add_argument("--doc", default=None, help="markdown report (default: docs/studies/learning_curve.md)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds of the whole curve (default 3)")
    parser.add_argument("--sizes", type=int, nargs="+", default=None, help="postures per object, ascending "
                        "(default 12 36 108)")
    parser.add_argument("--rounds", type=int, default=None, help="rounds of own grasps (default 1)")
    parser.add_argument("--controllers", nargs="+", default=None, choices=sorted(CONTROLLERS),
                        help=f"the curve's controllers (default {' '.join(DEFAULT_CONTROLLERS)})")
    parser.add_argument("--render", action="store_true", help="only write the report and its figure again from "
                        "OUT/study.json (the run that made it is the one it reports)")
    args = parser.parse_args(argv)
    flags = {k: getattr(args, k) for k in ("quick", "workers", "out", "doc", "seeds", "rounds")
             if getattr(args, k) is not None}
    flags.update({k: tuple(getattr(args, k)) for k in ("sizes", "controllers") if getattr(args, k) is not None})
    config = study_config(lambda: replace(read_config(args.config, LearningCurveConfig()) if args.config
                                          else LearningCurveConfig(), **flags))
    if args.render:
        stored = config.out_dir / "study.json"
        if not stored.exists():
            raise SystemExit(f"error: --render needs {stored}, written by a run of the study")
        info = read_json(stored, "the study's study.json")
        info["figure"] = plot(info, config.doc_path.with_suffix(".png"))
        write_text_atomic(config.doc_path, report(config, info))
        print(f"wrote {config.doc_path} and its figure from {stored}")
        return
    run_command(config.out_dir, lambda: LearningCurveStudy(config).run())


if __name__ == "__main__":
    main()
