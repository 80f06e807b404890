"""The first experience study, on the paper's grids: does recalling experienced grasps beat the strongest
simple control?

    python scripts/study_experience_paper_grids.py [--quick] [--workers 2] [--out study-paper-grids]
                                                   [--doc docs/studies/experience_study_paper_grids.md]

The current study is `scripts/study_experience.py` (a benchmark where grasp choice matters); this one is
kept so that its grids and its verdict stay reproducible. Its headroom table (the per-pose oracle over
the controls against the best of them) shows why these grids cannot show a recall effect.

For each object: verified spring grasps (`--candidates` spring candidates, of which those that hold when
replayed are kept: `generator.verify_postures`), and experience grown from the controller's own held grasps at training poses (the paper
grid's poses perturbed by 1 cm and 0.2 rad, a fresh draw per round, never the test poses
themselves: the paper's resumed learning as a loop, with its learning curve on the quick grid;
round 0 is the map of the verified spring grasps alone). Then every method and control runs on the
same poses of each grid, paired.

Methods: `som` (25 x 25 map of spring + grown grasps), `database` (the same grasps, raw),
`som_preshaped` (the best constant preshape in phase B, the SOM's PCP steering in phase C: does
recall add anything to the strongest control?). Controls: `none` (the plain tactile heuristic),
`none_fast` (the heuristic closing twice as fast: the experience controller's fingers may move up
to twice the heuristic's speed), `none_preshape` (the best constant preshape: of the cluster means
of the experience, the one that holds most often on the quick grid, with no recall). Ablations of
`som` on the paper grid: phase B's preshape off, phase C's steering off, every match trusted.
Grids: paper (every method), far, hard, and the paper grid with pose noise (1 cm, 0.2 rad) (the
controls and the SOMs); a per-axis breakdown of the hard grid; friction sensitivity (0.4 and 0.8)
on the quick grid.

Every finished evaluation is kept in --out, so an interrupted study resumes. Writes
`--out/study.json` and the markdown report `--doc`.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import TypedDict

import numpy as np

from ..base.checkpoints import result_key
from ..base.io import json_text, load_npz, markdown_table, save_npz, software_versions, write_text_atomic
from ..control.controller import BLEND
from ..judging.judge import JUDGING
from ..manifold.experience import PostureDatabase
from ..manifold.postureset import PostureSet
from ..sim.hand import N_FINGER_JOINTS
from ..sim.objects import get_object
from ..synthesis.generator import GeneratorParams, generate_postures, verify_postures
from ..trials.evaluation import EvaluationResult, evaluate, trial_count
from ..trials.experience_pays import (
    TRAINING_NOISE,
    closing_rate_params,
    comparison_rows,
    grow_experience,
    judge_target,
    train_experience_map,
)
from ..trials.grid import GRID_COLUMNS, coverage, grid_preset
from ..trials.stats import compare
from ..trials.stats import MIN_HEADROOM, headroom, holm, rate_text
from ..trials.setup import Noise, TrialSetup
from .runner import StudyRun, run_command

OBJECTS = ("box", "cylinder", "sphere")
CONTROLS = ("none", "none_fast", "none_preshape")
METHODS = ("som", "som_preshaped", "database")
ABLATIONS = {"som_no_preshape": replace(BLEND, experience_preshape=False),
             "som_no_steering": replace(BLEND, experience_steering=False),
             "som_trust_every_match": replace(BLEND, max_match_distance=float("inf"))}
PAPER_NOISE = Noise(position=0.01, yaw=0.2)


class Study(StudyRun):
    """The first study's run: its evaluations and experience kept in OUT under the keys of what made them."""

    def __init__(self, args: argparse.Namespace):
        super().__init__(args.out, args.workers)
        self.args = args
        self.results: dict[tuple[str, str, str], EvaluationResult] = {}

    def evaluate(self, obj, grid_name: str, method: str, experience, params=None, noise=None, grid=None,
                 preshape=None) -> EvaluationResult:
        """One method on one grid, taken from OUT when it holds this configuration's result."""
        obj = get_object(obj) if isinstance(obj, str) else obj
        poses = grid if grid is not None else grid_preset(grid_name.removesuffix("_noisy"), obj)
        params = params or BLEND
        key = TrialSetup(object=obj, experience=experience, noise=noise or Noise(), params=params, preshape=preshape, method=method,
                         margin=True).key(poses, 0)

        def compute(parts: Path) -> EvaluationResult:
            start = time.perf_counter()
            result = evaluate(obj, experience, poses, seed=0, workers=self.executor or self.workers, noise=noise, params=params,
                              preshape=preshape, checkpoint_dir=parts, margin=True, method=method)
            result.grid_name = grid_name
            s = result.summary
            self.log(f"{obj.name:8s} {grid_name:12s} {method:16s} n={trial_count(s):>3s} hold {s['hold_rate']:.0%} "
                     f"fc {s['force_closure_rate']:.0%} ({time.perf_counter() - start:.0f} s)")
            return result

        result = self.evaluation(f"evaluation/{obj.name}_{grid_name}_{method}", key, compute)
        self.results[(obj.name, grid_name, method)] = result
        return result


