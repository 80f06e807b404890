"""The completion study: how well do a SOM, a continuous manifold (UKR) and a linear one (PCA) complete a hand
posture from the joints touch has fixed, and does the continuous manifold grasp better?

    python scripts/study_completion.py [--quick] [--postures study-learning] [--out study-completion]
                                       [--doc docs/studies/completion_study.md] [--workers 2] [--no-trials]

Data: the verified postures of the experience benchmark's seven objects (`trials.benchmark.OBJECTS`: the paper's
box, cylinder and sphere and four small or flat ones), generated with three generator seeds by the experience or
learning-curve study (`--postures` names its folder: `experience_<object>.npz`, `experience_<object>_seed1.npz`,
`_seed2`, read as they are; their metadata says what made them). Fold k holds seed k's postures out and trains on the
other two seeds', all objects in one training set (the controller is never told the object); every held-out posture
is completed once, in the fold that holds it out.

Representations (`REPRESENTATIONS`), each trained on the fold's training postures: the paper's 25 x 25 SOM and
schedule, UKR with 1, 2 and 3 latent dimensions (`manifold.ukr.UKR`, its defaults), PCA with 2, 5 and 10 components
(`manifold.linear.LinearManifold`) and the raw database.

Masks (`masks`): 25, 50 and 75 % of the 22 joints hidden, per held-out posture, either as touch hides them (Eq. 1:
a finger's specified joints run from its base to its touching segment, so joints are hidden finger by finger from the
tip: a random finger's most distal specified joint, until enough are hidden) or at random. Measures per posture:
the RMS error of the hidden joints (degrees) and the mean fingertip position error of the completed posture
(`sim.hand.SegmentKinematics.fingertips`, mm, palm frame). Paired over postures, each UKR against the SOM by the
Wilcoxon signed-rank test, Holm over the six masking conditions of each; the target (issue 68): the 2-d UKR lower than
the SOM at every level, p < 0.01. Also: the variance PCA explains with two components and the components needed for
90 %, per object and pooled; training and completion times.

Trials (unless `--no-trials`), with fold 0's SOM and 2-d UKR: the experience benchmark's test split
(`trials.benchmark.run_benchmark`) with the paper's controller and the approach execution (`controller.APPROACH`),
and the planned-grasp benchmark (`trials.planned`, arms `paper` and `approach`) on the first `--plans` held-out
postures of each object as plans; McNemar of UKR against the SOM on the same trials, Holm over the four. Resumed
learning: the 2-d UKR resumed with the approach controller's successful benchmark grasps (`UKR.resume`), its
completion error on the held-out postures before and after.

Everything trained or run is kept in --out under the key of what made it (a rerun takes it); writes
`--out/study.json`, the report `--doc` and its figures beside it.
"""

from __future__ import annotations

import argparse
import copy
import time
from collections.abc import Callable
from typing import Any
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from ..base.checkpoints import result_key
from ..base.errors import InvalidInput, RenderingUnavailable
from ..base.io import fingerprint, load_npz, markdown_table, read_json, save_npz
from ..control.controller import APPROACH, ControllerParams
from ..judging.plans import open_loop_grasps
from ..manifold.analysis import latent_path
from ..manifold.experience import Experience, PostureDatabase
from ..manifold.linear import LinearManifold
from ..manifold.postureset import PostureSet
from ..manifold.representations import Representation
from ..manifold.som import SOM
from ..manifold.ukr import UKR
from ..sim.hand import FINGER_JOINTS, N_FINGER_JOINTS, SegmentKinematics, finger_of
from ..trials.benchmark import OBJECTS, pooled, run_benchmark
from ..trials.evaluation import EvaluationResult
from ..trials.planned import run_planned
from ..trials.stats import holm, mcnemar, rate_text
from .runner import StudyRun, comparison_table, holm_family, publish, run_study, save_figure

def _fitted_ukr(q: int) -> Callable[[np.ndarray, int], Representation]:
    """How a UKR of `q` latent dimensions is trained (its fit is deterministic: no seed)."""
    return lambda data, seed: UKR(q).fit(data, progress=False)


