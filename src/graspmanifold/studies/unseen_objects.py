"""Does experience carry over to objects it was not built from? Paper experience on unseen objects.

    python scripts/bench_unseen.py [--preset quick|paper] [--size m] [--own-candidates N] [--grid quick]
                                    [--objects NAME ...] [--seed 0] [--position-noise M] [--yaw-noise RAD]
                                    [--preshape-control] [--workers 2] [--out unseen]

Experience is built from the paper's three objects (verified spring postures of the preset's sizes):
one 25 x 25 map per object, one map of all three, and the raw database of all three. It is then
used, unchanged, on objects it never saw: the object family (one size) and the paper's objects
20 % smaller and larger. On every target the plain heuristic (`none`) and the database and maps of
the paper objects run on the same grid poses (`--grid`, quick by default); the map built from the nearest paper object
(`starts.nearest_primitive`, by proportions) is `som_nearest`.
Finally experience built from each family object itself (`som_own`) shows what seen experience buys
there. `--preshape-control` adds the strongest simple control, `none_preshape`: the plain heuristic
closing from one constant preshape, the best (on the quick grid, same seed) of the starting-posture
cluster means of the nearest paper object's experience and of the object's own. Every rate has a
Wilson interval and every method is compared with `none` by McNemar's test on the hold outcomes.
Without noise a trial is a deterministic function of its grid pose (the seed then changes nothing);
`--position-noise`/`--yaw-noise` with another `--seed` move every pose by a fresh random offset, so
`--objects ... --seed 1 --position-noise 0.005` replicates a comparison on new poses. Writes
`OUT/unseen.md` (`OUT/unseen_seed<S>.md` for another seed) and prints it; posture sets are kept in OUT under the keys of
what made them.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict

import numpy as np

from ..base.checkpoints import result_key
from ..base.io import markdown_table, write_text_atomic
from ..control.controller import BLEND  # the controller docs/unseen_objects_*.md ran
from ..manifold.experience import PostureDatabase
from ..manifold.postureset import PostureSet
from ..sim.family import SHAPES
from ..sim.objects import GraspObject, get_object, make_object
from ..synthesis.generator import DATASET_PRESETS, GeneratorParams, generate_postures, verify_postures
from ..synthesis.starts import nearest_primitive
from ..trials.evaluation import evaluate
from ..trials.experience_pays import train_experience_map
from ..trials.stats import compare
from ..trials.stats import headroom, holm, rate_text
from ..trials.setup import Noise
from .runner import StudyRun, run_study


def posture_set(run: StudyRun, obj: GraspObject, n: int) -> PostureSet:
    """Those of n spring candidates of an object that hold, kept in the run's folder under the key of what made
    them."""
    params = GeneratorParams(verify=False)
    key = result_key({"object": obj.params(), "n": n, "seed": 0, "params": asdict(params)})
    return run.postures(obj.name, key, lambda parts: verify_postures(generate_postures(
        obj, n, seed=0, workers=run.workers, checkpoint_dir=parts, params=params), obj, run.workers))


def targets(size: str) -> list[GraspObject]:
    resized = []
    for factor in (0.8, 1.2):
        resized += [make_object("cylinder", radius=0.03 * factor, length=0.16 * factor),
                    make_object("sphere", radius=0.03 * factor),
                    make_object("box", size=(0.04 * factor, 0.04 * factor, 0.16 * factor))]
    return [get_object(f"{shape}_{size}") for shape in SHAPES] + resized


def best_constant_preshape(obj: GraspObject, sets: list[PostureSet], seed: int, workers: int,
                           noise: Noise) -> np.ndarray:
    """Of the sets' starting-posture cluster means, the one whose constant preshape holds most on the quick grid."""
    candidates = [s.postures[s.start_ids == i].mean(axis=0) for s in sets if len(s) for i in np.unique(s.start_ids)]
    rates = [evaluate(obj, None, "quick", seed=seed, workers=workers, noise=noise, preshape=c, params=BLEND).rate()
             for c in candidates]
    return candidates[int(np.argmax(rates))]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=sorted(DATASET_PRESETS), default="quick")
    parser.add_argument("--size", choices=("s", "m", "l"), default="m", help="size of the family objects")
    parser.add_argument("--own-candidates", type=int, help="candidates for each family object's own experience "
                        "(default: the preset's cylinder size)")
    parser.add_argument("--grid", choices=("quick", "paper"), default="quick", help="evaluation grid preset")
    parser.add_argument("--objects", nargs="+", help="only these targets (names as in the table)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the trial noise")
    parser.add_argument("--position-noise", type=float, default=0.0, help="object position noise (m, std)")
    parser.add_argument("--yaw-noise", type=float, default=0.0, help="object yaw noise (rad, std)")
    parser.add_argument("--preshape-control", action="store_true", help="add none_preshape, the best constant preshape")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="unseen")
    args = parser.parse_args(argv)
    run_study(args.out, args.workers, lambda run: _run(args, run, parser), pool=False)  # the generator's own pool