class ExperienceSets(TypedDict):
    """An object's experience: its verified spring grasps, the grown experience's postures (n, 22) rad, and the
    learning curve (one point per round)."""

    spring: PostureSet
    grown: np.ndarray
    curve: list[dict]


def experience_sets(study: Study, obj: str) -> ExperienceSets:
    """Verified spring grasps and the grown experience, kept in OUT under the keys of what made them."""
    args = study.args
    params = GeneratorParams(verify=False)
    key = result_key({"object": get_object(obj).params(), "candidates": args.candidates, "seed": 0,
                      "params": asdict(params)})
    spring = study.postures(f"{obj}_spring", key, lambda parts: verify_postures(generate_postures(
        obj, args.candidates, seed=0, workers=study.executor or study.workers, params=params,
        checkpoint_dir=parts), obj,
        workers=study.workers))
    training = grid_preset("quick" if args.quick else "paper", obj)  # perturbed by TRAINING_NOISE
    grown_key = result_key(spring.postures, training, {"rounds": args.rounds})

    def grow() -> tuple[np.ndarray, list[dict]]:
        curve: list[dict] = []

        def measure(r, som, postures):
            result = study.evaluate(obj, "quick", f"learning_round{r}", som)
            curve.append({"round": r, "experience": len(postures), "quick_hold": result.summary["hold_rate"],
                          "quick_hold_text": rate_text(int(result.outcomes().sum()), result.summary["trials"])})

        grown, records = grow_experience(get_object(obj), spring.postures, training, args.rounds,
                                         workers=study.workers, on_round=measure)
        measure(args.rounds, train_experience_map(grown), grown)
        for record, point in zip(records, curve):
            point.update(train_held=record["held"], train_trials=record["trials"])
        first, last = (study.results[(obj, "quick", f"learning_round{r}")] for r in (0, args.rounds))
        curve[-1]["p_vs_round0"] = compare(last, first).p_value  # kept with the curve: a resumed run reports it too
        return grown, curve

    def read(path: Path) -> tuple[tuple[np.ndarray, list[dict]], dict]:
        arrays, meta = load_npz(path, "grown_experience", {"postures": (None, N_FINGER_JOINTS)})
        return (arrays["postures"], meta["curve"]), meta

    grown, curve = study.keep(f"{obj}_grown.npz", grown_key, grow, read, lambda made, target, meta: save_npz(
        target, "grown_experience", {"postures": made[0]}, {"curve": made[1], **meta}))
    return {"spring": spring, "grown": grown, "curve": curve}


def best_constant_preshape(study: Study, obj: str, sets: ExperienceSets) -> np.ndarray:
    """Of the experience's cluster means (per starting posture, the grown grasps, all), the one that holds most."""
    spring, grown = sets["spring"], sets["grown"]
    candidates = [spring.postures[spring.start_ids == i].mean(axis=0) for i in np.unique(spring.start_ids)]
    extra = grown[len(spring):]
    if len(extra):
        candidates.append(extra.mean(axis=0))
    candidates.append(grown.mean(axis=0))
    if study.args.quick:
        candidates = candidates[-2:]  # CI-sized: the grown grasps' mean and the mean of all
    scores = []
    for k, posture in enumerate(candidates):
        result = study.evaluate(obj, "quick", f"preshape_candidate{k}", None, preshape=posture)
        scores.append(result.rate())
    return candidates[int(np.argmax(scores))]


