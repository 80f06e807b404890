"""The `graspmanifold` command."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from .objects import PAPER_OBJECTS
from .posture import closed_posture, open_posture
from .scene import Scene, facing_pose


def _closed_scene(object_name: str, seconds: float, clearance: float) -> Scene:
    scene = Scene(object_name)
    scene.set_hand_pose(*facing_pose(object_name, clearance=clearance))
    scene.set_posture(open_posture())
    scene.set_target(closed_posture())
    scene.run(seconds)
    return scene


def _demo(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    scene = _closed_scene(args.object, args.seconds, args.clearance)
    wall = time.perf_counter() - start
    reading = scene.tactile()
    print(f"closed the hand on the {args.object} for {scene.time:.2f} s of simulated time "
          f"({scene.time / wall:.0f}x real time)")
    print(f"{len(reading.segments)} segments touch the object:")
    for segment in reading.segments:
        print(f"  {segment:<13} {reading.force_on(segment):7.2f} N")
    print(f"deepest penetration: {reading.max_penetration * 1e3:.2f} mm")
    return 0


def _view(args: argparse.Namespace) -> int:
    import mujoco.viewer  # imported here: it needs a display

    scene = Scene(args.object)
    scene.set_hand_pose(*facing_pose(args.object, clearance=args.clearance))
    scene.set_posture(open_posture())
    if args.close:
        scene.set_target(closed_posture())
    mujoco.viewer.launch(scene.model, scene.data)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="graspmanifold", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    demo = commands.add_parser("demo", help="close the hand on an object and print the touching segments")
    demo.add_argument("--object", choices=sorted(PAPER_OBJECTS), default="cylinder")
    demo.add_argument("--seconds", type=float, default=2.0, help="simulated seconds to close (default 2)")
    demo.add_argument("--clearance", type=float, default=0.01, help="palm-to-object gap in m (default 0.01)")
    demo.set_defaults(run=_demo)

    view = commands.add_parser("view", help="open MuJoCo's interactive viewer on a scene")
    view.add_argument("--object", choices=sorted(PAPER_OBJECTS), default="cylinder")
    view.add_argument("--clearance", type=float, default=0.01, help="palm-to-object gap in m (default 0.01)")
    view.add_argument("--close", action="store_true", help="command the closed posture (press space to run)")
    view.set_defaults(run=_view)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