def _run(args: argparse.Namespace, run: StudyRun, parser: argparse.ArgumentParser) -> None:
    noise = Noise(position=args.position_noise, yaw=args.yaw_noise)
    paper = {name: posture_set(run, get_object(name), n) for name, n in DATASET_PRESETS[args.preset].items()}
    everything = PostureSet.concatenate(list(paper.values()))
    maps = {name: train_experience_map(s.postures) for name, s in paper.items()}
    maps["all"] = train_experience_map(everything.postures)
    lines = [f"# Paper experience on unseen objects ({args.preset} preset, {args.grid} grid, family size "
             f"{args.size})", "",
             f"Experience: {', '.join(f'{k} {len(v)}' for k, v in paper.items())} verified postures; own experience "
             f"of a family object from {args.own_candidates or DATASET_PRESETS[args.preset]['cylinder']} candidates. "
             f"{args.grid} grid, seed {args.seed}, pose noise {args.position_noise} m / {args.yaw_noise} rad; hold "
             "[95 % Wilson CI]; McNemar against `none` on the same poses (p).", ""]
    rows = []
    rooms, tests = [], []  # per object: the headroom over its methods; every comparison against none
    chosen = targets(args.size)
    if args.objects:
        unknown = set(args.objects) - {obj.name for obj in chosen}
        if unknown:
            parser.error(f"--objects: unknown {sorted(unknown)}; expected some of {[obj.name for obj in chosen]}")
        chosen = [obj for obj in chosen if obj.name in args.objects]
    for obj in chosen:
        methods = {"none": None, "database_all": PostureDatabase(everything.postures), "som_all": maps["all"],
                   "som_nearest": maps[nearest_primitive(obj)]}
        own = None
        if obj.shape == "mesh":
            own = posture_set(run, obj, args.own_candidates or DATASET_PRESETS[args.preset]["cylinder"])
            if len(own):
                methods["som_own"] = train_experience_map(own.postures)
        preshape = {}
        if args.preshape_control:
            sources = [paper[nearest_primitive(obj)]] + ([own] if own is not None else [])
            methods["none_preshape"] = None
            preshape["none_preshape"] = best_constant_preshape(obj, sources, args.seed, args.workers, noise)
        results = {m: evaluate(obj, e, args.grid, seed=args.seed, workers=args.workers, noise=noise,
                                  preshape=preshape.get(m), params=BLEND) for m, e in methods.items()}
        for method, result in results.items():
            s, n = result.summary, result.summary["trials"]
            c = compare(result, results["none"])
            versus = "" if method == "none" else f"{c.verdict()} (+{c.only_a}/−{c.only_b}, p {c.p_value:.2f})"
            rows.append([obj.name, method, n, rate_text(round(s["hold_rate"] * n), n),
                         rate_text(round(s["force_closure_rate"] * n), n), f"{s['mean_epsilon']:.4f}",
                         f"{s['mean_time_to_grasp']:.2f}", versus])
            if method != "none":
                tests.append((obj.name, method, c.p_value))
        room = headroom({m: r.outcomes() for m, r in results.items()}, {m: r.valid for m, r in results.items()})
        rooms.append((obj.name, room))
        run.log(f"{obj.name}: " + ", ".join(f"{m} {r.summary['hold_rate']:.0%}" for m, r in results.items()))
    lines += markdown_table(["object", "method", "trials", "hold", "force closure", "mean ε", "time to grasp (s)",
                             "vs none (hold)"], rows)
    lines += ["", "Headroom per object (`stats.headroom`: the per-pose oracle over the methods above against the best "
              "of them; under 15 points no choice among them can show much):", ""]
    lines += markdown_table(["object", "headroom"], [[name, room.text()] for name, room in rooms])
    adjusted = holm([p for _, _, p in tests]) if tests else np.zeros(0)
    significant = [f"{o}/{m} (adjusted p {p:.2g})" for (o, m, _), p in zip(tests, adjusted) if p < 0.05]
    lines += ["", f"Holm's correction over the {len(tests)} comparisons against `none`: "
              f"{', '.join(significant) if significant else 'none'} significant at 0.05.",
              "", f"{time.perf_counter() - run.started:.0f} s on this machine with {args.workers} workers."]
    report = run.out / ("unseen.md" if args.seed == 0 else f"unseen_seed{args.seed}.md")
    write_text_atomic(report, "\n".join(lines) + "\n")
    print(f"wrote {report}")


if __name__ == "__main__":
    main()
