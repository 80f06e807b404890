"""The library on the community's Shadow Hands beside ours: the cross-model table (issue 28).

    python scripts/study_hands.py [--presets paper verified] [--hands ours gymnasium-robotics] [--workers 2]
                                  [--why [--why-grid paper]]

For each hand model: `graspmanifold reproduce` with each preset (`paper`: the paper's procedure and dataset
sizes, every candidate trained on; `verified`: the same candidates, the maps trained on those that hold when
replayed) on the paper grid, with the same seeds, so that the trials of every hand start from the same poses and
noise draws. From each run: the generator's candidates and the share that hold (`verified`), and the hold rate of
the heuristic controller (no experience), of the raw database and of the SOM, with 95 % Wilson intervals; the SOM
is compared with the heuristic on each hand and the hands with each other under each controller by McNemar's
exact test, with Holm's correction over the whole family. A finished run in --out is read, not recomputed
(delete it to run it again); the table is written to docs/studies/hands.md.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from ..base.io import markdown_table, read_json, write_text_atomic
from ..paper.reproduce import PRESETS, reproduce
from ..sim.hand import SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model, joint_agreement
from ..trials.evaluation import EvaluationResult, evaluate
from ..trials.stats import compare
from ..trials.grid import grid_preset
from ..trials.stats import holm, rate_text
from .runner import StudyRun, run_study

OBJECTS = ("box", "cylinder", "sphere")
METHODS = {"none": "heuristic", "database": "database", "som": "SOM"}


def label(hand: str) -> str:
    """A hand's name in file names and tables (an MJCF path: its file name)."""
    return Path(hand).stem if hand.endswith(".xml") else hand


def finished_run(out: Path, hand: str, preset: str, workers: int) -> Path:
    """The folder of a finished `reproduce` run of a preset on a hand: read when its run.json records this very
    configuration and its summary is written, else run (or resumed: its stages are kept under their keys)."""
    run = out / f"{label(hand)}_{preset}"
    config = replace(PRESETS[preset], hand=hand)
    recorded = run / "run.json"
    if not ((run / "summary.json").exists() and recorded.exists()
            and json.loads(recorded.read_text()).get("config") == json.loads(json.dumps(config.to_json()))):
        reproduce(run, config, workers=workers, force=True)
    return run


def held(result: EvaluationResult) -> str:
    return rate_text(int(result.outcomes()[result.valid].sum()), int(result.valid.sum()))


def our_finger_servo() -> tuple[float, float]:
    """Our finger servos' gain (N m/rad) and force limit (N m)."""
    actuator = SHADOW_HAND.model.actuator("A_FFJ3")
    return float(actuator.gainprm[0]), float(actuator.forcerange[1])


def with_our_servos(hand: HandModel) -> HandModel:
    """The model with our finger servos in place of its own."""
    gain, limit = our_finger_servo()

    def spec():
        spec = hand.spec()
        for actuator in spec.actuators:
            if actuator.name not in [hand.actuators[row] for row in hand.wrist_rows]:
                actuator.gainprm[0], actuator.biasprm[1] = gain, -gain
                actuator.forcerange = [-limit, limit]
        return spec

    return replace(hand, loader=spec)


def with_our_contacts(hand: HandModel) -> HandModel:
    """The model with our contact parameters on every colliding geom of the hand (condim, solref, solimp); the
    friction is the object's on every model already (`Scene`)."""
    ours = SHADOW_HAND.model.geom("ffdistal")

    def spec():
        spec = hand.spec()
        for geom in spec.geoms:
            if geom.contype or geom.conaffinity:
                geom.condim, geom.solref, geom.solimp = int(ours.condim[0]), list(ours.solref), list(ours.solimp)
        return spec

    return replace(hand, loader=spec)


