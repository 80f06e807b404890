"""The experience study: where grasp choice matters, does recalling experience choose better than one preshape?

    python scripts/study_experience.py [--quick] [--workers 2] [--out study] [--doc docs/experience_study.md]

The benchmark (`graspmanifold.trials.benchmark`): the paper's three objects and four small or flat ones
(marble, pen, disc, cube), each placed near the palm and out at the fingertips; the controller is
never told which object it grasps. The study, in the order a careful reviewer would ask for it:

1. Experience of every grasp type: for each object `--postures` verified postures from the designs of
   every grasp type (power wraps, pinch, tripod, lateral: `GeneratorParams(designs="grasp_types")`),
   all objects in one set: one 25 x 25 SOM and one database for all of them.
2. Strategies fixed before any test: the plain heuristic and one constant preshape per grasp type (the
   mean of the experience's postures of that type).
3. Selection, on the selection grid only (no value shared with the test grid): the best shared preshape
   (pooled over all objects: the control), the best preshape per object (an upper reference that knows
   the object), and the SOM controller's variant (`SOM_VARIANTS`: the paper's, the recall restarting
   the closure, and that with the palm moved by up to 3 cm).
4. Headroom, on the test grid, before any method comparison: the per-pose oracle over the strategies
   against the best of them, per object and pooled, and beside it the oracle of the plain heuristic and
   a rerun of it with 1 mm / 0.02 rad pose noise: the part of any headroom that is chance.
5. Test: the methods on the test grid, paired (McNemar) against the shared preshape, with Holm's
   correction over each family of comparisons; rates with Wilson intervals; the target judged.

Every method runs the blend controller (`controller.BLEND`, the library's controller when this study was
run; `params` default to it), the paper's reading of phase C is not in it yet.

Every finished evaluation is kept in --out, so an interrupted study resumes. Writes `--out/study.json`
and the markdown report `--doc` (with `--quick`: a CI-sized run of two objects and an eighth of the
poses into `study-quick/`). The first study, on the paper's grids, is
`scripts/study_experience_paper_grids.py`; its verdict is quoted in the report from
`docs/experience_study_paper_grids.json`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

import graspmanifold as gm
from graspmanifold.base.checkpoints import PartStore, remove_checkpoints, result_key
from graspmanifold.base.errors import GraspManifoldError
from graspmanifold.base.io import LOCK_FILE, output_lock, write_text_atomic
from graspmanifold.base.validation import check_int
from graspmanifold.base.workers import worker_pool, workers_for
from graspmanifold.control.controller import BLEND
from graspmanifold.trials.benchmark import OBJECTS, PLACEMENTS, benchmark_grid, cells, pooled, run_benchmark
from graspmanifold.trials.stats import MIN_HEADROOM, headroom, holm, mcnemar, rate_text
from graspmanifold.trials.study import train_experience_map

#: the target of issue 23, pooled over the test grid
TARGET_POINTS, TARGET_P, TARGET_POSES, TARGET_GAP_SHARE = 0.08, 0.01, 600, 0.5
#: the pose noise of the rerun that measures how much of the headroom is chance
JITTER = gm.Noise(position=0.001, yaw=0.02)
QUICK_OBJECTS = ("box", "marble")
#: the SOM controller's variants, one of which the selection grid picks: the paper's controller, the recall
#: restarting the closure, and that with the palm moved by up to 3 cm (ControllerParams.reach)
SOM_VARIANTS = {"som_paper": BLEND, "som_restart": replace(BLEND, restart_closure=True),
                "som_reach": replace(BLEND, restart_closure=True, reach=0.03)}
SOM_DESCRIPTIONS = {"som_paper": "the blend (BLEND)", "som_restart": "replace(BLEND, restart_closure=True)",
                    "som_reach": "replace(BLEND, restart_closure=True, reach=0.03)"}


class Study:
    def __init__(self, args: argparse.Namespace):
        self.args, self.out = args, Path(args.out)
        self.out.mkdir(parents=True, exist_ok=True)
        self.started = time.perf_counter()
        self.objects = QUICK_OBJECTS if args.quick else tuple(OBJECTS)
        self.results: dict[tuple[str, str], dict] = {}  # (split, method) -> {(object, placement): EvaluationResult}
        self.executor = None  # one pool of worker processes for the whole study (see main)
        self.reused, self.evaluations = 0, 0  # (object, placement) evaluations taken from --out, and all of them

    def log(self, text: str) -> None:
        print(f"[{time.perf_counter() - self.started:6.0f} s] {text}", flush=True)

    def run(self, split: str, method: str, experience=None, params=None, preshape=None, noise=None,
            controller=None) -> dict:
        """One method on every cell of a split, kept in --out/evaluation."""
        every = (8 if split == "test" else 6) if self.args.quick else 1
        start = time.perf_counter()
        stored = self.out / "evaluation"
        self.reused += sum((stored / f"{method}_{split}_{o}_{p}.npz").exists() for o, p in cells() if o in self.objects)
        self.evaluations += sum(o in self.objects for o, _ in cells())
        results = run_benchmark(experience, split=split, params=params or (None if controller else BLEND),
                                preshape=preshape, noise=noise, controller=controller,
                                objects=self.objects, every=every, workers=self.args.workers,
                                store=self.out / "evaluation", label=method, executor=self.executor)
        self.results[(split, method)] = results
        outcomes, valid = pooled(results)
        self.log(f"{split:9s} {method:22s} hold {rate_text(int(outcomes[valid].sum()), int(valid.sum()))} "
                 f"({time.perf_counter() - start:.0f} s)")
        return results


def _read_experience(path: Path) -> tuple[gm.PostureSet, dict]:
    postures = gm.PostureSet.load(path)
    return postures, postures.metadata


def experience(study: Study) -> tuple[gm.PostureSet, dict[str, gm.PostureSet]]:
    """Verified postures of every grasp type per object, kept in --out under the key of what made them (the
    object, the number of postures, the generator's parameters and the code: `checkpoints.result_key`), and
    their union."""
    sets = {}
    params = gm.GeneratorParams(designs="grasp_types", max_candidates_per_posture=10 if study.args.quick else 50)
    for name in study.objects:
        obj, file_name = OBJECTS[name].object, f"experience_{name}.npz"
        store = PartStore(study.out, result_key({"object": obj.params(), "n": study.args.postures, "seed": 0,
                                                 "params": asdict(params)}), _read_experience)
        stored = store.load(file_name)
        if stored:
            sets[name] = stored[study.out / file_name]
            continue
        start = time.perf_counter()
        parts = study.out / f"experience_{name}.parts"
        postures = gm.generate_postures(obj, study.args.postures, seed=0, workers=study.args.workers,
                                        executor=study.executor, params=params, checkpoint_dir=parts)
        store.save(file_name, lambda target, meta: replace(postures, metadata={**postures.metadata, **meta}).save(target))
        remove_checkpoints(parts)
        study.log(f"experience {name}: {len(postures)} postures from {postures.metadata['candidates']} "
                  f"candidates ({time.perf_counter() - start:.0f} s)")
        sets[name] = postures
    return gm.PostureSet.concatenate(list(sets.values())), sets


def grasp_type_preshapes(sets: dict[str, gm.PostureSet]) -> dict[str, np.ndarray]:
    """One constant preshape per grasp type: the mean of the experience's postures of that type."""
    by_type: dict[str, list[np.ndarray]] = {}
    for postures in sets.values():
        types = postures.metadata["grasp_types"]
        for i, name in enumerate(postures.start_names):
            rows = postures.postures[postures.start_ids == i]
            if len(rows):
                by_type.setdefault(types[name.split(":", 1)[1]], []).append(rows)
    return {f"preshape_{t}": np.concatenate(rows).mean(axis=0) for t, rows in sorted(by_type.items())}


def rate(results: dict, rows: list | None = None) -> float:
    outcomes, valid = pooled(results, rows=rows)
    return float(outcomes[valid].mean())


def compare(a: dict, b: dict, rows: list | None = None):
    """McNemar of method a against method b, pooled over `rows` (cells), poses valid for both."""
    (oa, va), (ob, vb) = pooled(a, rows=rows), pooled(b, rows=rows)
    both = va & vb
    return mcnemar(oa[both], ob[both])


def object_rows(name: str) -> list[tuple[str, str]]:
    return [(name, p) for p in PLACEMENTS]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two objects, an eighth of the poses (CI-sized)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None, help="data directory (default: study or study-quick)")
    parser.add_argument("--doc", default=None, help="markdown report (default: docs/experience_study.md; with "
                        "--quick: OUT/experience_study.md)")
    parser.add_argument("--postures", type=int, default=None, help="verified postures per object (default 48; "
                        "quick: 7)")
    args = parser.parse_args()
    args.out = args.out or ("study-quick" if args.quick else "study")
    args.postures = 7 if args.quick and args.postures is None else 48 if args.postures is None else args.postures
    doc = Path(args.doc or (Path(args.out) / "experience_study.md" if args.quick else "docs/experience_study.md"))
    try:  # every argument checked before --out is made
        args.postures = check_int(args.postures, "--postures")
        args.workers = workers_for(args.workers, 10**6, 1)  # capped at the cores: the trials always outnumber them
        with output_lock(Path(args.out) / LOCK_FILE, args.out):
            study = Study(args)
            with worker_pool(args.workers) as pool:  # started once: a pool per evaluation costs seconds on small grids
                study.executor = pool if args.workers > 1 else None
                info = run(study)
            write_report(study, info, doc)
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished evaluations are kept in {args.out}; run the same command again to resume",
              file=sys.stderr)
        raise SystemExit(130) from None
    except GraspManifoldError as error:
        raise SystemExit(f"error: {error}") from None


