"""A hand model whose mesh files are not at hand, run on its MJCF text alone: a diagnostic of kinematics and
actuators (issue 28).

    python scripts/study_hand_without_meshes.py PATH/TO/right_hand.xml [--grid quick]

Menagerie's snapshot could not be fetched on the project's machine, but its `shadow_hand/right_hand.xml` could be
read. Without meshes MuJoCo cannot compile it; this script drops the visual meshes and replaces each colliding mesh
by a primitive of ours (a finger's or the thumb's distal phalanx: our capsule, radius 9 mm, 17 mm long; other
bodies' colliding meshes: nothing), so that everything else (kinematics, joint ranges, actuators, tendons, the
primitive collision geometry) is the model's own. It reports the hands study's tables for it: what the model is
made of beside ours (`joint_agreement` among them), then the heuristic controller on a grid with the model's own
physics, with our finger servos, and with our servos and contact parameters, beside our hand (Wilson intervals,
McNemar's test on the same poses). It is not the model with its meshes: fingertip contacts differ.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

import mujoco
from graspmanifold.studies.hands import ablation_rows, facts_rows

import graspmanifold as gm
from graspmanifold.sim.hand_models import check_hand_model, describe_shadow_hand, hand_file_spec


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
    parser.add_argument("--doc", help="also write the tables to this Markdown file")
    args = parser.parse_args()
    path = Path(args.mjcf).resolve()
    hand = describe_shadow_hand(functools.partial(without_meshes, functools.partial(hand_file_spec, path)),
                                f"{path.name} without meshes", str(path))
    check_hand_model(hand)
    text = "\n".join([f"# {path.name} without its meshes, beside ours (issue 28)", "",
                      f"`python scripts/study_hand_without_meshes.py {path.parent.name}/{path.name} --grid {args.grid}`: "
                      "its MJCF text alone, the visual meshes dropped and each colliding distal mesh replaced by our "
                      "capsule; everything else is the model's own. A diagnostic of its kinematics and actuators, not "
                      "the model with its meshes."]
                     + facts_rows([gm.SHADOW_HAND, hand]) + ablation_rows(hand, args.grid))
    if args.doc:
        Path(args.doc).write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
