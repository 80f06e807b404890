"""Verified means held when replayed: what the generator keeps under each protocol, at what yield and speed, and
how its grasps fare under the other protocol; and what limits our hand under DexGraspBench's pushes. A part of
the protocols study (`studies.protocols`, `scripts/study_protocols.py`), which writes it into docs/studies/protocols.md.

For every object of the benchmark (the paper's box, cylinder and sphere, the marble, pen, disc and cube) and of
the test family (the family members the generator's defaults were tuned beside; `--held-out` adds the members
kept aside, checked once at the end), `--verify-postures` verified postures are generated under each verifying protocol
(`GeneratorParams.verify_protocol`: ours, DexGraspBench's main version), one worker each, timed: verified grasps
per second per core and the yield (the share of the spring walk's candidates that hold). Every verified grasp is
then replayed open loop (`replay.replay`, a new scene, the stages it was verified with) under both
protocols, with DexGraspBench's Q1 of its fingertip contacts and its penetration at the grasp. Rates carry
95 % Wilson intervals; the same grasps under the two protocols are paired (McNemar, Holm within the family).

What limits our hand under DexGraspBench's main version is measured on the benchmark's grasps verified under
ours, one change at a time against the protocol as it is (the same grasps, McNemar, Holm): the servos four times
as stiff and strong (the hand), the friction 1.0 instead of 0.6 and the object at its own mass instead of 0.1 kg
(the protocol's physics), no limit on the turn (the protocol's rule), and the pregrasp and squeeze of the open
hand instead of those made from the contacts (the grasps' stages). Finished objects are kept in the study's
folder (a rerun resumes).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from ..base.errors import GenerationError
from ..base.io import load_npz, markdown_table, save_npz
from ..judging.protocols import DEFAULT_PROTOCOL, DEXGRASPBENCH, pushed
from ..judging.plans import GRASP_STAGES, open_loop_grasps
from ..judging.quality import Q1_CONTACT_DISTANCE, q1
from ..judging.replay import replay, replay_grasp
from ..sim.family import FAMILY, HELD_OUT
from ..sim.hand import DISTAL_SEGMENTS, segment_of_geoms
from ..sim.objects import PAPER_OBJECTS, GraspObject, get_object
from ..sim.scene import Scene
from ..synthesis.generator import GeneratorParams, generate_postures, starting_postures
from ..trials.benchmark import OBJECTS as BENCHMARK_OBJECTS
from ..trials.stats import PairedComparison, mcnemar, rate_text
from .runner import StudyRun

#: the verifying protocols compared
VERIFYING = (DEFAULT_PROTOCOL, "dexgraspbench")
#: BODex's published figures on the Shadow hand (its paper, with DexGraspBench): success under the protocol,
#: grasps synthesised per second on one GPU
BODEX_SUCCESS, BODEX_GRASPS_PER_SECOND = 0.75, 49.0


def test_family() -> list[str]:
    """The test family: the family members the generator's defaults were tuned beside (not held out)."""
    return [name for name in FAMILY if name not in HELD_OUT]


def named(name: str) -> GraspObject:
    """A benchmark or family object by name."""
    return BENCHMARK_OBJECTS[name].object if name in BENCHMARK_OBJECTS else get_object(name)


def grasp_measures(obj: GraspObject, hand_pose: np.ndarray, posture: np.ndarray, scene: Scene) -> tuple[float, float]:
    """DexGraspBench's Q1 of a grasp's fingertip contacts (within 5 mm: `quality.q1`) and the hand's deepest
    penetration into the object (m), both at the grasp, by kinematics."""
    scene.set_posture(posture)
    scene.set_hand_pose(hand_pose[:3], hand_pose[3:])
    segment_of = segment_of_geoms(scene.model, scene.hand)
    points, normals, links, distances = [], [], [], []
    fromto = np.zeros(6)
    for segment in (scene.hand.segments.index(s) for s in DISTAL_SEGMENTS):
        for geom in np.flatnonzero(segment_of == segment):
            for other in scene.object_geoms:
                distance = mujoco.mj_geomDistance(scene.model, scene.data, int(geom), other, 0.05, fromto)
                if distance <= Q1_CONTACT_DISTANCE:
                    points.append(fromto[3:].copy())
                    normals.append(-obj.surface_normal(fromto[3:].copy()))
                    links.append(segment)
                    distances.append(distance)
    quality = q1(np.reshape(points, (-1, 3)), np.reshape(normals, (-1, 3)), np.array(links, dtype=int),
                 np.array(distances)) if points else 0.0
    return quality, scene.penetration()