def write_report(study: Study, info: dict, doc: Path) -> None:
    """The report, study.json (and, for the full study, the report's JSON beside it)."""
    args = study.args
    write_text_atomic(doc, report(study, info))
    data = json.dumps(info, indent=1, default=float)
    write_text_atomic(study.out / "study.json", data)
    if not args.quick:
        write_text_atomic(doc.with_suffix(".json"), data)
    print(f"\n{info['verdict']}\nwrote {doc} and {study.out / 'study.json'} in {info['seconds']:.0f} s")


def run(study: Study) -> dict:
    union, sets = experience(study)
    som = train_experience_map(union.postures)
    database = gm.PostureDatabase(union.postures)
    preshapes = grasp_type_preshapes(sets)

    # selection: the controls and the SOM's switch, on the selection grid only
    strategies = {"none": None, **preshapes}
    for name, posture in strategies.items():
        study.run("selection", name, preshape=posture)
    for name, params in SOM_VARIANTS.items():
        study.run("selection", name, som, params)
    selection = {m: study.results[("selection", m)] for m in strategies}
    shared = max(preshapes, key=lambda m: (rate(selection[m]), m))
    per_object = {o: max(strategies, key=lambda m: (rate(selection[m], object_rows(o)), m)) for o in study.objects}
    per_cell = {key: max(strategies, key=lambda m: (rate(selection[m], [key]), m))
                for key in cells() if key[0] in study.objects}
    order = list(SOM_VARIANTS)  # on a tie the simpler variant (earlier in SOM_VARIANTS) wins
    tuned = max(order, key=lambda m: (rate(study.results[("selection", m)]), -order.index(m)))
    som_params = SOM_VARIANTS[tuned]
    study.log(f"selected: shared preshape {shared}; per object {per_object}; SOM {tuned}")

    # headroom on the test grid, before any method comparison
    test = {m: study.run("test", m, preshape=p) for m, p in strategies.items()}
    test["none_rerun"] = study.run("test", "none_rerun", noise=JITTER)

    def room(methods: list[str], rows=None):
        outcomes = {m: pooled(test[m], rows=rows) for m in methods}
        return headroom({m: o for m, (o, _) in outcomes.items()}, {m: v for m, (_, v) in outcomes.items()})

    headroom_rows = []
    for rows, label in [(object_rows(o), o) for o in study.objects] + [(None, "pooled")]:
        strategy_room, chance = room(list(strategies), rows), room(["none", "none_rerun"], rows)
        headroom_rows.append({"object": label, "n": strategy_room.n, "oracle": strategy_room.oracle,
                              "best": strategy_room.best, "best_successes": strategy_room.best_successes,
                              "gain": strategy_room.gain, "neither": strategy_room.neither,
                              "chance_gain": chance.gain, "chance_n": chance.n, "rates": strategy_room.rates})

    # the methods on the test grid
    test["shared_preshape"] = test[shared]
    test["per_object_preshape"] = {key: test[per_object[key[0]]][key] for key in test["none"]}
    test["per_placement_preshape"] = {key: test[per_cell[key]][key] for key in test["none"]}
    for name, params in SOM_VARIANTS.items():  # the selected one and, as ablations, the others
        test[name] = study.run("test", name, som, params)
    test["som"] = test[tuned]
    test["database"] = study.run("test", f"database_{tuned}", database, som_params)
    test["som_preshaped"] = study.run("test", f"som_preshaped_{tuned}_{shared}", som, som_params,
                                      preshape=preshapes[shared])

    # comparisons, each family corrected by Holm
    families = {}
    primary = [("pooled", compare(test["som"], test["shared_preshape"]))]
    primary += [(o, compare(test["som"], test["shared_preshape"], object_rows(o))) for o in study.objects]
    families["som against the shared preshape (primary)"] = primary
    families["som against the plain heuristic"] = [("pooled", compare(test["som"], test["none"]))] + [
        (o, compare(test["som"], test["none"], object_rows(o))) for o in study.objects]
    others = ["database", *(m for m in SOM_VARIANTS if m != tuned), "som_preshaped", "per_object_preshape",
              "per_placement_preshape"]
    families["other methods against the shared preshape, pooled"] = [
        (m, compare(test[m], test["shared_preshape"])) for m in others]
    comparisons = []
    for family, tests in families.items():
        adjusted = holm([c.p_value for _, c in tests])
        for (label, c), p in zip(tests, adjusted):
            comparisons.append({"family": family, "label": label, "n": c.n, "only_a": c.only_a, "only_b": c.only_b,
                                "both": c.both, "p_value": c.p_value, "p_holm": float(p),
                                "difference": c.difference})

    # the target
    main = next(c for c in comparisons if c["family"].endswith("(primary)") and c["label"] == "pooled")
    worse = [c["label"] for c in comparisons if c["family"].endswith("(primary)") and c["label"] != "pooled"
             and c["p_holm"] < 0.05 and c["only_a"] < c["only_b"]]
    shared_rate, perobj_rate, som_rate = (rate(test[m]) for m in ("shared_preshape", "per_object_preshape", "som"))
    gap = perobj_rate - shared_rate
    closed = (som_rate - shared_rate) / gap if gap > 0 else float("nan")
    pooled_room = headroom_rows[-1]
    checks = {
        "headroom": pooled_room["gain"] / pooled_room["n"] >= MIN_HEADROOM,
        "poses": main["n"] >= TARGET_POSES,
        "points": main["difference"] >= TARGET_POINTS,
        "significant": main["p_holm"] < TARGET_P and main["only_a"] > main["only_b"],
        "no object worse": not worse,
        "half the gap": gap > 0 and closed >= TARGET_GAP_SHARE,
    }
    met = all(checks.values())
    verdict = (f"Target {'met' if met else 'not met'}: on {main['n']} paired test poses the one-for-all SOM "
               f"controller holds {som_rate:.1%} against the best shared constant preshape's ({shared}) "
               f"{shared_rate:.1%}, {100 * main['difference']:+.1f} points (+{main['only_a']} / -{main['only_b']} "
               f"discordant poses, McNemar p = {main['p_value']:.2g}, Holm-adjusted {main['p_holm']:.2g}); the "
               f"per-object preshape (which knows the object) holds {perobj_rate:.1%}, " +
               (f"so the SOM closes {closed:.0%} of that gap" if gap > 0 else
                "no more than the shared one, so there is no gap to close") +
               (f" (a gap inside the noise: per-object against shared preshape p = "
                f"{next(c['p_value'] for c in comparisons if c['label'] == 'per_object_preshape'):.2g})"
                if gap > 0 else "") + (f"; significantly worse on {', '.join(worse)}" if worse else
                                              "; significantly worse on no object") +
               f". Pooled headroom {100 * pooled_room['gain'] / pooled_room['n']:.1f} points: "
               + (f"the benchmark can show a recall effect (at least {MIN_HEADROOM:.0%})." if checks["headroom"] else
                  f"below {MIN_HEADROOM:.0%}, so the benchmark cannot show a recall effect."))
    shared_rate = rate(test["shared_preshape"])
    by_placement = {m: {p: rate(test[m], [(o, p) for o in study.objects]) for p in PLACEMENTS}
                    for m in ("none", "shared_preshape", "per_object_preshape", "som")}
    apart = []  # how far the SOM's final grasp lies from the shared preshape's, pose by pose
    for key in test["som"]:
        a, b = test["som"][key], test["shared_preshape"][key]
        both = a.valid() & b.valid()
        final = np.array([t.posture for t in a.trials])[both] - np.array([t.posture for t in b.trials])[both]
        apart.append(np.degrees(np.sqrt(np.mean(final ** 2, axis=1))))
    apart = np.concatenate(apart)
    perobj_test = next(c for c in comparisons if c["label"] == "per_object_preshape")
    info_why = {"by_placement": by_placement, "final_rms_deg_median": float(np.median(apart)),
                "final_rms_deg_over_5": float(np.mean(apart > 5.0)),
                "knowing": {c["label"]: c["difference"] for c in comparisons
                            if c["label"] in ("per_object_preshape", "per_placement_preshape")},
                "oracle_gain": pooled_room["gain"] / pooled_room["n"], "per_object_p": perobj_test["p_value"]}
    info = {"objects": list(study.objects), "quick": study.args.quick, "postures_per_object": study.args.postures,
            "why": info_why,
            "experience": {n: {"postures": len(s), "candidates": s.metadata["candidates"],
                               "verified_by_start": s.metadata["verified_by_start"],
                               "kept_by_start": s.metadata["kept_by_start"],
                               "grasp_types": s.metadata["grasp_types"]} for n, s in sets.items()},
            "selected": {"shared": shared, "per_object": per_object, "som": tuned,
                         "per_placement": {f"{o}/{p}": m for (o, p), m in per_cell.items()}},
            "selection_rates": {f"{split}/{m}": rate(r) for (split, m), r in study.results.items() if split == "selection"},
            "headroom": headroom_rows, "comparisons": comparisons, "checks": checks, "target_met": met,
            "verdict": verdict,
            "rates": {m: {f"{o}/{p}": rate(r, [(o, p)]) for (o, p) in r} for m, r in test.items()},
            "counts": {m: {f"{o}/{p}": [int(r[(o, p)].outcomes()[r[(o, p)].valid()].sum()), int(r[(o, p)].valid().sum())]
                           for (o, p) in r} for m, r in test.items()},
            "seconds": time.perf_counter() - study.started, "reused": study.reused, "evaluations": study.evaluations}
    return info


