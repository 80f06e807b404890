"""Our grasps judged the way the field judges them: DexGraspBench's protocol beside our hold test.

    python scripts/study_protocols.py [--postures 16] [--every 4] [--verify-postures 12] [--held-out]
                                      [--workers 2] [--out protocols] [--doc docs/studies/protocols.md]

On the benchmark's objects (the paper's box, cylinder and sphere, and the marble, pen, disc and cube):
our verified grasps replayed open loop (`replay.replay`: pregrasp the open hand, grasp, squeeze), and
the plain heuristic and the paper's controller (recalling from a SOM of the object's verified postures)
closed loop on every `--every`-th pose of the benchmark's test lattice; each judged by our hold test and by
DexGraspBench's external-force test in both its versions. Rates with Wilson intervals; McNemar's test
pairs the two controllers on the same poses, and each protocol against ours on the same grasps (open loop)
or poses (closed loop; the grasp itself is made under each protocol's physics). Finished evaluations are
kept in --out (a rerun resumes). First, what verification by replay gives over every object of the benchmark and
the test family (`studies.verification`: yield, speed, both protocols, grasp types, Q1, penetration, what limits
the hand under DexGraspBench's pushes); `--held-out` adds the family's held-out members (once, at the end).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..base.io import markdown_table, write_text_atomic
from ..base.progress import show_progress
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOL_NAMES
from ..judging.plans import open_loop_grasps
from ..judging.replay import replay
from ..synthesis.generator import generate_postures
from ..trials.benchmark import OBJECTS, PLACEMENTS, compare_pooled, pooled, run_benchmark
from ..trials.experience_pays import train_experience_map
from ..trials.stats import mcnemar, rate_text
from .runner import StudyRun, comparison_table, holm_family, run_command
from .verification import Verification, measure, section


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--postures", type=int, default=16, help="verified postures per object (replay, controllers)")
    parser.add_argument("--every", type=int, default=4, help="every k-th pose of the test lattice")
    parser.add_argument("--verify-postures", type=int, default=12,
                        help="verified postures per object and verifying protocol (verification by replay)")
    parser.add_argument("--held-out", action="store_true", help="add the family's held-out members to verification")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="protocols")
    parser.add_argument("--doc", default="docs/studies/protocols.md")
    args = parser.parse_args(argv)
    study = StudyRun(args.out, args.workers)
    study.check_writable(args.doc)
    run_command(args.out, lambda: _run(args, study))


def _run(args: argparse.Namespace, study: StudyRun) -> None:
    started = time.perf_counter()
    out = Path(args.out)
    open_loop: dict[str, dict[str, np.ndarray]] = {}  # object -> protocol -> held per grasp
    closed: dict[tuple[str, str], dict] = {}  # (controller, protocol) -> {(object, placement): EvaluationResult}
    soms = {}
    with study.session():
        verification = measure(study, args.verify_postures, args.held_out)
    for name, entry in OBJECTS.items():
        postures = generate_postures(entry.object, args.postures, seed=0, workers=args.workers, progress=False)
        grasps = open_loop_grasps(postures, obj=entry.object)
        open_loop[name] = {p: replay(entry.object, grasps, p)[0] for p in PROTOCOL_NAMES}
        soms[name] = train_experience_map(postures.postures)
        print(f"[{time.perf_counter() - started:5.0f} s] {name}: open loop " + ", ".join(
            f"{p} {held.sum()}/{len(held)}" for p, held in open_loop[name].items()), flush=True)
    shown = show_progress(False)  # the study's log says what runs
    try:
        for protocol in PROTOCOL_NAMES:
            closed[("heuristic", protocol)] = run_benchmark(None, every=args.every, workers=args.workers, store=out,
                                                            method=f"heuristic_{protocol}", protocol=protocol)
            closed[("paper", protocol)] = {}
            for name in OBJECTS:  # the paper's controller recalls from the object's own SOM, as in the paper
                closed[("paper", protocol)].update(run_benchmark(
                    soms[name], objects=(name,), every=args.every, workers=args.workers, store=out,
                    method=f"paper_{name}_{protocol}", protocol=protocol))
            print(f"[{time.perf_counter() - started:5.0f} s] closed loop under {protocol}", flush=True)
    finally:
        show_progress(shown)
    write_text_atomic(Path(args.doc), report(args, verification, open_loop, closed, time.perf_counter() - started))
    print(f"wrote {args.doc}")


def report(args: argparse.Namespace, verification: Verification, open_loop: dict, closed: dict, seconds: float) -> str:
    lines = ["# Our grasps judged the way the field judges them", "",
             f"Generated by `python scripts/study_protocols.py --postures {args.postures} --every {args.every} "
             f"--verify-postures {args.verify_postures}{' --held-out' if args.held_out else ''} --workers "
             f"{args.workers}` in {seconds:.0f} s on the two-core machine. Protocols: ours (gravity along ±x, ±y, ±z for 0.5 s "
             "each, the object within 2 cm; 2 ms step, a spring support while the hand closes); DexGraspBench's main "
             "version (a push of 10 N/kg x 0.1 kg along each direction for 2 s, each from the grasp's end, within "
             "5 cm and 15°; 4 ms step, impratio 10, condim 4, noslip 2, friction 0.6 / 0.02) and its paper's "
             "(0.03 kg, within 10 cm and 180°). Rates with 95 % Wilson intervals; Holm over each section's paired "
             "comparisons.", ""]
    verifying, verification_tests = section(verification)
    lines += [*verifying, "", "#### Paired comparisons (verification)", "",
              "`+` / `-`: grasps held only under the first / only under the second.", "",
              *comparison_table(holm_family(verification_tests)), "",
              "## Open loop: our verified grasps replayed as DexGraspBench replays grasps", "",
              f"{args.postures} verified postures per object (`generate_postures`, the defaults: verified under ours), "
              "each replayed (`plans.open_loop_grasps`, `replay`): the pregrasp, the posture at its palm pose, "
              "its squeeze (the stages it was verified with), in 10 targets of 10 steps each (under ours, the same "
              "seconds at our step), the object free and unsupported, gravity off; the same grasps under each "
              "protocol (McNemar against ours, pooled).", ""]
    pooled_open = {p: np.concatenate([held[p] for held in open_loop.values()]) for p in PROTOCOL_NAMES}
    lines += markdown_table(["object", *PROTOCOL_NAMES], [
        [name, *(rate_text(int(h.sum()), len(h)) for h in held.values())]
        for name, held in [*open_loop.items(), ("pooled", pooled_open)]])
    tests = [(f"open loop, {p} against {DEFAULT_PROTOCOL}, pooled", mcnemar(pooled_open[p], pooled_open[DEFAULT_PROTOCOL]))
             for p in PROTOCOL_NAMES if p != DEFAULT_PROTOCOL]
    lines += ["", "## Closed loop: the plain heuristic and the paper's controller on the benchmark's poses", "",
              f"Every {args.every}th pose of the benchmark's test lattice (`benchmark_grid`, both placements); the "
              "paper's controller (`ControllerParams()`, recall='target') recalls from a 25 x 25 SOM of the object's "
              "verified postures. Each protocol's physics from the trial's start.", ""]

    def closed_cells(name: str) -> list[str]:
        rows = None if name == "pooled" else [(name, p) for p in PLACEMENTS]
        held_valid = [pooled(closed[(c, p)], rows=rows) for c in ("heuristic", "paper") for p in PROTOCOL_NAMES]
        return [name, *(rate_text(int(held[valid].sum()), int(valid.sum())) for held, valid in held_valid)]

    lines += markdown_table(["object", *(f"{c} / {p}" for c in ("heuristic", "paper") for p in PROTOCOL_NAMES)],
                            [closed_cells(name) for name in [*OBJECTS, "pooled"]])
    for protocol in PROTOCOL_NAMES:
        tests.append((f"closed loop under {protocol}: the paper's controller against the heuristic, pooled",
                      compare_pooled(closed[("paper", protocol)], closed[("heuristic", protocol)])))
    for controller in ("heuristic", "paper"):
        for protocol in (p for p in PROTOCOL_NAMES if p != DEFAULT_PROTOCOL):
            tests.append((f"closed loop, {controller}: {protocol} against ours, pooled (same poses)",
                          compare_pooled(closed[(controller, protocol)], closed[(controller, DEFAULT_PROTOCOL)])))
    lines += ["", "Trials whose physics failed (a contact deeper than 5 mm, a MuJoCo warning) are left out of the "
              "rates and of every pair: " + "; ".join(
                  f"{c} / {p} {sum(int((~r.valid).sum()) for r in closed[(c, p)].values())}"
                  for c in ("heuristic", "paper") for p in PROTOCOL_NAMES) + " of "
              f"{sum(len(r.trials) for r in closed[('heuristic', DEFAULT_PROTOCOL)].values())} poses."]
    lines += ["", "## Paired comparisons (replay and closed loop)", "", "`+` / `-`: poses or grasps held only under the "
              "first / only under the second. Holm over this table.", "", *comparison_table(holm_family(tests))]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