def run(study: Study) -> dict:
    args = study.args
    grids = ["quick"] if args.quick else ["paper", "far", "hard", "paper_noisy"]
    info: dict = {"objects": {}, "grids": grids}
    for obj in OBJECTS:
        sets = experience_sets(study, obj)
        spring, grown = sets["spring"], sets["grown"]
        som = train_experience_map(grown)
        preshape = best_constant_preshape(study, obj, sets)
        methods = {"none": (None, None, None), "none_fast": (None, closing_rate_params(2.0), None),
                   "none_preshape": (None, None, preshape), "som": (som, None, None),
                   "som_preshaped": (som, None, preshape), "database": (PostureDatabase(grown), None, None)}
        methods.update({name: (som, params, None) for name, params in ABLATIONS.items()})
        for grid in grids:
            noise = PAPER_NOISE if grid.endswith("_noisy") else None
            for method, (experience, params, fixed) in methods.items():
                if experience is None and method.startswith("som"):
                    continue  # no verified spring grasp for this object: nothing to map
                if method not in (*CONTROLS, "som", "som_preshaped") and grid != grids[0]:
                    continue  # the other grids compare the controls with the SOMs alone
                if method in ABLATIONS and args.quick:
                    continue
                study.evaluate(obj, grid, method, experience, params, noise, preshape=fixed)
        near = coverage(obj, grid_preset(grids[0].removesuffix("_noisy"), obj), spring.hand_poses) if len(spring) \
            else np.zeros((0, 1))  # no verified grasp: nothing to cover the grid with
        info["objects"][obj] = {
            "spring_candidates": int(spring.metadata["candidates"]), "spring_verified": len(spring),
            "verified_by_start": spring.metadata["verified_by_start"], "grown": int(len(grown) - len(spring)),
            "learning_curve": sets["curve"],
            "coverage_median_mm": float(np.median(near[:, 0]) * 1000) if len(spring) else None,
            "coverage_within_5mm": float(np.mean(near[:, 0] <= 0.005)) if len(spring) else None}
        if not args.quick:
            friction_study(study, obj, som, info)
    return info


def friction_study(study: Study, obj: str, som, info: dict) -> None:
    base = get_object(obj)
    for friction in (0.4, 0.8):
        other = replace(base, friction=friction)
        for method, experience in (("none", None), ("som", som)):
            study.evaluate(other, f"quick_mu{friction}", method, experience, grid=grid_preset("quick", base))


def axis_breakdown(study: Study, obj: str, grid: str, methods: tuple[str, ...]) -> str:
    present = [m for m in methods if (obj, grid, m) in study.results]
    poses = np.array([t.grid_pose for t in study.results[(obj, grid, present[0])].trials])
    table = []
    for column, axis in enumerate(GRID_COLUMNS):
        values = np.unique(poses[:, column])
        if len(values) < 2:
            continue
        for value in values:
            rows = poses[:, column] == value
            rates = [study.results[(obj, grid, m)].rate(rows=rows) for m in present]
            table.append([axis, f"{value:+.3f}", rows.sum(), *(f"{r:.0%}" for r in rates)])
    return "\n".join(markdown_table(["axis", "value", "n", *present], table))