def verify_object(task: tuple[str, str, int]) -> dict[str, np.ndarray]:
    """One object under one verifying protocol: its verified postures generated on one core (timed), each replayed
    under both protocols, with its Q1, penetration and grasp type."""
    name, protocol_name, n = task
    obj = named(name)
    starting_postures(obj, "grasp_types")  # a held-out member's are searched on first use: not timed
    started = time.perf_counter()
    try:
        postures = generate_postures(obj, n, seed=0, workers=1, progress=False,
                                     params=GeneratorParams(verify_protocol=protocol_name))
    except GenerationError as error:
        return {"seconds": np.array(time.perf_counter() - started), "error": np.array(str(error))}
    seconds = time.perf_counter() - started
    grasps = open_loop_grasps(postures, obj=obj)
    held = {p: replay(obj, grasps, p)[0] for p in VERIFYING}
    scene = Scene(obj)
    measures = np.array([grasp_measures(obj, pose, posture, scene)
                         for pose, posture in zip(postures.hand_poses, postures.postures)])
    types = postures.metadata["grasp_types"]
    names = [start.split(":", 1)[-1] for start in postures.start_names]
    return {"seconds": np.array(seconds), "candidates": np.array(postures.metadata["candidates"]),
            **{f"held_{p}": held[p] for p in VERIFYING}, "q1": measures[:, 0], "penetration": measures[:, 1],
            "grasp_type": np.array([types[names[i]] for i in postures.start_ids]),
            "design": np.array([names[i] for i in postures.start_ids])}


def ablations() -> dict[str, tuple]:
    """What limits our hand under DexGraspBench's main version: one change each, (protocol, servo scale, stages)."""
    physics = DEXGRASPBENCH.physics
    return {
        "the protocol as it is": (DEXGRASPBENCH, 1.0, "contacts"),
        "servos 4x stiffer and stronger (the hand)": (DEXGRASPBENCH, 4.0, "contacts"),
        "friction 1.0 (the protocol's physics)": (replace(DEXGRASPBENCH, physics=replace(physics, friction=(1.0, 0.02))),
                                                  1.0, "contacts"),
        "the object at its own mass (the protocol's physics)": (None, 1.0, "contacts"),
        "no limit on the turn (the protocol's rule)": (replace(DEXGRASPBENCH, angle_limit=math.pi), 1.0, "contacts"),
        "the open hand's pregrasp and squeeze (the grasps' stages)": (DEXGRASPBENCH, 1.0, "open"),
    }


def ablate(task: tuple[str, str, int]) -> dict[str, np.ndarray]:
    """The benchmark object's n grasps verified under ours, replayed under one ablation of DexGraspBench's main
    version: {'held': held per grasp}."""
    name, label, n = task
    obj = named(name)
    protocol, servo_scale, stages = ablations()[label]
    if protocol is None:
        protocol = replace(DEXGRASPBENCH, physics=replace(DEXGRASPBENCH.physics, object_mass=obj.mass))
    protocol = pushed(protocol, label)
    postures = generate_postures(obj, n, seed=0, workers=1, progress=False)
    grasps = open_loop_grasps(postures, GRASP_STAGES[stages], obj)
    scene = Scene(obj, free_object=True)
    actuators = scene.actuator_ids
    scene.model.actuator_gainprm[actuators, 0] *= servo_scale
    scene.model.actuator_biasprm[actuators, 1] *= servo_scale
    scene.model.actuator_forcerange[actuators] *= servo_scale
    return {"held": np.array([replay_grasp(scene, grasp, protocol).held for grasp in grasps])}


def _read(path: Path) -> tuple[dict[str, np.ndarray], dict]:
    return load_npz(path, "verification", {})


def _write(arrays: dict[str, np.ndarray], path: Path, meta: dict) -> None:
    save_npz(path, "verification", arrays, meta)


@dataclass(frozen=True)
class Verification:
    """What `measure` found.

    Attributes:
        postures: verified postures per object and protocol (twice as many per benchmark object in the ablations).
        names: the objects (benchmark and test family).
        held_out: the held-out members measured (none unless asked for).
        verified: per (object, protocol, postures) the arrays of `verify_object`.
        ablated: per (benchmark object, ablation) held per grasp.
    """

    postures: int
    names: list[str]
    held_out: list[str]
    verified: dict
    ablated: dict


