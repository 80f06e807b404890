"""A hand model whose mesh files are not at hand, run on its MJCF text alone: a diagnostic of kinematics and
actuators (issue 28).

    python scripts/study_hand_without_meshes.py PATH/TO/right_hand.xml [--grid quick] [--workers 1]

Menagerie's snapshot could not be fetched on the project's machine, but its `shadow_hand/right_hand.xml` could be
read. Without meshes MuJoCo cannot compile it; this script drops the visual meshes and replaces each colliding mesh
by a primitive of ours (a finger's or the thumb's distal phalanx: our capsule, radius 9 mm, 17 mm long; other
bodies' colliding meshes: nothing), so that everything else (kinematics, joint ranges, actuators, tendons, the
primitive collision geometry) is the model's own. It reports how the model's joints compare with ours
(`joint_agreement`), then the heuristic controller on a grid on ours, on the model, and on the model with our
finger servos, with Wilson intervals and McNemar's test on the same poses. It is not the model with its meshes:
fingertip contacts differ.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

import mujoco
from study_hands import with_our_servos  # the hands study's servo swap (this script's folder is on the path)

import graspmanifold as gm
from graspmanifold.sim.hand_models import check_hand_model, describe_shadow_hand, hand_file_spec, joint_agreement
from graspmanifold.trials.stats import mcnemar, rate_text


def without_meshes(file_spec) -> mujoco.MjSpec:
    spec = file_spec()
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            body, collides = geom.parent, geom.contype != 0 or geom.conaffinity != 0
            spec.delete(geom)
            if collides and body.name.endswith("distal"):
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, 0.017], size=[0.009, 0, 0],
                              group=3, mass=0.0)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    return spec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mjcf")
    parser.add_argument("--grid", default="quick")
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    path = Path(args.mjcf).resolve()
    hand = describe_shadow_hand(functools.partial(without_meshes, functools.partial(hand_file_spec, path)),
                                f"{path.name} without meshes", str(path))
    check_hand_model(hand)
    agreement = joint_agreement(hand)
    print(f"{hand.name}: joints flipped {list(hand.flipped)}; joint agreement with ours min {agreement.min():.3f}")
    print("| object | ours | the model | the model, our finger servos | p (model vs ours) | p (servos) |")
    print("|---|---|---|---|---|---|")
    for obj in ("box", "cylinder", "sphere"):
        grid = gm.grid_preset(args.grid, obj)
        runs = [gm.evaluate(obj, None, grid, workers=args.workers, hand=h, progress=False)
                for h in (gm.SHADOW_HAND, hand, with_our_servos(hand))]
        rates = [rate_text(int(r.outcomes()[r.valid()].sum()), int(r.valid().sum())) for r in runs]
        tests = []
        for a, b in ((runs[1], runs[0]), (runs[2], runs[1])):
            valid = a.valid() & b.valid()
            tests.append(f"{mcnemar(a.outcomes()[valid], b.outcomes()[valid]).p_value:.3g}")
        print(f"| {obj} | {' | '.join(rates)} | {' | '.join(tests)} |", flush=True)


if __name__ == "__main__":
    main()