def _fitted_linear(k: int) -> Callable[[np.ndarray, int], Representation]:
    """How a linear manifold of `k` principal axes is trained (deterministic: no seed)."""
    return lambda data, seed: LinearManifold(k).fit(data)


#: the representations compared: name -> how one is trained on postures (n, 22) with a seed
REPRESENTATIONS: dict[str, Callable[[np.ndarray, int], Representation]] = {
    "som": lambda data, seed: SOM(25, 25, N_FINGER_JOINTS, seed=seed).fit(data, progress=False),
    **{f"ukr{q}": _fitted_ukr(q) for q in (1, 2, 3)},
    **{f"pca{k}": _fitted_linear(k) for k in (2, 5, 10)},
    "database": lambda data, seed: PostureDatabase(data),
}
#: the shares of the joints hidden, and how they are hidden
LEVELS: tuple[float, ...] = (0.25, 0.5, 0.75)
SCHEMES: tuple[str, ...] = ("touch", "random")
#: the target's representation and level (issue 68): the default UKR below the SOM at every level, p < TARGET_P
TARGET, TARGET_P = "ukr2", 0.01
#: the paired tests of completion error: (representation, against), each a family over the six masking conditions
PAIRS: tuple[tuple[str, str], ...] = (("ukr1", "som"), ("ukr2", "som"), ("ukr3", "som"), ("pca5", "som"),
                                      ("database", "som"), ("ukr2", "database"))
#: the controllers of the trials: label -> parameters (the benchmark) or arm (the planned grasps)
CONTROLLERS: dict[str, ControllerParams] = {"paper": ControllerParams(), "approach": APPROACH}
_FINGER_CHAINS = [np.flatnonzero([finger_of(j) == f for j in FINGER_JOINTS]) for f in ("ff", "mf", "rf", "lf", "th")]


def masks(scheme: str, level: float, count: int, seed: int) -> np.ndarray:
    """Which joints each of `count` held-out postures keeps specified (see the module doc).

    Args:
        scheme: 'touch' (hidden finger by finger from the tip, Eq. 1) or 'random'.
        level: the share of the 22 joints hidden, in (0, 1).
        count: postures.
        seed: seeds the draw.

    Returns:
        (count, 22) bool, True where specified.
    """
    if scheme not in SCHEMES or not 0 < level < 1:
        raise InvalidInput(f"scheme must be one of {SCHEMES} and level in (0, 1), got {scheme!r}, {level!r}")
    hidden = round(level * N_FINGER_JOINTS)
    rng = np.random.default_rng([seed, SCHEMES.index(scheme), round(1000 * level)])
    out = np.ones((count, N_FINGER_JOINTS), dtype=bool)
    for row in out:
        if scheme == "random":
            row[rng.choice(N_FINGER_JOINTS, hidden, replace=False)] = False
            continue
        kept = [len(chain) for chain in _FINGER_CHAINS]
        for _ in range(hidden):
            finger = rng.choice([f for f, k in enumerate(kept) if k > 0])
            kept[finger] -= 1
            row[_FINGER_CHAINS[finger][kept[finger]]] = False
    return out


def posture_sets(folder: str | Path, objects: tuple[str, ...], seeds: int) -> list[dict[str, PostureSet]]:
    """The verified postures of each object and generator seed, as the experience studies kept them.

    Args:
        folder: their folder.
        objects: benchmark objects.
        seeds: generator seeds 0 ... seeds-1.

    Returns:
        One {object: PostureSet} per seed.
    """
    sets = []
    for seed in range(seeds):
        files = {name: Path(folder) / f"experience_{name}{f'_seed{seed}' if seed else ''}.npz" for name in objects}
        missing = [str(p) for p in files.values() if not p.exists()]
        if missing:
            raise InvalidInput(f"--postures {folder}: no {', '.join(missing[:3])}; the learning-curve study writes "
                               "them (python scripts/study_learning_curve.py --out FOLDER)")
        sets.append({name: PostureSet.load(path) for name, path in files.items()})
    return sets