def measure(study: StudyRun, postures: int, held_out: bool) -> Verification:
    """Every object under both verifying protocols, and the ablations, in the study's pool and folder.

    Args:
        study: the running study (its session open).
        postures: verified postures per object and protocol.
        held_out: add the family's held-out members.

    Returns:
        The `Verification`.
    """
    names = list(dict.fromkeys([*BENCHMARK_OBJECTS, *PAPER_OBJECTS, *test_family()]))
    extra = list(HELD_OUT) if held_out else []
    tasks = [(name, p, postures) for p in VERIFYING for name in names + extra]  # a protocol at a time: a held-out
    # member's starts are searched once, under the first, and taken from the cache under the second
    verified = study.keep_each("verified", tasks, verify_object, _read, _write, lambda task, r: (
        f"{task[0]} verified under {task[1]}: " + (str(r["error"])[:120] if "error" in r else
        f"{len(r['q1'])} in {float(r['seconds']):.0f} s, " + ", ".join(
            f"held under {p} {r[f'held_{p}'].mean():.0%}" for p in VERIFYING))))
    ablated = study.keep_each("ablations", [(name, label, 2 * postures) for name in BENCHMARK_OBJECTS
                                             for label in ablations()],
                              ablate, _read, _write, lambda task, r: f"{task[0]}, {task[1]}: {r['held'].mean():.0%}")
    return Verification(postures, names, extra, verified, {task[:2]: r["held"] for task, r in ablated.items()})


def section(found: Verification) -> tuple[list[str], list[tuple[str, PairedComparison]]]:
    """The report's section on verification (markdown lines) and its paired comparisons (for the report's Holm
    family)."""
    lines = ["## Verified means held when replayed", "",
             "The generator verifies a candidate by its open-loop replay (`replay.replay_grasp`: the touching "
             "segments 2 cm out along the object's normals, the grasp, the squeeze 1 cm in along them, the object "
             "free, gravity off) under the protocol named (`GeneratorParams.verify_protocol`). "
             f"{found.postures} verified postures per object and protocol, generated on one core each and timed; "
             "every verified grasp replayed again in a new scene under both protocols.", ""]
    rows, pooled, by_type, by_design, speed, yields = _tally(found)
    tests: list[tuple[str, PairedComparison]] = []
    header = ["object"] + [f"{label} ({p})" for p in VERIFYING for label in (
        "yield", "verified / s / core", *(f"held under {q}" for q in VERIFYING), "Q1 median / penetration max (mm)")]
    pooled_rows = []
    for p in VERIFYING:
        cells = {q: np.concatenate(pooled[p][q]) if pooled[p][q] else np.zeros(0, dtype=bool) for q in VERIFYING}
        pooled_rows.append([f"verified under {p}", *(rate_text(int(c.sum()), len(c)) for c in cells.values()),
                            f"{speed[p][1] / max(speed[p][0], 1e-9):.2f}", f"{yields[p][1] / max(yields[p][0], 1):.0%}"])
        if len(cells[DEFAULT_PROTOCOL]):
            other = [q for q in VERIFYING if q != p][0]
            tests.append((f"verified under {p}: held under {other} against under {p} (same grasps, benchmark pooled)",
                          mcnemar(cells[other], cells[p])))
    lines += ["### The benchmark's seven objects, pooled", "",
              *markdown_table(["grasps", *(f"held under {q}" for q in VERIFYING),
                               "verified / s / core (benchmark and test family)", "yield (every object)"],
                              pooled_rows), "",
              f"BODex (its paper, with DexGraspBench) passes its protocol with over {BODEX_SUCCESS:.0%} of its Shadow-hand "
              f"grasps, at more than {BODEX_GRASPS_PER_SECOND:.0f} grasps per second on one GPU. Not like for like: its "
              "hand is Menagerie's (its own servos and meshes) where ours is our MJCF of capsules; its objects are "
              "thousands of convex decompositions, ours the benchmark's primitives and our family's meshes; its "
              "speed is a GPU's batch optimisation, ours a spring walk and a replay per candidate on one CPU core; "
              "and a grasp verified under a protocol is one that passed it once (a replay is the same deterministic "
              "simulation), so the rate of a protocol's own verified grasps measures only that the verifier and the "
              "replay are one procedure: the yield and the speed are the measure of how hard the protocol is for "
              "the hand, and the other protocol's rate how far a grasp verified one way carries.", "",
              "### Every object", "", *markdown_table(header, rows), "",
              "### By grasp type (every object)", ""]
    lines += _by_type_and_design(by_type, by_design)
    lines += _ablation_lines(found, tests)
    return lines, tests


