"""Why do the spring grasps of some shapes never hold? Each candidate's verification, taken apart.

    python scripts/study_spring_holds.py [--objects cylinder capsule_m frustum_m bottle_m] [--n 200]
                                         [--workers 2] [--out DIR] [--doc spring_holds.md] [--by-start]

The generator keeps a spring candidate only when it holds the free object under the controller's
squeeze (`GeneratorParams.verify`). For the bottle none of 1000 candidates did, for the frustum 11.
This script generates `--n` unverified candidates per object (seed 0) and replays each exactly as the
verifier does, recording what the verifier does not keep: the contacts under the squeeze (how many
segments, where along the object's long axis z, how much of each contact normal points along z,
whether the contacts close the grasp (epsilon), whether all five fingertips still touch), and in
which gravity direction the object first leaves the 2 cm bound (the directions are tried in the
order +x, -x, +y, -y, +z, -z, 0.25 s each, so a grasp that fails at once shows as +x). The paper
cylinder is the reference whose candidates hold one time in four. `--by-start` gives a row per
starting posture (design) instead of per object, with how often the thumb still touches under the
squeeze: why some designs never hold.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

import mujoco
import numpy as np

from ..base.io import markdown_table, write_text_atomic
from ..control.controller import squeezed
from ..control.generator import GeneratorParams, generate_postures
from ..control.judge import JUDGING, reading_epsilon
from ..control.stages import HOLD_DIRECTIONS
from ..sim.hand import DISTAL_SEGMENTS
from ..sim.objects import GraspObject, named_objects
from ..sim.scene import GRAVITY, Scene
from ..trials.stats import rate_text
from .runner import StudyRun, run_study

DIRECTION_NAMES = ("+x", "-x", "+y", "-y", "+z", "-z")
PERIOD = 0.02  # s, as the verifier checks


def replay(scene: Scene, posture: np.ndarray, pose: np.ndarray, params: GeneratorParams) -> dict[str, object]:
    """The verifier's replay of one candidate, with what it saw on the way."""
    mujoco.mj_resetData(scene.model, scene.data)
    scene.set_object_support(JUDGING.support_stiffness, JUDGING.support_damping)
    scene.set_hand_pose(pose[:3], pose[3:])
    scene.set_posture(posture)
    scene.set_target(squeezed(posture, params.squeeze))
    scene.run(0.2)
    reading = scene.tactile()
    half_length = scene.object.half_extents[2]
    weights = reading.forces / max(reading.forces.sum(), 1e-12)
    record = {"segments": len(reading.segments), "five_tips": set(DISTAL_SEGMENTS) <= set(reading.segments),
              "thumb": any(s.startswith("th") for s in reading.segments),
              "epsilon": reading_epsilon(scene.tactile(), scene.data.xipos[scene.object_body].copy(), scene.object.friction),
              "axial_normal": float(weights @ np.abs(reading.normals[:, 2])) if len(weights) else np.nan,
              "contact_height": float(weights @ (reading.points[:, 2] / half_length)) if len(weights) else np.nan,
              "squeeze_force": float(reading.forces.sum()), "dropped_along": ""}
    scene.set_object_support(0.0, 0.0)
    start = scene.object_pose()[0]
    for name, direction in zip(DIRECTION_NAMES, HOLD_DIRECTIONS):
        scene.set_gravity(GRAVITY * direction)
        for _ in range(round(params.verify_hold_seconds / PERIOD)):
            scene.run(PERIOD)
            if np.linalg.norm(scene.object_pose()[0] - start) > JUDGING.hold_limit:
                record["dropped_along"] = name
                return record
    return record


def study(obj: GraspObject, n: int, workers: int, by_start: bool = False) -> list[list]:
    """The table's rows of one object."""
    name = obj.name
    params = GeneratorParams(verify=False)
    candidates = generate_postures(obj, n, seed=0, workers=workers, params=params)
    scene = Scene(obj, free_object=True)
    records = [replay(scene, p, pose, params) for p, pose in zip(candidates.postures, candidates.hand_poses)]
    if not by_start:
        return [row(name, records)]
    return [row(candidates.start_names[i], [r for r, s in zip(records, candidates.start_ids) if s == i])
            for i in np.unique(candidates.start_ids)]


def row(name: str, records: list[dict]) -> list:
    """One table row: what the verifier saw of these candidates."""
    n = len(records)
    held = [r for r in records if not r["dropped_along"]]
    closure = sum(r["epsilon"] > JUDGING.epsilon_threshold for r in records)
    five = sum(r["five_tips"] for r in records)
    drops = Counter(r["dropped_along"] for r in records if r["dropped_along"])
    first_drops = ", ".join(f"{d} {drops[d]}" for d in DIRECTION_NAMES if drops[d])
    median = lambda key: float(np.nanmedian([r[key] for r in records]))  # noqa: E731
    thumb = sum(r["thumb"] for r in records)
    return [name, rate_text(len(held), n), rate_text(closure, n), rate_text(five, n), rate_text(thumb, n),
            f"{median('segments'):.0f}", f"{median('squeeze_force'):.1f}", f"{median('contact_height'):+.2f}",
            f"{median('axial_normal'):.2f}", first_drops or "–"]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="+", default=["cylinder", "capsule_m", "frustum_m", "bottle_m"],
                        help="library objects by name, or mesh files of one's own (times --scale)")
    parser.add_argument("--scale", type=float, default=1.0, help="metres per unit of the mesh files (0.001 for mm)")
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study-spring-holds", help="the study's folder (its log, a copy of the report)")
    parser.add_argument("--doc", default="spring_holds.md", help="the report")
    parser.add_argument("--by-start", action="store_true", help="a row per starting posture instead of per object")
    args = parser.parse_args(argv)
    run_study(args.out, 1, lambda run: _run(args, run), "spring_holds.log")  # the generator has its own pool


def _run(args: argparse.Namespace, run: StudyRun) -> None:
    rows = []
    for obj in named_objects(args.objects, args.scale):
        rows += study(obj, args.n, args.workers, args.by_start)
        run.log(f"{obj.name}: done")
    command = "python scripts/study_spring_holds.py " + " ".join(sys.argv[1:])
    table = "\n".join(
        [f"# Why spring candidates do not hold{' (by starting posture)' if args.by_start else ''}", "",
         f"Generated by `{command}`. "
         f"{args.n} unverified spring candidates per object (seed 0), each replayed as the verifier does. Medians over "
         "candidates; contact height: force-weighted mean z of the contacts over the half length (+1 top, −1 "
         "bottom); axial normal: force-weighted mean |n_z| of the contact normals (0: all normals across the long "
         "axis, 1: all along it).", "",
         *markdown_table(["starting posture" if args.by_start else "object", "held [95 % CI]", "force closure",
                          "five fingertips still touch", "the thumb still touches", "touching segments",
                          "squeeze force (N)", "contact height", "axial normal", "first drop along (count)"], rows)])
    write_text_atomic(args.doc, table + "\n")
    print(table)


if __name__ == "__main__":
    main()