def _kept_representation(run: StudyRun, name: str, data: np.ndarray, fold: int) -> tuple[Experience, float]:
    """A representation trained on `data`, kept in OUT/representations under its key, with its training seconds."""
    if name == "database":
        start = time.perf_counter()
        return REPRESENTATIONS[name](data, fold), time.perf_counter() - start
    kinds: dict[str, type[SOM | UKR | LinearManifold]] = {"som": SOM, "ukr": UKR, "pca": LinearManifold}
    kind = kinds[name[:3]]

    def compute() -> tuple[Representation, float]:
        start = time.perf_counter()
        made = REPRESENTATIONS[name](data, fold)
        return made, time.perf_counter() - start

    def read(path: Path) -> tuple[tuple[Representation, float], dict]:
        made, meta = kind.load_with_metadata(path)
        return (made, float(meta["seconds"])), meta

    return run.keep(f"representations/{name}_fold{fold}.npz", result_key(name, fold, data), compute, read,
                    lambda kept, path, meta: kept[0].save(path, extra={**meta, "seconds": kept[1]}))


def completion_errors(experience: Experience, truth: np.ndarray, specified: np.ndarray,
                      kinematics: SegmentKinematics, tips: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """How far each completion lies from the truth.

    Args:
        experience: the representation.
        truth: (n, 22) held-out postures, rad.
        specified: (n, 22) bool, the joints given.
        kinematics: the hand's.
        tips: (n, 5, 3) the truth's fingertips, m.

    Returns:
        The RMS error of the hidden joints (n,) degrees, the mean fingertip error (n,) mm, the seconds per query.
    """
    start = time.perf_counter()
    completed = experience.complete_batch(np.where(specified, truth, np.nan), specified)
    seconds = (time.perf_counter() - start) / len(truth)
    hidden = ~specified
    degrees = np.degrees(np.sqrt((np.where(hidden, completed - truth, 0.0) ** 2).sum(axis=1) / hidden.sum(axis=1)))
    millimetres = 1e3 * np.array([np.linalg.norm(kinematics.fingertips(p) - t, axis=1).mean()
                                  for p, t in zip(completed, tips)])
    return degrees, millimetres, seconds


def measure_completion(run: StudyRun, sets: list[dict[str, PostureSet]]) -> tuple[dict, dict]:
    """The completion part (module doc): errors per representation, scheme and level, pooled over the folds, and the
    representations trained ({(name, fold): experience})."""
    kinematics = SegmentKinematics()
    errors: dict[str, dict[str, list]] = {}
    seconds: dict[str, dict[str, list[float]]] = {name: {"train": [], "query": []} for name in REPRESENTATIONS}
    trained = {}
    for fold, held_sets in enumerate(sets):
        held = np.concatenate([s.postures for s in held_sets.values()])
        data = np.concatenate([s.postures for k, other in enumerate(sets) if k != fold for s in other.values()])
        tips = np.array([kinematics.fingertips(p) for p in held])
        for name in REPRESENTATIONS:
            experience, train_seconds = _kept_representation(run, name, data, fold)
            trained[(name, fold)] = experience
            seconds[name]["train"].append(train_seconds)
            for scheme in SCHEMES:
                for level in LEVELS:
                    given = masks(scheme, level, len(held), fold)
                    deg, mm, per_query = completion_errors(experience, held, given, kinematics, tips)
                    cell = errors.setdefault(f"{scheme}/{level:.2f}", {}).setdefault(name, [[], []])
                    cell[0].append(deg)
                    cell[1].append(mm)
                    seconds[name]["query"].append(per_query)
            run.log(f"fold {fold}: {name} trained in {train_seconds:.1f} s on {len(data)} postures")
    pooled_errors = {cond: {name: (np.concatenate(v[0]), np.concatenate(v[1])) for name, v in by.items()}
                     for cond, by in errors.items()}
    rows, tests = [], []
    for cond, by in pooled_errors.items():
        for name, (deg, mm) in by.items():
            rows.append({"condition": cond, "representation": name, "n": len(deg), "deg_mean": float(deg.mean()),
                         "deg_ci": float(1.96 * deg.std(ddof=1) / np.sqrt(len(deg))), "deg_median": float(np.median(deg)),
                         "mm_mean": float(mm.mean()), "mm_ci": float(1.96 * mm.std(ddof=1) / np.sqrt(len(mm)))})
    for name, baseline in PAIRS:
        family: list[dict[str, Any]] = []
        for cond, by in pooled_errors.items():
            difference = by[name][0] - by[baseline][0]
            family.append({"representation": name, "against": baseline, "condition": cond, "n": len(difference),
                           "mean_difference_deg": float(difference.mean()),
                           "lower_share": float((difference < 0).mean()),
                           "p_value": float(wilcoxon(by[name][0], by[baseline][0]).pvalue)})
        for test, p in zip(family, holm([t["p_value"] for t in family])):
            test["p_holm"] = float(p)
        tests += family
    target = [t for t in tests if t["representation"] == TARGET and t["against"] == "som"]
    met = all(t["mean_difference_deg"] < 0 and t["p_holm"] < TARGET_P for t in target)
    variance = _variance(sets)
    timing = {name: {"train_s": float(np.mean(s["train"])), "query_us": float(1e6 * np.mean(s["query"]))}
              for name, s in seconds.items()}
    return {"rows": rows, "tests": tests, "target_met": met, "variance": variance, "timing": timing,
            "postures": {"held_out": int(sum(len(s) for held in sets for s in held.values())),
                         "training_per_fold": [int(sum(len(s) for k, o in enumerate(sets) if k != f for s in o.values()))
                                               for f in range(len(sets))]},
            "inputs": {f"{name}_seed{seed}": {"fingerprint": fingerprint(s.postures), "n": len(s),
                                              "library_version": s.metadata.get("library_version")}
                       for seed, held in enumerate(sets) for name, s in held.items()}}, trained


def _variance(sets: list[dict[str, PostureSet]]) -> dict:
    """The variance PCA explains with two components, and the components for 90 %, per object and pooled."""
    out = {}
    groups = {name: np.concatenate([held[name].postures for held in sets]) for name in sets[0]}
    groups["all"] = np.concatenate(list(groups.values()))
    for name, data in groups.items():
        linear = LinearManifold(2).fit(data)
        explained = linear.explained
        assert explained is not None  # fitted
        out[name] = {"two": float(explained[:2].sum()), "for_90": linear.components_for(0.9), "n": len(data)}
    return out


def _outcomes_file(run: StudyRun, name: str, key: str, compute: Callable[[], dict[str, np.ndarray]]
                   ) -> dict[str, np.ndarray]:
    """Boolean outcome arrays kept as an .npz under their key."""
    def read(path: Path) -> tuple[dict[str, np.ndarray], dict]:
        arrays, meta = load_npz(path, "completion_outcomes", {})
        return {k: np.asarray(arrays[k]) for k in arrays}, meta

    return run.keep(name, key, compute, read,
                    lambda arrays, path, meta: save_npz(path, "completion_outcomes", arrays, meta))


def _fold_trials(run: StudyRun, fold: int, sets: list[dict[str, PostureSet]], trained: dict, every: int,
                 plans: int) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]],
                                      dict[tuple[str, str], EvaluationResult]]:
    """One fold's trials (fold k's SOM and 2-d UKR, trial seed k, plans from seed k's held-out postures): outcomes
    {run: (held, valid)} and the approach controller's benchmark results with the UKR."""
    experiences = {"som": trained[("som", fold)], "ukr2": trained[("ukr2", fold)]}
    objects, tag = tuple(sets[fold]), f"_fold{fold}" if fold else ""
    outcomes: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    own: dict[tuple[str, str], EvaluationResult] = {}
    for label, params in CONTROLLERS.items():
        for name, experience in experiences.items():
            results = run_benchmark(experience, split="test", objects=objects, every=every, params=params, seed=fold,
                                    method=f"{name}_{label}{tag}", workers=run.executor or run.workers,
                                    store=run.out / "benchmark")
            outcomes[f"benchmark_{name}_{label}"] = held, valid = pooled(results)
            own = results if (name, label) == ("ukr2", "approach") else own
            run.log(f"fold {fold} benchmark {name}_{label}: hold {rate_text(int(held[valid].sum()), int(valid.sum()))}")
    planned: dict[str, list[np.ndarray]] = {}
    for obj in objects:
        chosen = open_loop_grasps(sets[fold][obj].subset(np.arange(min(plans, len(sets[fold][obj])))))
        for name, experience in experiences.items():
            def compute(obj=obj, chosen=chosen, experience=experience) -> dict[str, np.ndarray]:
                done = run_planned(OBJECTS[obj].object, chosen, tuple(CONTROLLERS), {"object": experience}, seed=fold,
                                   workers=run.workers, executor=run.executor)
                return {f"{arm}_{kind}": np.concatenate([getattr(t, kind)(arm) for t in done])
                        for arm in CONTROLLERS for kind in ("held", "faulted")} | {
                    "started": np.concatenate([t.started for t in done])}
            arrays = _outcomes_file(run, f"planned/{obj}_{name}{tag}.npz",
                                    result_key(obj, name, fold, [p.postures.tolist() for p in chosen],
                                               fingerprint(experience.references)), compute)
            for arm in CONTROLLERS:  # a fault is a failure of its arm; a displacement where no trial started is none
                planned.setdefault(f"planned_{name}_{arm}", []).append(arrays[f"{arm}_held"][arrays["started"]])
        run.log(f"fold {fold} planned {obj}: done")
    for method, parts in planned.items():
        held = np.concatenate(parts)
        outcomes[method] = (held, np.ones_like(held))
    return outcomes, own