def why(study: Study, rows: list[dict], info: dict) -> list[str]:
    """What the ablations and controls say about the verdict, computed from this run's results."""
    results = study.results

    def hold(obj: str, grid: str, method: str) -> str:
        r = results.get((obj, grid, method))
        return "-" if r is None else f"{r.rate():.0%}"

    main = info["grids"][0]
    strongest = [r for r in rows if r["method"] == "som"]
    preshape_best = sum(r["control"] == "none_preshape" for r in strongest if not r["grid"].startswith("quick_mu"))
    pairs = sum(not r["grid"].startswith("quick_mu") for r in strongest)
    lines = [f"- The strongest control is the best constant preshape (`none_preshape`) on {preshape_best} of "
             f"{pairs} object/grid pairs: one fixed posture to close from, chosen by trial, is worth as much "
             "as recalling experienced grasps (hold on the {0} grid, none / none_preshape / som: {1}).".format(
                 main, "; ".join(f"{o} {hold(o, main, 'none')} / {hold(o, main, 'none_preshape')} / "
                                 f"{hold(o, main, 'som')}" for o in OBJECTS))]
    on_top = [r for r in comparison_rows(results, ("som_preshaped",), ("none_preshape",))]
    if on_top:
        lines.append("- Recall on top of that preshape (`som_preshaped`: the best preshape in phase B, the SOM's "
                     "PCP steering in phase C) against the preshape alone: " + "; ".join(
                         f"{r['object']}/{r['grid']} +{r['only_method']} -{r['only_control']} (p = {r['p_value']:.2g})"
                         for r in on_top) + (". PCP steering after the first contact adds nothing measurable."
                                            if all(r["verdict"] == "no difference" for r in on_top) else "."))
    if any((o, main, "som_no_steering") in results for o in OBJECTS):
        ablated = [compare(results[(o, main, "som")], results[(o, main, a)]) for o in OBJECTS for a in ABLATIONS
                   if (o, main, "som") in results and (o, main, a) in results]
        differs = sum(c.verdict() != "no difference" for c in ablated)
        lines.append("- Ablations on the {0} grid (hold, som / without phase-B preshape / without phase-C steering "
                     "/ trusting every match): {1}; {2} of {3} ablations differ significantly from the full "
                     "mechanism.".format(main, "; ".join(f"{o} {hold(o, main, 'som')} / {hold(o, main, 'som_no_preshape')} / "
                                                          f"{hold(o, main, 'som_no_steering')} / "
                                                          f"{hold(o, main, 'som_trust_every_match')}" for o in OBJECTS),
                                         differs, len(ablated)))
    curves = {o: info["objects"][o]["learning_curve"] for o in OBJECTS if o in info["objects"]}
    curve = "; ".join(f"{o} {c[0]['quick_hold']:.0%} -> {c[-1]['quick_hold']:.0%} (p = {c[-1]['p_vs_round0']:.2g})"
                      for o, c in curves.items() if len(c) > 1 and "p_vs_round0" in c[-1])
    if curve:
        lines.append(f"- Growing the experience from the controller's own held grasps, round 0 against the last "
                     f"round on the quick grid: {curve}.")
    hard = "hard" if "hard" in info["grids"] else main
    hopeless = []
    for obj in OBJECTS:
        present = [m for m in (*CONTROLS, "som") if (obj, hard, m) in results]
        if not present:
            continue
        poses = np.array([t.grid_pose for t in results[(obj, hard, present[0])].trials])
        for column, axis in enumerate(GRID_COLUMNS):
            for value in np.unique(poses[:, column]):
                rows_at = poses[:, column] == value
                best = max(results[(obj, hard, m)].rate(rows=rows_at) for m in present)
                if best < 0.2 and len(np.unique(poses[:, column])) > 1:
                    hopeless.append(f"{obj} {axis} {value:+.2f} (best {best:.0%})")
    if hopeless:
        lines.append(f"- On the {hard} grid every method fails together at: {', '.join(hopeless)}. There the "
                     "hand does not reach round the object from that placement; a recalled finger posture cannot "
                     "move the wrist, and the experience holds no grasp there to recall.")
    return lines


def report(study: Study, info: dict) -> str:
    """The markdown report of the study (what `info` holds, the study's results); `info` gains the verdict, the
    comparisons and the summaries."""
    results, args = study.results, study.args
    rows = comparison_rows(results, (*METHODS, *ABLATIONS), CONTROLS)
    verdict = judge_target(rows)
    adjusted = holm([r["p_value"] for r in rows]) if rows else np.zeros(0)
    for r, p in zip(rows, adjusted):
        r["p_holm"] = float(p)
    lines = ["# Does experience pay? The first experience study, on the paper's grids", "",
             f"Generated by `python scripts/study_experience_paper_grids.py{' --quick' if args.quick else ''} --workers "
             f"{args.workers}` ({study.computed} results computed, {study.reused} taken from an earlier run in --out; "
             f"{study.seconds:.0f} s of computing). "
             "Every rate is the hold test (six gravity directions, object within 2 cm) with its 95 % Wilson "
             "interval; comparisons are paired on the same poses (McNemar's exact test).", "",
             "## Verdict", "", verdict.text, "",
             f"After Holm's correction over all {len(rows)} comparisons of the table below, "
             f"{sum(r['p_holm'] < 0.05 and r['verdict'] == 'worse' for r in rows)} of them are significantly worse "
             f"and {sum(r['p_holm'] < 0.05 and r['verdict'] == 'better' for r in rows)} significantly better "
             "(adjusted p < 0.05).", ""]
    lines += _report_headroom(results, info)
    lines += _report_experience(study, rows, info)
    lines += _report_rates(results, info)
    lines += _report_comparisons(study, rows, info)
    info.update(verdict=verdict.text, target_met=verdict.met, comparisons=rows,
                summaries=[r.summary for r in results.values()], seconds=time.perf_counter() - study.started)
    return "\n".join(lines) + "\n"