def with_our_joints(hand: HandModel) -> HandModel:
    """The model with our finger joints' damping, armature and friction loss."""
    ours = SHADOW_HAND.model.joint("FFJ3")
    finger_joints = set(hand.finger_joints)

    def spec():
        spec = hand.spec()
        for joint in spec.joints:
            if joint.name in finger_joints:
                joint.damping, joint.armature = [float(ours.damping[0])] * len(joint.damping), float(ours.armature[0])
                joint.frictionloss = float(ours.frictionloss[0])
        return spec

    return replace(hand, loader=spec)


def with_our_coupling(hand: HandModel) -> HandModel:
    """The model with our J1/J2 coupling on the four fingers: whatever ties a finger's J1 to its J2 (a tendon over
    both) goes; one servo drives the tendon J1 + J2, and a soft tendon (ours: 0.2 N m/rad) pulls J1 towards J2,
    so that J1 keeps closing when the middle phalanx is stopped, as on the real hand."""
    ours = SHADOW_HAND.model
    balance = float(ours.tendon_stiffness[ours.tendon("FFJ12_balance").id])
    compiled = hand.model
    pairs = {finger: (hand.finger_joints[SHADOW_HAND.finger_joints.index(f"{finger}J2")],
                      hand.finger_joints[SHADOW_HAND.finger_joints.index(f"{finger}J1")])
             for finger in ("FF", "MF", "RF", "LF")}
    finger_of_pair = {frozenset(pair): finger for finger, pair in pairs.items()}

    def joints_of(tendon: int) -> frozenset[str]:
        first = compiled.tendon_adr[tendon]
        return frozenset(compiled.joint(compiled.wrap_objid[w]).name
                         for w in range(first, first + compiled.tendon_num[tendon]))

    ties = {compiled.tendon(t).name: finger_of_pair[joints_of(t)] for t in range(compiled.ntendon)
            if joints_of(t) in finger_of_pair}  # what ties J1 to J2 now, by finger
    sign = dict(zip(hand.finger_joints, hand.to_model(np.ones(len(hand.finger_joints)))))

    def spec():
        spec = hand.spec()
        for name in ties:
            spec.delete(spec.tendon(name))
        for finger, (j2, j1) in pairs.items():
            total = spec.add_tendon(name=f"{finger}_J1J2_sum")
            total.wrap_joint(j2, sign[j2])
            total.wrap_joint(j1, sign[j1])
            spring = spec.add_tendon(name=f"{finger}_J1J2_balance", stiffness=[balance, 0, 0])
            spring.wrap_joint(j2, sign[j2])
            spring.wrap_joint(j1, -sign[j1])
            for actuator in spec.actuators:  # the servo of J2 (or of the old sum) drives the sum
                if actuator.target == j2 or ties.get(actuator.target) == finger:
                    actuator.trntype, actuator.target = mujoco.mjtTrn.mjTRN_TENDON, total.name
                    actuator.ctrlrange = [0.0, np.pi]
        return spec

    return replace(hand, loader=spec)


def hand_facts(hand: HandModel) -> list[str]:
    """What a model's physics is made of, measured from its compiled MJCF: one table row."""
    model = hand.model
    wrist = set(hand.wrist_rows)
    servos = [model.actuator(a).id for row, a in enumerate(hand.actuators) if row not in wrist]
    dofs = model.jnt_dofadr[[model.joint(j).id for j in hand.finger_joints]]
    bodies = {model.body(b).id for b in hand.segments}
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] in bodies
             and (model.geom_contype[g] or model.geom_conaffinity[g])]
    kinds = Counter(mujoco.mjtGeom(int(model.geom_type[g])).name.removeprefix("mjGEOM_").lower() for g in geoms)
    ours = dict(zip(SHADOW_HAND.finger_joints, SHADOW_HAND.limits()))
    narrower = [paper for paper, limits in zip(SHADOW_HAND.finger_joints, hand.limits())
                if not np.allclose(limits, ours[paper], atol=1e-3)]

    def values(array, digits=4):
        return ", ".join(f"{v:.{digits}g}" for v in np.unique(np.round(array, 6)))

    return [label(hand.name), values(model.actuator_gainprm[servos, 0]), values(model.actuator_forcerange[servos, 1]),
            f"{values(model.dof_damping[dofs])} / {values(model.dof_armature[dofs])} / "
            f"{values(model.dof_frictionloss[dofs])}",
            ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())), values(model.geom_condim[geoms]),
            "; ".join(values(model.geom_solref[geoms][:, i]) for i in range(2)),
            "; ".join(values(model.geom_solimp[geoms][:, i]) for i in range(3)),
            f"{sum(model.body_mass[b] for b in bodies):.2f}", f"{joint_agreement(hand).min():.3f}",
            ", ".join(narrower) or "none"]