def measure_trials(run: StudyRun, sets: list[dict[str, PostureSet]], trained: dict, quick: bool, plans: int) -> dict:
    """The trials part (module doc): the benchmark and the planned grasps, the SOM against the 2-d UKR, once per
    fold, pooled over the folds (McNemar, Holm over the four comparisons) with each fold's difference."""
    every, folds = (6, 1) if quick else (1, len(sets))
    per_fold: list[dict[str, tuple[np.ndarray, np.ndarray]]] = []
    own: dict[tuple[str, str], EvaluationResult] = {}
    for fold in range(folds):
        outcomes, mine = _fold_trials(run, fold, sets, trained, every, plans)
        per_fold.append(outcomes)
        own = own or mine

    def rate(held: np.ndarray, valid: np.ndarray) -> list[int]:
        return [int(held[valid].sum()), int(valid.sum())]

    pooled_outcomes = {m: tuple(np.concatenate([f[m][k] for f in per_fold]) for k in (0, 1)) for m in per_fold[0]}
    family, differences = [], {}
    for kind in ("benchmark", "planned"):
        for label in CONTROLLERS:
            (a, va), (b, vb) = pooled_outcomes[f"{kind}_ukr2_{label}"], pooled_outcomes[f"{kind}_som_{label}"]
            name = f"{kind}, {label}: ukr2 vs som"
            family.append((name, mcnemar(a, b, valid=va & vb)))
            differences[name] = [mcnemar(f[f"{kind}_ukr2_{label}"][0], f[f"{kind}_som_{label}"][0],
                                         valid=f[f"{kind}_ukr2_{label}"][1] & f[f"{kind}_som_{label}"][1]).difference
                                 for f in per_fold]
    resumed = _resumed(run, trained[("ukr2", 0)], own, sets[0])
    return {"rates": {m: rate(*v) for m, v in pooled_outcomes.items()},
            "rates_by_fold": [{m: rate(*v) for m, v in f.items()} for f in per_fold],
            "comparisons": holm_family(family, "ukr2 vs som"), "fold_differences": differences, "resumed": resumed,
            "every": every, "plans_per_object": plans, "folds": folds}