def report(study: Study, info: dict) -> str:
    args = study.args
    selected = info["selected"]
    lines = ["# Does experience pay where grasp choice matters? The experience study", "",
             f"Generated by `python scripts/study_experience.py{' --quick' if args.quick else ''} --workers "
             f"{args.workers}` in {info['seconds']:.0f} s ({info['reused']} of {info['evaluations']} evaluations taken "
             "from an earlier run in --out). Every rate is the hold test (gravity along six directions, "
             "the object within 2 cm) with its 95 % Wilson interval; comparisons are paired on the same poses "
             "(McNemar's exact test) and corrected for their family (Holm).", "",
             "## Verdict", "", info["verdict"], ""]
    lines += ["Target (issue 23): on a benchmark with at least 15 points of pooled headroom, the one-for-all-objects "
              "SOM controller beats the best shared constant preshape by at least 8 points pooled over at least 600 "
              "paired poses (Holm-adjusted McNemar p < 0.01), is significantly worse on no object, and closes at least "
              "half of the gap to the per-object preshape. Checks: " + ", ".join(
                  f"{k} {'yes' if v else 'no'}" for k, v in info["checks"].items()) + ".", ""]
    why = info["why"]
    lines += ["## Why", "",
              "- Hold rate by placement, pooled over the objects (none / shared preshape / per-object preshape / SOM): "
              + "; ".join(f"{p} " + " / ".join(f"{why['by_placement'][m][p]:.0%}" for m in why["by_placement"])
                          for p in PLACEMENTS) + ".",
              f"- Where the headroom lies: the per-pose oracle over the strategies gains {100 * why['oracle_gain']:.1f} points "
              f"over the best single strategy, but knowing the object and choosing its best preshape (on the selection "
              f"grid) gains only {100 * why['knowing']['per_object_preshape']:+.1f} points on the test grid (p = "
              f"{why['per_object_p']:.2g}), and knowing the object and the placement "
              f"{100 * why['knowing']['per_placement_preshape']:+.1f}"
              + (": which preshape holds changes from pose to pose within one object and placement, so a choice by "
                 "object or grasp type, which is what a recall from the first contacts can make, cannot reach most of "
                 "it." if why["knowing"]["per_placement_preshape"] < why["oracle_gain"] / 2 else
                 ": most of it lies in choosing by object and placement."),
              f"- The SOM's final grasp against the shared preshape's on the same pose: median RMS difference "
              f"{why['final_rms_deg_median']:.1f} degrees per joint; {why['final_rms_deg_over_5']:.0%} of the poses "
              "differ by more than 5 degrees.", ""]
    lines += ["## The benchmark", "", "Objects (`graspmanifold.trials.benchmark.OBJECTS`), each chosen for a reason stated "
              "before any method ran on it, placed near the palm and out at the fingertips "
              "(`benchmark_grid`); the controller is never told the object.", "",
              "| object | size | mass | asks for | why | test poses (palm / fingertips) | selection poses |",
              "|---|---|---|---|---|---|---|"]
    for name in info["objects"]:
        b = OBJECTS[name]
        size = " x ".join(f"{100 * 2 * h:.1f}" for h in b.object.half_extents) + " cm"
        counts = " / ".join(str(len(benchmark_grid(name, p))) for p in PLACEMENTS)
        selection = sum(len(benchmark_grid(name, p, "selection")) for p in PLACEMENTS)
        lines.append(f"| {name} | {size} | {b.object.mass * 1000:.0f} g | {b.grasp} | {b.reason} | {counts} | "
                     f"{selection} |")
    lines += ["", "## Experience of every grasp type", "",
              f"{args.postures} verified postures per object (the generator draws candidates until that many hold when "
              "replayed: `generate_postures(obj, n)` with `GeneratorParams(designs='grasp_types')`); all objects in one "
              "set, one 25 x 25 SOM and one database. Verified share of the candidates per starting design (kept "
              "postures in brackets; a design the budget gave up on keeps none):", "",
              "| object | candidates | verified share by design (kept) |", "|---|---|---|"]
    for name, e in info["experience"].items():
        shares = ", ".join(f"{d} ({e['grasp_types'][d]}) {v:.0%} ({e['kept_by_start'].get(d, 0)})"
                           for d, v in e["verified_by_start"].items())
        lines.append(f"| {name} | {e['candidates']} | {shares} |")
    lines += ["", "## Selection (selection grid only)", "",
              "| method | pooled hold on the selection grid |", "|---|---|"]
    lines += [f"| {m.split('/', 1)[1]} | {r:.1%} |" for m, r in info["selection_rates"].items()]
    lines += ["", f"Chosen before the test: shared preshape **{selected['shared']}**; per-object preshape "
              + ", ".join(f"{o} {m}" for o, m in selected["per_object"].items())
              + f"; SOM controller **{selected['som']}** ({SOM_DESCRIPTIONS[selected['som']]}).", ""]
    lines += ["## Headroom (test grid)", "",
              "The per-pose oracle over the strategies (the plain heuristic and one constant preshape per grasp type) "
              "against the best single one (`graspmanifold.trials.stats.headroom`). Beside it, the same oracle over the plain "
              "heuristic and a rerun of it with 1 mm / 0.02 rad pose noise: what two runs of one strategy gain by "
              "chance alone.", "",
              "| object | n | oracle | best strategy | headroom | chance (heuristic + its rerun) | held by none |",
              "|---|---|---|---|---|---|---|"]
    for h in info["headroom"]:
        lines.append(f"| {h['object']} | {h['n']} | {rate_text(h['oracle'], h['n'])} | {h['best']} "
                     f"{rate_text(h['best_successes'], h['n'])} | **{rate_text(h['gain'], h['n'])}** | "
                     f"{rate_text(h['chance_gain'], h['chance_n'])} | {h['neither']} |")
    lines += ["", "## Hold rate per method (test grid)", ""]
    methods = list(info["counts"])
    keys = list(info["counts"]["none"])
    lines += ["| method | " + " | ".join(keys) + " | pooled |", "|---|" + "---|" * (len(keys) + 1)]
    for m in methods:
        cells_text = [rate_text(*info["counts"][m][k]) for k in keys]
        k_all = sum(c[0] for c in info["counts"][m].values())
        n_all = sum(c[1] for c in info["counts"][m].values())
        lines.append(f"| {m} | " + " | ".join(cells_text) + f" | {rate_text(k_all, n_all)} |")
    lines += ["", "## Paired comparisons", "",
              "`+` / `-`: poses where only the first / only the second method held. Holm's correction within each "
              "family.", "", "| family | comparison | n | + | - | difference | p | p (Holm) |", "|---|---|---|---|---|---|---|---|"]
    for c in info["comparisons"]:
        lines.append(f"| {c['family']} | {c['label']} | {c['n']} | {c['only_a']} | {c['only_b']} | "
                     f"{100 * c['difference']:+.1f} pts | {c['p_value']:.3g} | {c['p_holm']:.3g} |")
    lines += ["", "## The first study, on the paper's grids", ""]
    old = Path("docs/experience_study_paper_grids.md")
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
                  "`docs/experience_study_paper_grids.md`).", ""]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