def _report_headroom(results: dict, info: dict) -> list[str]:
    """How much choosing among the controls per pose could gain, by grid and object."""
    lines: list[str] = []
    lines += ["## Headroom", "", "Before any comparison: how much could choosing among the controls per pose gain "
              "(`graspmanifold.trials.stats.headroom`: the per-pose oracle over the plain heuristic, the fast heuristic and "
              "the best constant preshape, against the best of them)? Below 15 points a benchmark cannot show a "
              "recall effect.", ""]
    room_rows = []
    able: list[str] = []
    unable: list[str] = []
    for grid in info["grids"]:
        pooled: dict[str, list[np.ndarray]] = {}
        for obj in OBJECTS:
            present = {c: results[(obj, grid, c)] for c in CONTROLS if (obj, grid, c) in results}
            if len(present) < 2:
                continue
            room = headroom({c: r.outcomes() for c, r in present.items()}, {c: r.valid for c, r in present.items()})
            room_rows.append([grid, obj, room.n, rate_text(room.oracle, room.n),
                              f"{room.best} {rate_text(room.best_successes, room.n)}", rate_text(room.gain, room.n)])
            for c, r in present.items():
                pooled.setdefault(c, []).append(r.outcomes() & r.valid)
        if pooled and len({len(v) for v in pooled.values()}) == 1:
            room = headroom({c: np.concatenate(v) for c, v in pooled.items()})
            room_rows.append([grid, "pooled", room.n, rate_text(room.oracle, room.n),
                              f"{room.best} {rate_text(room.best_successes, room.n)}",
                              f"**{rate_text(room.gain, room.n)}**"])
            (able if room.sufficient else unable).append(grid)
    lines += markdown_table(["grid", "object", "n", "oracle", "best control", "headroom"], room_rows) + [""]
    if unable:
        lines += [f"Pooled headroom below {MIN_HEADROOM:.0%} on the {', '.join(unable)} grid(s): "
                  "they cannot show a recall effect, whatever the method.", ""]
    return lines


def _report_experience(study: Study, rows: list, info: dict) -> list[str]:
    """Why the verdict is what it is, and the experience and its learning curve."""
    lines: list[str] = []
    lines += ["## Why", ""] + why(study, rows, info) + [""]
    lines += ["## Experience", ""]
    lines += markdown_table(
        ["object", "spring candidates", "verified (hold)", "verified by starting posture", "grown from own grasps",
         "grid poses: nearest experienced palm position (median)", "within 5 mm"],
        [[obj, o["spring_candidates"], o["spring_verified"],
          ", ".join(f"{k} {v:.0%}" for k, v in o["verified_by_start"].items()), o["grown"],
          "n/a" if o["coverage_median_mm"] is None else f"{o['coverage_median_mm']:.0f} mm",
          "n/a" if o["coverage_within_5mm"] is None else f"{o['coverage_within_5mm']:.0%}"]
         for obj, o in info["objects"].items()])
    lines += ["", "Learning curve (quick grid, hold; each round grasps at noisy training poses, keeps what held "
              f"and retrains; training noise {TRAINING_NOISE.position * 100:.0f} cm, {TRAINING_NOISE.yaw} rad):", ""]
    lines += markdown_table(
        ["object", "round", "experience postures", "quick-grid hold", "held at training poses"],
        [[obj, point["round"], point["experience"], point["quick_hold_text"],
          f"{point['train_held']} of {point['train_trials']}" if "train_held" in point else "-"]
         for obj, o in info["objects"].items() for point in o["learning_curve"]])
    return lines