def _resumed(run: StudyRun, ukr: UKR, results: dict, held: dict[str, PostureSet]) -> dict:
    """Resumed learning with the controller's own grasps: the UKR's completion error before and after."""
    own = np.concatenate([r.successful_postures() for r in results.values()] or [np.zeros((0, N_FINGER_JOINTS))])
    truth = np.concatenate([s.postures for s in held.values()])
    kinematics = SegmentKinematics()
    tips = np.array([kinematics.fingertips(p) for p in truth])
    given = masks("touch", 0.5, len(truth), 0)
    before = completion_errors(ukr, truth, given, kinematics, tips)
    if not len(own):
        return {"own_grasps": 0}
    resumed = copy.copy(ukr)  # its arrays are read-only: `resume` replaces them, the original keeps its own
    resumed.resume(own, progress=False)
    after = completion_errors(resumed, truth, given, kinematics, tips)
    return {"own_grasps": len(own), "loo_before": ukr.loo_error(), "loo_after": resumed.history[-1]["loo"],
            "deg_before": float(before[0].mean()), "deg_after": float(after[0].mean()),
            "p_value": float(wilcoxon(after[0], before[0]).pvalue)}



def figures(info: dict, path: Path, ukr: UKR | None, sets: list[dict[str, PostureSet]]) -> str:
    """The report's figure: the completion error against the share hidden (touch, random), and the 2-d UKR's latent
    points by object; returns the file's name."""
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    rows = info["completion"]["rows"]
    for ax, scheme in zip(axes[:2], SCHEMES):
        for name in REPRESENTATIONS:
            mine = [r for r in rows if r["representation"] == name and r["condition"].startswith(scheme)]
            ax.errorbar([100 * float(r["condition"].split("/")[1]) for r in mine], [r["deg_mean"] for r in mine],
                        yerr=[r["deg_ci"] for r in mine], capsize=2, marker="o", label=name,
                        linestyle="-" if name in ("som", TARGET) else ":")
        ax.set(title=f"masked as {scheme}", xlabel="joints hidden (%)", ylabel="RMS error of the hidden joints (°)",
               yscale="log")
    axes[1].legend(fontsize=8, ncol=2)
    latent = None if ukr is None else ukr.latent
    if latent is not None:
        start = 0
        for name, postures in sets[1].items():  # fold 0 trains on seeds 1 and 2, objects in order
            count = len(postures)
            points = latent[start:start + count]
            axes[2].scatter(points[:, 0], points[:, 1] if points.shape[1] > 1 else np.zeros(count), s=4, label=name)
            start += count
        axes[2].set(title="2-d UKR: latent points of seed 1's postures", xlabel="z1", ylabel="z2")
        axes[2].legend(fontsize=8, markerscale=3)
    figure.tight_layout()
    return save_figure(figure, path)


