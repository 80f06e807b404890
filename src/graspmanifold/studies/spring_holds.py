"""Why do the spring grasps of some shapes never hold? Each candidate's verification, taken apart.

    python scripts/study_spring_holds.py [--objects cylinder capsule_m frustum_m bottle_m] [--n 200]
                                         [--workers 2] [--out DIR] [--doc spring_holds.md] [--by-start]

The generator keeps a spring candidate only when it holds the free object when replayed open loop
(`GeneratorParams.verify`). This script generates `--n` unverified candidates per object (seed 0) and runs each
through the generator's own verifier (`springs.verifier_of`: its pregrasp, grasp and squeeze, then our hold
test), recording what the verifier does not keep: at the squeeze's end, the contacts (how many segments, where
along the object's long axis z, how much of each contact normal points along z, whether the contacts close
the grasp (epsilon), whether all five fingertips and the thumb still touch), and in which gravity direction the
object first leaves the 2 cm bound (the directions are tried in the order +x, -x, +y, -y, +z, -z, so a grasp
that fails at once shows as +x; 'refused': a pregrasp inside the object, never run). The paper cylinder is the
reference. `--by-start` gives a row per starting posture (design) instead of per object: why some designs never
hold.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

import numpy as np

from ..base.errors import SimulationError
from ..base.io import markdown_table, write_text_atomic
from ..judging.judge import JUDGING, reading_epsilon
from ..judging.replay import GraspVerifier
from ..sim.hand import DISTAL_SEGMENTS
from ..sim.objects import GraspObject, named_objects
from ..sim.scene import Scene
from ..synthesis.generator import GeneratorParams, generate_postures
from ..synthesis.springs import verifier_of
from ..trials.stats import rate_text
from .runner import StudyRun, run_study

PERIOD = 0.02  # s, the control period the verifier's hold test checks the object in (`judge.judge_scene`)
OUTCOMES = ("+x", "-x", "+y", "-y", "+z", "-z", "pushed", "refused", "fault")  # the last column's order


def direction_name(direction: np.ndarray) -> str:
    """'+x', '-z', ...: a unit direction along an axis by its sign and axis."""
    axis = int(np.argmax(np.abs(direction)))
    return ("+" if direction[axis] > 0 else "-") + "xyz"[axis]


def replay(verifier: GraspVerifier, posture: np.ndarray, pose: np.ndarray) -> dict[str, object]:
    """One candidate through the generator's verifier, with what it saw at the squeeze's end."""
    record: dict[str, object] = {"segments": 0, "five_tips": False, "thumb": False, "epsilon": np.nan,
                                 "axial_normal": np.nan, "contact_height": np.nan, "squeeze_force": np.nan,
                                 "approach_shift": np.nan, "dropped_along": "refused"}

    def look(scene: Scene) -> None:
        reading = scene.tactile()
        position = scene.data.xpos[scene.object_body]
        rotation = scene.data.xmat[scene.object_body].reshape(3, 3)  # the contacts in the object's frame, as it is now
        points, normals = (reading.points - position) @ rotation, reading.normals @ rotation
        weights = reading.forces / max(reading.forces.sum(), 1e-12)
        record.update(
            approach_shift=float(np.linalg.norm(position)),  # the object starts at the world's origin
            segments=len(reading.segments), five_tips=set(DISTAL_SEGMENTS) <= set(reading.segments),
            thumb=any(s.startswith("th") for s in reading.segments), dropped_along="",
            epsilon=reading_epsilon(reading, scene.data.xipos[scene.object_body].copy(), scene.object.friction),
            axial_normal=float(weights @ np.abs(normals[:, 2])) if len(weights) else np.nan,
            contact_height=float(weights @ (points[:, 2] / scene.object.half_extents[2])) if len(weights) else np.nan,
            squeeze_force=float(reading.forces.sum()) if len(weights) else np.nan)

    try:
        judgement = verifier(posture, pose[:3], pose[3:], observe=look)
    except SimulationError:
        record["dropped_along"] = "fault"
        return record
    if not judgement.hold and not record["dropped_along"]:
        if verifier.protocol.push_test is not None:
            record["dropped_along"] = "pushed"
        else:  # the hold test stopped in the period the object left: which direction it was in
            rules = verifier.protocol.rules
            turn = int((judgement.hold_time - PERIOD / 2) // verifier.hold_seconds)
            record["dropped_along"] = direction_name(np.asarray(rules.directions[min(turn, len(rules.directions) - 1)]))
    return record


def study(obj: GraspObject, n: int, workers: int, by_start: bool = False) -> list[list]:
    """The table's rows of one object."""
    name = obj.name
    params = GeneratorParams(verify=False)
    candidates = generate_postures(obj, n, seed=0, workers=workers, params=params)
    verifier = verifier_of(obj, params)
    records = [replay(verifier, p, pose) for p, pose in zip(candidates.postures, candidates.hand_poses)]
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
    first_drops = ", ".join(f"{d} {drops[d]}" for d in OUTCOMES if drops[d])
    thumb = sum(r["thumb"] for r in records)

    def median(key: str, form: str, unit: float = 1.0) -> str:  # over the candidates it was measured on (not NaN)
        values = [r[key] for r in records if np.isfinite(r[key])]
        return format(unit * float(np.median(values)), form) if values else "–"

    return [name, rate_text(len(held), n), rate_text(closure, n), rate_text(five, n), rate_text(thumb, n),
            f"{np.median([r['segments'] for r in records]):.0f}", median("squeeze_force", ".1f"),
            median("contact_height", "+.2f"), median("axial_normal", ".2f"), median("approach_shift", ".0f", 1000),
            first_drops or "–"]


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
         f"{args.n} unverified spring candidates per object (seed 0), each through the generator's verifier "
         "(its pregrasp, grasp and squeeze, then our hold test). Medians over candidates, at the squeeze's end (the "
         "force, height and normal over those that touch the object there; how far the free object was moved before "
         "the hold test, over those that ran); contact height: force-weighted mean z of the contacts over the half length (+1 top, −1 "
         "bottom); axial normal: force-weighted mean |n_z| of the contact normals (0: all normals across the long "
         "axis, 1: all along it).", "",
         *markdown_table(["starting posture" if args.by_start else "object", "held [95 % CI]", "force closure",
                          "five fingertips still touch", "the thumb still touches", "touching segments",
                          "squeeze force (N)", "contact height", "axial normal", "moved by the approach (mm)",
                          "first drop along (count)"], rows)])
    write_text_atomic(args.doc, table + "\n")
    print(table)


if __name__ == "__main__":
    main()
