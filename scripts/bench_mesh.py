"""The paper's cylinder as a mesh and as a primitive: the same generator seed, the same grid.

    python scripts/bench_mesh.py [--n 1000] [--workers 2] [--grid paper] [--sections 128]

Generates `--n` candidates on each (same seed) and compares what the posture sets look like
(acceptance ratio, verified ratio with Wilson intervals, cluster spread within and between starting
postures), then evaluates the plain heuristic and the raw database of each set on the grid and
compares them trial by trial (McNemar). Also the generation speed: wall time per candidate, the
mesh against the primitive in the same run.
"""

from __future__ import annotations

import argparse
import os
import time

import trimesh

import graspmanifold as gm
from graspmanifold.control.controller import BLEND  # the controller BENCHMARKS.md's mesh rows ran
from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.trials.stats import mcnemar, rate_text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--grid", default="paper")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sections", type=int, default=128, help="sides of the mesh prism (128: the family's "
                        "cylinder_mesh)")
    args = parser.parse_args()
    mesh = (gm.get_object("cylinder_mesh") if args.sections == 128 else gm.make_object(
        "mesh", mesh=trimesh.creation.cylinder(radius=0.03, height=0.16, sections=args.sections),
        name=f"cylinder_{args.sections}"))
    objects = {"primitive": gm.get_object("cylinder"), "mesh": mesh}
    print(f"{os.cpu_count()} cores, {args.workers} workers, {args.n} candidates, seed {args.seed}, "
          f"{len(objects['mesh'].mesh.faces)}-triangle mesh\n")
    sets, seconds = {}, {}
    for label, obj in objects.items():
        gm.starting_postures(obj)  # shipped for both; not part of the timing
        start = time.perf_counter()
        candidates = gm.generate_postures(obj, args.n, seed=args.seed, workers=args.workers,
                                          params=gm.GeneratorParams(verify=False))
        sets[label] = gm.verify_postures(candidates, obj, args.workers)  # the n candidates that hold
        seconds[label] = time.perf_counter() - start
    print("\n".join(markdown_table(["cylinder", "wall (s)", "ms / candidate", "acceptance", "verified [95 % CI]", "within-start (°)", "between starts (°)"], [])))
    for label, postures in sets.items():
        sep, meta = postures.cluster_separation(), postures.metadata
        print(markdown_row([label, f"{seconds[label]:.1f}", f"{1000 * seconds[label] / args.n:.1f}",
                            f"{meta['acceptance_ratio']:.3f}", rate_text(len(postures), args.n),
                            f"{sep['within_deg']:.2f}", f"{sep['between_deg']:.2f}"]))
    print(f"\nmesh / primitive generation time: {seconds['mesh'] / seconds['primitive']:.2f}x\n")

    print("\n".join(markdown_table(["method", "primitive", "mesh", "only primitive", "only mesh", "McNemar p"], [])))
    for method in ("none", "database"):
        results = {label: gm.evaluate(obj, None if method == "none" else sets[label], args.grid, seed=args.seed,
                                      workers=args.workers, params=BLEND) for label, obj in objects.items()}
        held = {label: r.outcomes("hold") for label, r in results.items()}
        test = mcnemar(held["primitive"], held["mesh"])
        print(markdown_row([f"{method} (hold)", rate_text(held["primitive"].sum(), len(held["primitive"])),
                            rate_text(held["mesh"].sum(), len(held["mesh"])), test.only_a, test.only_b,
                            f"{test.p_value:.3f}"]), flush=True)


if __name__ == "__main__":
    main()