def rendered_figures(ukr: UKR, path: Path, sets: list[dict[str, PostureSet]], image: int = 96) -> dict:
    """Figs. 3 and 5 for the 2-d UKR of fold 0 (`paper.figures.latent_figure`: hand pictures, offscreen OpenGL): a
    grid over its latent space and the path between the box's and the sphere's postures (each the posture nearest
    its object's latent centre, `paper.figures.cluster_ends`); returns what the path shows."""
    from ..paper.figures import cluster_ends, latent_figure
    from ..sim.render import render_postures

    labels = np.concatenate([np.full(len(s), name) for held in sets[1:] for name, s in held.items()])
    ends = ("box", "sphere") if {"box", "sphere"} <= set(labels) else tuple(sets[1])[:2]
    start, end = cluster_ends(ukr, labels, ends)
    figure = latent_figure(ukr, lambda postures: render_postures(postures, image), start, end,
                           title="the 2-d UKR of all seven objects", steps=6)
    figure.savefig(path, dpi=110)
    measures = latent_path(ukr, start, end, 6)
    return {"file": path.name, "ends": list(ends), "steps_deg": measures["steps_deg"].tolist(),
            "intermediate": measures["intermediate"].tolist(), "support": measures["support"].tolist()}


def report(info: dict) -> str:
    """The markdown report of the study."""
    completion = info["completion"]
    lines = ["# The completion study: SOM, UKR, PCA and the database (issue 68)", "",
             "Generated by `python scripts/study_completion.py` (`graspmanifold.studies.completion`, whose docstring "
             "says what it runs); the numbers are in `completion_study.json`.", "",
             f"**Verdict.** {info['verdict']}", "",
             *([f"The report and figures were redrawn (`--redraw`) from the results of the run with code "
                f"{info['computed_with'].get('code')}.", ""] if info.get("computed_with") else []),
             f"{completion['postures']['held_out']} held-out verified postures of {len(info['objects'])} objects "
             f"({', '.join(info['objects'])}), each completed once in the fold that holds its generator seed out; "
             f"{', '.join(map(str, completion['postures']['training_per_fold']))} training postures per fold.", "",
             "## Completion error", "",
             "RMS error of the hidden joints (degrees, mean over postures [95 % CI]) and the mean fingertip position "
             "error (mm):", ""]
    conditions = list(dict.fromkeys(r["condition"] for r in completion["rows"]))
    table = []
    for name in REPRESENTATIONS:
        cells = {r["condition"]: r for r in completion["rows"] if r["representation"] == name}
        table.append([name] + [f"{cells[c]['deg_mean']:.2f} ± {cells[c]['deg_ci']:.2f} ° / "
                               f"{cells[c]['mm_mean']:.1f} mm" for c in conditions])
    lines += markdown_table(["representation", *(c.replace("/", " ") for c in conditions)], table)
    lines += ["", "Paired over postures (Wilcoxon signed-rank, Holm over the six conditions of each pair); the "
              "difference is the first's error minus the second's:", ""]
    lines += markdown_table(["pair", "condition", "n", "mean difference (°)", "postures lower", "p", "p (Holm)"],
                            [[f"{t['representation']} - {t['against']}", t["condition"], t["n"],
                              f"{t['mean_difference_deg']:+.2f}", f"{100 * t['lower_share']:.0f} %",
                              f"{t['p_value']:.2g}", f"{t['p_holm']:.2g}"] for t in completion["tests"]])
    lines += ["", "## Linear synergies", "", "The variance PCA explains with two components, and the components "
              "needed for 90 % (the human hand: about 80 % with two, Santello et al. 1998):", ""]
    lines += markdown_table(["postures", "n", "two components", "components for 90 %"],
                            [[k, v["n"], f"{100 * v['two']:.0f} %", v["for_90"]]
                             for k, v in completion["variance"].items()])
    lines += ["", "## Times", "", f"On this machine ({info['machine']}), fold means:", ""]
    lines += markdown_table(["representation", "training (s)", "completion per query (µs, batch)"],
                            [[k, f"{v['train_s']:.2f}", f"{v['query_us']:.0f}"]
                             for k, v in completion["timing"].items()])
    if "figure" in info:
        lines += ["", f"![completion error]({info['figure']})"]
    if info.get("rendered"):
        r = info["rendered"]
        lines += ["", "## The continuous manifold's pictures (Figs. 3 and 5)", "",
                  f"![UKR grid and path]({r['file']})", "",
                  f"The path from the {r['ends'][0]}'s posture nearest its latent centre to the {r['ends'][1]}'s: steps "
                  f"{', '.join(f'{s:.0f}°' for s in r['steps_deg'])}; inner postures intermediate: "
                  f"{sum(r['intermediate'])} of {len(r['intermediate'])}; distance of each path point to the nearest "
                  f"training latent point: {', '.join(f'{s:.1f}' for s in r['support'])} (kernel bandwidths)."]
    if info.get("trials"):
        trials = info["trials"]
        poses = "every test pose" if trials["every"] == 1 else f"every {trials['every']}th test pose"
        lines += ["", "## Trials", "", f"Hold rates [95 % Wilson interval], each fold's SOM and 2-d UKR with the trials "
                  f"seeded by the fold ({poses} of the benchmark; the planned grasps: {trials['plans_per_object']} "
                  "held-out postures of each object as plans, at every displacement level; a fault counts as a "
                  "failure), pooled over the folds and per fold:", ""]
        folds = trials["rates_by_fold"]
        lines += markdown_table(["run", "pooled", *(f"fold {k}" for k in range(len(folds)))],
                                [[k, rate_text(*v), *(rate_text(*f[k]) for f in folds)]
                                 for k, v in trials["rates"].items()])
        lines += ["", "UKR against the SOM on the same trials, pooled over the folds (McNemar, Holm over the four), "
                  "with each fold's difference:", ""]
        lines += comparison_table(trials["comparisons"])
        lines += ["", *(f"- {name}: " + ", ".join(f"{100 * d:+.1f}" for d in values) + " points by fold"
                        for name, values in trials["fold_differences"].items())]
        resumed = trials["resumed"]
        if resumed.get("own_grasps"):
            lines += ["", f"Resumed learning with the approach controller's {resumed['own_grasps']} successful "
                      f"benchmark grasps: leave-one-out error {resumed['loo_before']:.2e} -> {resumed['loo_after']:.2e} "
                      f"rad^2 (its training set grew); touch-masked 50 % completion of the held-out postures "
                      f"{resumed['deg_before']:.2f}° -> {resumed['deg_after']:.2f}° (Wilcoxon p = "
                      f"{resumed['p_value']:.2g})."]
    return "\n".join(lines) + "\n"