def _tally(found: Verification) -> tuple[list, dict, dict, dict, dict, dict]:
    """Each object's row of the table; the verified grasps' outcomes pooled over the benchmark, by grasp type and
    by design; the seconds and the yield per protocol."""
    names, held_out, verified = found.names, found.held_out, found.verified
    rows = []
    pooled: dict[str, dict[str, list]] = {p: {q: [] for q in VERIFYING} for p in VERIFYING}
    by_type: dict[tuple[str, str], dict[str, list]] = {}
    by_design: dict[tuple[str, str, str], dict[str, list]] = {}
    speed = {p: [0.0, 0] for p in VERIFYING}  # s and postures, the objects whose starts ship
    yields = {p: [0, 0] for p in VERIFYING}  # candidates and postures, every object
    for name in names + held_out:
        row = [name + (" (held out)" if name in held_out else "")]
        for p in VERIFYING:
            result = verified[(name, p, found.postures)]
            if "error" in result:
                row += ["no set", "-", "-", "-", "-"]
                continue
            n = len(result["q1"])
            yields[p][0] += int(result["candidates"])
            yields[p][1] += n
            if name not in held_out:
                speed[p][0] += float(result["seconds"])
                speed[p][1] += n
            if name in BENCHMARK_OBJECTS:
                for q in VERIFYING:
                    pooled[p][q].append(result[f"held_{q}"])
            for kind, design in set(zip(result["grasp_type"].tolist(), result["design"].tolist())):
                chosen = (result["grasp_type"] == kind) & (result["design"] == design)
                for cell in (by_type.setdefault((p, kind), {q: [] for q in VERIFYING}),
                             by_design.setdefault((p, kind, design), {q: [] for q in VERIFYING})):
                    for q in VERIFYING:
                        cell[q].append(result[f"held_{q}"][chosen])
            row += [f"{n / int(result['candidates']):.0%}", f"{n / float(result['seconds']):.2f}",
                    *(rate_text(int(result[f"held_{q}"].sum()), n) for q in VERIFYING),
                    f"{np.median(result['q1']):.3f} / {1000 * np.max(result['penetration']):.1f}"]
        rows.append(row)
    return rows, pooled, by_type, by_design, speed, yields


def _by_type_and_design(by_type: dict, by_design: dict) -> list[str]:
    """The held rates by grasp type and by design."""
    lines: list[str] = []
    type_rows = []
    for (p, kind), cell in sorted(by_type.items()):
        held = {q: np.concatenate(cell[q]) for q in VERIFYING}
        type_rows.append([kind, p, *(rate_text(int(h.sum()), len(h)) for h in held.values())])
    lines += markdown_table(["grasp type", "verified under", *(f"held under {q}" for q in VERIFYING)], type_rows)
    design_rows = []
    for (p, kind, design), cell in sorted(by_design.items()):
        held = {q: np.concatenate(cell[q]) for q in VERIFYING}
        design_rows.append([design, kind, p, *(rate_text(int(h.sum()), len(h)) for h in held.values())])
    lines += ["", "### By design (every object where the design gave postures)", "",
              *markdown_table(["design", "grasp type", "verified under", *(f"held under {q}" for q in VERIFYING)],
                              design_rows)]
    return lines


def _ablation_lines(found: Verification, tests: list) -> list[str]:
    """What limits our hand under DexGraspBench's pushes: one change of the protocol at a time (its comparisons
    added to `tests`)."""
    ablated = found.ablated
    base_label = "the protocol as it is"
    base = np.concatenate([ablated[(name, base_label)] for name in BENCHMARK_OBJECTS])
    ablation_rows = []
    for label in ablations():
        held = np.concatenate([ablated[(name, label)] for name in BENCHMARK_OBJECTS])
        per_object = ", ".join(f"{name} {ablated[(name, label)].mean():.0%}" for name in BENCHMARK_OBJECTS)
        ablation_rows.append([label, rate_text(int(held.sum()), len(held)), per_object])
        if label != base_label:
            tests.append((f"{label} against the protocol as it is", mcnemar(held, base)))
    return ["", "### What limits our hand under DexGraspBench's pushes", "",
              f"{2 * found.postures} grasps per benchmark object verified under ours, replayed under DexGraspBench's "
              "main version with one change each (the same grasps in every row).", "",
            *markdown_table(["change", "held, pooled", "per object"], ablation_rows)]