def _report_rates(results: dict, info: dict) -> list[str]:
    """The hold rate per object, grid and method, with force closure, margin and time."""
    lines: list[str] = []
    lines += ["", "## Hold rate per object, grid and method", ""]
    for grid in info["grids"]:
        present = [m for m in (*CONTROLS, *METHODS, *ABLATIONS) if any((o, grid, m) in results for o in OBJECTS)]
        def hold(r: EvaluationResult) -> str:
            return rate_text(int(r.outcomes().sum()), r.summary["trials"])

        def closure(r: EvaluationResult) -> str:
            s = r.summary
            return f"{s['force_closure_rate']:.0%} / {s['mean_margin']:.1f} / {s['mean_time_to_grasp']:.2f}"

        lines += [f"### {grid}", ""]
        lines += markdown_table(["object", *present], [[obj, *("-" if (obj, grid, m) not in results else
                                                              hold(results[(obj, grid, m)]) for m in present)]
                                                       for obj in OBJECTS])
        lines += ["", f"Force closure (ε > {JUDGING.epsilon_threshold}) / mean margin (N) / mean time to grasp (s):", ""]
        lines += markdown_table(["object", *present], [[obj, *("-" if (obj, grid, m) not in results else
                                                              closure(results[(obj, grid, m)]) for m in present)]
                                                       for obj in OBJECTS])
        lines.append("")
    return lines


def _report_comparisons(study: Study, rows: list, info: dict) -> list[str]:
    """The paired comparisons, where each method fails, and the friction sensitivity."""
    lines: list[str] = []
    results = study.results
    lines += ["## Paired comparisons against the strongest control", "",
              "The strongest control is, per object and grid, the control with the highest hold rate there. "
              "`only method` / `only control`: poses where just one of the two held.", ""]
    lines += markdown_table(["object", "grid", "method", "hold", "strongest control", "its hold", "only method",
                             "only control", "p", "p (Holm)", "verdict"],
                            [[r["object"], r["grid"], r["method"], r["rate_text"], r["control"], r["control_text"],
                              r["only_method"], r["only_control"], f"{r['p_value']:.3g}", f"{r['p_holm']:.3g}",
                              r["verdict"]] for r in rows])
    hard = "hard" if "hard" in info["grids"] else info["grids"][0]
    lines += ["", f"## Where each method fails: hold rate by axis of the {hard} grid", ""]
    for obj in OBJECTS:
        lines += [f"### {obj}", "", axis_breakdown(study, obj, hard, (*CONTROLS, *METHODS)), ""]
    friction = sorted({g for _, g, _ in results if g.startswith("quick_mu")})
    if friction:
        lines += ["## Sensitivity to friction (quick grid; experience built at μ = 0.6)", ""]
        lines += markdown_table(["object", "μ", "none", "som"], [
            [obj, g.removeprefix("quick_mu"), *(rate_text(int(results[(obj, g, m)].outcomes().sum()),
                                                          results[(obj, g, m)].summary["trials"]) for m in ("none", "som"))]
            for obj in OBJECTS for g in friction])
        lines.append("")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="quick grid only, small experience (CI-sized)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None, help="data directory (default: study-paper-grids, with --quick "
                        "study-paper-grids-quick)")
    parser.add_argument("--doc", default=None, help="markdown report (default: docs/studies/experience_study_paper_grids.md; "
                        "with --quick: OUT/experience_study.md)")
    parser.add_argument("--candidates", type=int, default=None, help="spring candidates per object")
    parser.add_argument("--rounds", type=int, default=None, help="rounds of growing experience")
    args = parser.parse_args(argv)
    args.out = args.out or ("study-paper-grids-quick" if args.quick else "study-paper-grids")
    args.candidates = args.candidates or (60 if args.quick else 600)
    args.rounds = args.rounds if args.rounds is not None else (1 if args.quick else 2)
    doc = Path(args.doc or (Path(args.out) / "experience_study.md" if args.quick else "docs/studies/experience_study_paper_grids.md"))
    run_command(args.out, lambda: write_study(Study(args), doc))


def write_study(study: Study, doc: Path) -> None:
    """Run the study in one pool of workers; write its report, OUT/study.json (and, for the full study, the
    report's JSON beside it)."""
    study.check_writable(doc)
    with study.session():
        info = run(study)
        text = report(study, info)
        write_text_atomic(doc, text)
        data = json_text({**info, "versions": software_versions()})  # what it ran on
        write_text_atomic(study.out / "study.json", data)
        if not study.args.quick:
            write_text_atomic(doc.with_suffix(".json"), data)
    print(f"\n{info['verdict']}\nwrote {doc} and {study.out / 'study.json'} in {info['seconds']:.0f} s")


if __name__ == "__main__":
    main()