def _verdict(completion: dict) -> str:
    target = [t for t in completion["tests"] if t["representation"] == TARGET and t["against"] == "som"]
    worst = max(target, key=lambda t: (t["p_holm"] >= TARGET_P, t["mean_difference_deg"]))
    if completion["target_met"]:
        return (f"Target met: the 2-d UKR completes held-out postures with a lower error than the 25 x 25 SOM in every "
                f"one of the six masking conditions (paired over postures, Holm p < {TARGET_P}; the smallest gain "
                f"{-worst['mean_difference_deg']:.2f}°, {worst['condition']}).")
    return (f"Target not met: the 2-d UKR is not lower than the 25 x 25 SOM in every masking condition at p < "
            f"{TARGET_P}; where it falls short most: {worst['condition']}, mean difference "
            f"{worst['mean_difference_deg']:+.2f}° (p Holm {worst['p_holm']:.2g}).")


def main(argv: list[str] | None = None) -> None:
    """The study's command (see the module doc)."""
    import platform

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run: two objects, one fold, few trials")
    parser.add_argument("--postures", default="study-learning", help="the folder of the verified posture sets")
    parser.add_argument("--out", default="", help="the folder of kept results (default study-completion[-quick])")
    parser.add_argument("--doc", default="", help="the report (default docs/studies/completion_study.md, or OUT/... quick)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--plans", type=int, default=4, help="planned grasps per object")
    parser.add_argument("--no-trials", action="store_true", help="the completion part only")
    parser.add_argument("--redraw", action="store_true", help="redraw the report and its figures from OUT/study.json "
                        "and the kept 2-d UKR of fold 0 (nothing is computed)")
    args = parser.parse_args(argv)
    out = Path(args.out or ("study-completion-quick" if args.quick else "study-completion"))
    doc = Path(args.doc or (out / "completion_study.md" if args.quick else "docs/studies/completion_study.md"))

    def redraw(run: StudyRun) -> None:
        info = read_json(out / "study.json", "the study's study.json")
        info["computed_with"] = info.pop("computed_with", None) or info.pop("versions", {})  # the run's software
        sets = posture_sets(args.postures, tuple(info["objects"]), 2 if args.quick else 3)
        ukr = UKR.load(out / "representations" / "ukr2_fold0.npz")
        info["figure"] = figures(info, doc.with_name(doc.stem + "_errors.png"), ukr, sets)
        if info.get("rendered"):
            info["rendered"] = rendered_figures(ukr, doc.with_name(doc.stem + "_ukr.png"), sets)
        publish(run, doc, args.quick, info, report)

    def body(run: StudyRun) -> None:
        run.check_writable(doc)
        objects = ("box", "pen") if args.quick else tuple(OBJECTS)
        sets = posture_sets(args.postures, objects, 2 if args.quick else 3)
        completion, trained = measure_completion(run, sets)
        info = {"objects": list(objects), "completion": completion, "verdict": _verdict(completion),
                "machine": f"{platform.machine()}, {platform.python_version()}, {run.workers} workers"}
        ukr = trained[("ukr2", 0)]
        info["figure"] = figures(info, doc.with_name(doc.stem + "_errors.png"), ukr, sets)
        try:
            info["rendered"] = rendered_figures(ukr, doc.with_name(doc.stem + "_ukr.png"), sets)
        except RenderingUnavailable as error:  # no OpenGL: the report goes without the hand pictures
            info["rendered"] = {}
            run.log(f"no hand pictures: {type(error).__name__}: {error}")
        if not args.no_trials:
            info["trials"] = measure_trials(run, sets, trained, args.quick, 1 if args.quick else args.plans)
        publish(run, doc, args.quick, info, report)

    run_study(out, args.workers, redraw if args.redraw else body, None if args.redraw else "completion.log")