def facts_rows(hands: list[HandModel]) -> list[str]:
    lines = ["", "What the models are made of (from their compiled MJCF; finger servos, finger joints, the colliding "
             "geoms of the segments):", ""]
    return lines + markdown_table(
        ["hand", "servo kp (N m/rad)", "servo force limit (N m)", "joint damping / armature / friction loss",
         "colliding geoms", "condim", "solref (time; damping ratio)", "solimp (d0; dwidth; width)", "segment mass (kg)",
         "joint agreement (min cosine)", "finger joint ranges unlike ours"], [hand_facts(hand) for hand in hands])


def ablation_rows(hand: HandModel, grid: str = "quick") -> list[str]:
    """The heuristic on a grid with the model's own physics, then with our finger servos, then also our contact
    parameters, our J1/J2 coupling and our joint dynamics, beside our hand (in this process: the changed models are
    not registered by name)."""
    gain, limit = our_finger_servo()
    steps = [hand]
    for change in (with_our_servos, with_our_contacts, with_our_coupling, with_our_joints):
        steps.append(change(steps[-1]))
    lines = ["", f"Why {label(hand.name)} holds less, causes tried one after the other: our finger servos (kp {gain:g} "
             f"N m/rad, force limit {limit:g} N m), then also our contact parameters, then also our J1/J2 coupling "
             "(one servo on J1 + J2, a soft tendon between them), then also our finger joints' damping, armature and "
             f"friction loss; the plain controller on the {grid} grid, seed 0, "
             "the same poses (McNemar: each column against the one before; p, then Holm's over the table's "
             f"{3 * (len(steps) - 1)} tests):", ""]
    rates, tests = {}, []
    for obj in OBJECTS:
        poses = grid_preset(grid, obj)
        runs = [evaluate(obj, None, poses, workers=1, hand=h, progress=False) for h in steps + [SHADOW_HAND]]
        rates[obj] = [held(run) for run in runs]
        tests += [compare(after, before).p_value for before, after in zip(runs[:-2], runs[1:-1])]
    adjusted = iter(zip(tests, holm(tests)))
    rows = []
    for obj in OBJECTS:
        cells = [obj, rates[obj][0]]
        for rate in rates[obj][1:-1]:
            raw, corrected = next(adjusted)
            cells += [rate, f"{raw:.2g} ({corrected:.2g})"]
        rows.append(cells + [rates[obj][-1]])
    return lines + markdown_table(["object", "its own physics", "our servos", "p", "and contacts", "p", "and coupling",
                                   "p", "and joints", "p", "our hand"], rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--presets", nargs="+", default=["paper", "verified"], choices=list(PRESETS))
    parser.add_argument("--hands", nargs="+", default=[SHADOW_HAND.name, "gymnasium-robotics"],
                        help="hand names or MJCF paths (the first is the one the others are compared with)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study-hands")
    parser.add_argument("--doc", default="docs/studies/hands.md")
    parser.add_argument("--why", action="store_true", help="also the models' physics side by side, and the other "
                        "hands with our servos, contact parameters and coupling, one after the other")
    parser.add_argument("--why-grid", default="paper", help="the grid of the --why ablation (one worker: the changed "
                        "models are not registered by name)")
    args = parser.parse_args(argv)
    run_study(args.out, 1, lambda run: _run(args, run), "hands.log")  # each reproduction has its own pool


def _run(args: argparse.Namespace, run: StudyRun) -> None:
    out, started = run.out, run.started
    runs = {(hand, preset): finished_run(out, hand, preset, args.workers) for preset in args.presets
            for hand in args.hands}
    results = {(hand, preset, obj, method): EvaluationResult.load(run / "evaluation" / f"{obj}_{method}.npz")
               for (hand, preset), run in runs.items() for obj in OBJECTS for method in METHODS}
    comparisons = []  # (preset, what, object, PairedComparison)
    for preset in args.presets:
        for obj in OBJECTS:
            for hand in args.hands:
                comparisons.append((preset, f"{label(hand)}: SOM vs heuristic", obj,
                                    compare(results[(hand, preset, obj, "som")], results[(hand, preset, obj, "none")])))
            first, *others = args.hands
            for method in ("none", "som"):
                for other in others:
                    comparisons.append((preset, f"{METHODS[method]}: {label(other)} vs {label(first)}", obj,
                                        compare(results[(other, preset, obj, method)],
                                               results[(first, preset, obj, method)])))
    adjusted = holm([c.p_value for *_, c in comparisons])
    lines = ["# The library on other Shadow Hand models (issue 28)", "",
             f"`python scripts/study_hands.py --presets {' '.join(args.presets)} --hands {' '.join(args.hands)} "
             f"--workers {args.workers}{f' --why --why-grid {args.why_grid}' if args.why else ''}`: each row is a "
             "`graspmanifold reproduce --preset PRESET --hand HAND` run (the paper's dataset sizes, 25 x 25 maps, the "
             "paper grid, seed 0: the same poses and noise draws on every hand); SECONDS s for what this call computed "
             "(runs read from --out not counted); the project's 2-core machine.", "",
             "Candidates: the spring generator's postures (the paper's procedure) and their acceptance; trained on: "
             "every candidate (`paper`) or those that hold when replayed with the controller's squeeze (`verified`, "
             "with the share). Hold rates over the valid trials with 95 % Wilson intervals.", ""]
    table = []
    for preset in args.presets:
        for hand in args.hands:
            summary = read_json(runs[(hand, preset)] / "summary.json", "a run's summary.json")
            for obj in OBJECTS:
                facts = summary["objects"][obj]
                trained = (rate_text(facts["dataset_size"], facts["candidates"]) if preset == "verified"
                           else str(facts["dataset_size"]))
                rows = [results[(hand, preset, obj, m)] for m in METHODS]
                table.append([preset, label(hand), obj, f"{facts['candidates']} ({facts['acceptance_ratio']:.1%})",
                              trained, *(held(r) for r in rows), " / ".join(str(int((~r.valid).sum())) for r in rows)])
    lines += markdown_table(["preset", "hand", "object", "candidates (acceptance)", "trained on", "heuristic hold",
                             "database hold", "SOM hold", "invalid trials"], table)
    lines += ["", "Paired comparisons (McNemar's exact test on the poses valid for both; Holm over all "
              f"{len(comparisons)}):", ""]
    lines += markdown_table(["preset", "comparison", "object", "n", "only first holds", "only second holds", "p",
                             "Holm p"], [[preset, what, obj, c.n, c.only_a, c.only_b, f"{c.p_value:.3g}", f"{p_holm:.3g}"]
                                         for (preset, what, obj, c), p_holm in zip(comparisons, adjusted)])
    if args.why:
        hands = [hand_model(hand) for hand in args.hands]
        lines += facts_rows(hands)
        for hand in hands[1:]:
            lines += ablation_rows(hand, args.why_grid)
    text = "\n".join(lines).replace("SECONDS", f"{time.perf_counter() - started:.0f}")
    write_text_atomic(args.doc, text + "\n")
    print(text)


if __name__ == "__main__":
    main()
