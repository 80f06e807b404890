"""graspmanifold: experience-based tactile grasping with the Shadow Hand in MuJoCo.

Commands: `reproduce` regenerates the paper's figures and tables, `generate` makes grasp postures,
`evaluate` runs the controller over a grid of object poses, `dataset` takes a folder of dataset objects to
experience and a comparison of controllers, `demo` closes the hand once, `view` opens MuJoCo's viewer. `graspmanifold COMMAND --help` shows each command's options and defaults.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any  # argparse names its subparsers action privately

from .base.config_files import read_config
from .base.errors import GraspManifoldError, InvalidInput
from .base.io import LOCK_FILE, check_writable_folder, npz_metadata, output_lock, write_failure
from .base.moved import OldFlag, current_name
from .base.version import __version__
from .base.workers import default_workers
from .control.controller import CONTROLLERS, PALM_STEERINGS
from .judging.protocols import DEFAULT_PROTOCOL, PROTOCOL_NAMES
from .judging.plans import GRASP_STAGES, VERIFY_STAGES
from .manifold.representations import REPRESENTATIONS
from .paper.report import FIGURES
from .sim.family import FAMILY
from .sim.flange import FlangeLimits
from .sim.hand import SHADOW_HAND
from .sim.hand_models import HAND_MODELS
from .sim.objects import GraspObject, named_object, named_objects
from .sim.posture import closed_posture, open_posture
from .sim.scene import TOUCH_SOURCES, Scene, facing_pose
from .studies.dataset import add_arguments as dataset_arguments, run as run_dataset
from .synthesis.generator import DATASET_PRESETS
from .synthesis.springs import MODES, PRESET_PARAMS
from .synthesis.starts import DESIGN_FAMILIES
from .trials.grid import GRID_PRESETS

HAND_HELP = (f"the hand model: {', '.join(HAND_MODELS)} ({SHADOW_HAND.name}: our MJCF of capsules, called ours before 0.2; gymnasium-robotics: pip install 'graspmanifold[hands]', from a checkout '.[hands]'; "
             "menagerie: MENAGERIE_ROOT set to a Menagerie checkout) or the path of a Shadow Hand's MJCF file")


def _object(args: argparse.Namespace) -> GraspObject:
    """The object --object names: a paper object, a family member, or a mesh file (times --scale)."""
    try:
        return named_object(args.object, args.scale)
    except (InvalidInput, ImportError) as error:
        raise SystemExit(f"error: --object: {error}") from None


def _hand_on(obj: GraspObject, clearance: float, hand: str, close: bool = True, seconds: float | None = None) -> Scene:
    """The open hand `clearance` in front of the object, commanded to its closed posture, `seconds` run."""
    scene = Scene(obj, hand=hand)
    scene.set_hand_pose(*facing_pose(obj, clearance=clearance))
    scene.set_posture(open_posture(scene.hand))
    if close:
        scene.set_target(closed_posture(scene.hand))
    if seconds is not None:
        scene.run(seconds)
    return scene


#: s, the longest `demo` closes the hand for (it closes in about 2 s)
MAX_DEMO_SECONDS = 60.0


def _demo(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    obj = _object(args)
    if not 0 < args.seconds <= MAX_DEMO_SECONDS:  # NaN fails too
        raise SystemExit(f"error: --seconds must be a positive duration of at most {MAX_DEMO_SECONDS:g} s (the hand "
                         f"closes in about 2 s), got {args.seconds}")
    try:
        scene = _hand_on(obj, args.clearance, args.hand, seconds=args.seconds)
    except (ValueError, ImportError) as error:
        raise SystemExit(f"error: {error}") from None
    wall = time.perf_counter() - start
    reading = scene.tactile()
    print(f"closed the hand on the {obj.name} for {scene.time:.2f} s of simulated time "
          f"({scene.time / wall:.0f}x real time)")
    print(f"{len(reading.segments)} segments touch the object:")
    for segment in reading.segments:
        print(f"  {segment:<13} {reading.force_on(segment):7.2f} N")
    print(f"deepest penetration: {reading.max_penetration * 1e3:.2f} mm")
    return 0


def _view(args: argparse.Namespace) -> int:
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise SystemExit("error: view opens a window and needs a display (DISPLAY is not set); `graspmanifold demo` "
                         "runs the same scene without one")
    import mujoco.viewer  # imported here: it needs a display

    scene = _hand_on(_object(args), args.clearance, args.hand, args.close)
    mujoco.viewer.launch(scene.model, scene.data)
    return 0


def _check_output(path: str, force: bool) -> Path:
    """An output .npz path that may be written: refuse existing files without --force, unwritable places."""
    out = Path(path)
    if out.suffix != ".npz":
        raise SystemExit(f"error: --out must end in .npz, got {path!r}")
    if out.is_dir():
        raise SystemExit(f"error: --out {out} is a directory; name an .npz file")
    if out.exists() and not force:
        raise SystemExit(f"error: {out} exists; pass --force to overwrite it")
    _check_writable_directory(out.parent)
    return out


def _check_writable_directory(out: Path) -> None:
    """Refuse an output folder that cannot be made or written, before any work (`io.check_writable_folder`)."""
    try:
        check_writable_folder(out, "--out")
    except InvalidInput as error:
        raise SystemExit(f"error: {error}") from None


def _checked(args: argparse.Namespace, units: int) -> None:
    """The arguments every working command shares, checked before any file is made: the hand (loaded, so
    that a file that is no Shadow Hand is refused now), the worker count (capped to the job's `units` of work)
    and the executor (connected: `args.cluster`)."""
    from .base.workers import workers_for
    from .sim.hand_models import hand_model

    try:
        hand_model(args.hand)
    except (InvalidInput, ImportError) as error:
        raise SystemExit(f"error: --hand: {error}") from None
    try:
        args.workers = workers_for(args.workers, units, 1)
    except InvalidInput as error:
        raise SystemExit(f"error: --{error}") from None
    args.cluster = _executor(args)


def _generate(args: argparse.Namespace) -> int:
    from .synthesis.generator import MAX_POSTURES

    obj = _object(args)
    n = args.n if args.n is not None else DATASET_PRESETS[args.preset].get(obj.name, DATASET_PRESETS[args.preset]["cylinder"])
    if not 0 < n <= MAX_POSTURES:
        raise SystemExit(f"error: --n must be a whole number in 1 ... {MAX_POSTURES}, got {n}")
    if args.seed < 0:
        raise SystemExit(f"error: --seed must be a whole number >= 0, got {args.seed}")
    out = _check_output(args.out, args.force)
    _checked(args, n)
    with output_lock(out.with_name(f".{out.name}.lock"), out):
        return _generate_into(args, obj, n, out)


def _generate_into(args: argparse.Namespace, obj: GraspObject, n: int, out: Path) -> int:
    """`generate` with its output file held."""
    from .base.checkpoints import remove_checkpoints
    from .synthesis.generator import generate_postures

    checkpoints = out.with_name(out.name + ".parts")
    params = replace(PRESET_PARAMS[args.preset], verify=not args.no_verify, designs=args.designs,
                     verify_protocol=args.protocol, stages=args.stages, hand=args.hand,
                     **({"mode": args.mode} if args.mode else {}))
    start = time.perf_counter()
    if args.force:
        remove_checkpoints(checkpoints)
    postures = generate_postures(obj, n, seed=args.seed, workers=args.cluster or args.workers, params=params,
                                 checkpoint_dir=checkpoints, progress=True)
    postures.save(out)
    remove_checkpoints(checkpoints)
    verified = (f"verified: {postures.metadata['verified_ratio']:.0%} of {postures.metadata['candidates']} candidates "
                "held" if params.verify else "not verified")
    print(f"wrote {len(postures)} {obj.name} postures to {out} in {time.perf_counter() - start:.1f} s "
          f"({verified}; acceptance {postures.metadata['acceptance_ratio']:.2f})")
    return 0


def _experience_files(args: argparse.Namespace):
    """The files of the experience base the evaluate command asks for, read and checked: None, a trained
    representation (--experience FILE.npz), or the posture sets (of --hand's postures) for a database or a representation to train."""
    from .manifold.postureset import PostureSet
    from .manifold.representations import load_representation, representation_name
    from .sim.hand_models import hand_name

    if args.experience not in (None, "none", *REPRESENTATIONS):  # a trained file (--map before 0.3)
        if Path(args.experience).suffix == "" and not Path(args.experience).exists():
            raise SystemExit(f"error: --experience must be none, one of {', '.join(REPRESENTATIONS)}, or a trained "
                             f"file (FILE.npz), got {args.experience!r}")
        if args.map:
            raise SystemExit(f"error: --experience {args.experience} and --map {args.map} both name a trained file: "
                             "give one, as --experience FILE.npz")
        if Path(args.experience).is_dir() or not Path(args.experience).exists():  # a device or FIFO: named on load
            why = "is a folder" if Path(args.experience).is_dir() else "does not exist"
            raise SystemExit(f"error: --experience {args.experience} {why}: give none, one of "
                             f"{', '.join(REPRESENTATIONS)}, or a trained file (FILE.npz)")
        args.map, args.experience = args.experience, None
    if args.map:  # the file says its kind; a kind named beside it must be that one
        if args.experience == "none":
            raise SystemExit("error: --map gives the controller an experience; --experience none runs without one: "
                             "drop one of them")
        experience = load_representation(args.map)
        recorded = npz_metadata(args.map).get("hand")  # maps a run trained say their hand
        if recorded is not None and current_name("hand", recorded) != hand_name(args.hand, "--hand"):
            raise SystemExit(f"error: --map {args.map} was trained on the {recorded!r} hand's postures, not --hand "
                             f"{args.hand}'s")
        kind = representation_name(experience)
        if args.experience not in (None, kind):
            raise SystemExit(f"error: --map {args.map} holds a {kind}, not a {args.experience}: pass --experience "
                             f"{kind}, or leave --experience out beside --map")
        args.experience = kind
        return experience
    args.experience = args.experience or "som"
    if args.experience == "none":
        if args.postures:
            raise SystemExit("error: --postures make the controller's experience; --experience none runs without one: "
                             "drop one of them")
        return None
    if not args.postures:
        raise SystemExit(f"error: --experience {args.experience} needs --postures FILE.npz (or give a trained file: --experience FILE.npz)")
    sets = [PostureSet.load(p) for p in args.postures]
    hand = hand_name(args.hand, "--hand")
    foreign = [f"{p} ({s.hand})" for p, s in zip(args.postures, sets) if s.hand != hand]
    if foreign:
        raise SystemExit(f"error: --postures of another hand than --hand {args.hand}: {', '.join(foreign)}")
    return PostureSet.concatenate(sets)


def _experience(args: argparse.Namespace, files):
    """The experience base from its files (`_experience_files`): as read, or the representation --experience
    names trained on the posture sets."""
    from .manifold.postureset import PostureSet
    from .manifold.representations import fit_representation

    if not isinstance(files, PostureSet):
        return files
    if args.experience != "database":
        print(f"training the {args.experience} representation on {len(files)} postures ...", file=sys.stderr)
    return fit_representation(args.experience, files.postures, seed=args.seed, progress=True)


def _evaluate(args: argparse.Namespace) -> int:
    from .trials.grid import check_grid
    from .trials.setup import Noise

    obj = _object(args)
    out = Path(args.out)
    _check_writable_directory(out)
    if args.seed < 0:
        raise SystemExit(f"error: --seed must be a whole number >= 0, got {args.seed}")
    try:
        noise = Noise(args.position_noise, args.yaw_noise, args.joint_noise)
        units = len(check_grid(args.grid, obj)[1])
        files = _experience_files(args)
    except (InvalidInput, FileNotFoundError) as error:
        raise SystemExit(f"error: {error}") from None
    _checked(args, units)
    with output_lock(out / LOCK_FILE, out):
        return _evaluate_into(args, obj, out, noise, files)


def _evaluate_into(args: argparse.Namespace, obj: GraspObject, out: Path, noise, files) -> int:
    """`evaluate` with its output folder held."""
    from .base.checkpoints import remove_checkpoints
    from .base.io import write_text_atomic
    from .trials.evaluation import evaluate, summary_json

    checkpoints = out / "trials.parts"
    results = [out / name for name in ("trials.npz", "summary.json", "table.md")]
    if any(p.exists() for p in results) and not args.force:
        raise SystemExit(f"error: {out} holds results already; pass --force to overwrite them")
    if args.force:
        remove_checkpoints(checkpoints)
    experience = _experience(args, files)
    start = time.perf_counter()
    steering = PALM_STEERINGS[args.palm_steering]
    ours = {"controller": args.controller} if not steering.active else {  # our controller with the palm's phases
        "params": replace(CONTROLLERS[args.controller], palm=steering)}
    result = evaluate(obj, experience, args.grid, seed=args.seed, workers=args.cluster or args.workers, noise=noise,
                      table=args.table, checkpoint_dir=checkpoints, progress=True,
                      backend=args.backend, hand=args.hand, margin=args.margin, protocol=args.protocol,
                      touch=args.touch, palm=FlangeLimits() if args.palm or steering.active else None, **ours)
    result.save(out / "trials.npz")
    write_text_atomic(out / "summary.json", summary_json([result]) + "\n")
    write_text_atomic(out / "table.md", result.markdown())
    remove_checkpoints(checkpoints)
    print(result.markdown() + f"\n{len(result.trials)} trials in {time.perf_counter() - start:.1f} s; results in {out}")
    return 0


def _figure(args: argparse.Namespace) -> int:
    from .paper.report import figure_from_run

    try:
        figure_from_run(args.run_dir, args.name, args.out)
    except FileNotFoundError as error:
        raise SystemExit(f"error: {error}") from None
    print(f"wrote {args.name}.png and {args.name}.pdf to {args.out or Path(args.run_dir) / 'figures'}")
    return 0


def _executor(args: argparse.Namespace):
    """The executor named by --executor, if any (a Dask cluster's)."""
    if not args.executor:
        return None
    from .base.workers import cluster_executor

    try:
        return cluster_executor(args.executor)
    except (ImportError, InvalidInput, OSError) as error:
        raise SystemExit(f"error: --executor: {error}") from None


def _reproduce(args: argparse.Namespace) -> int:
    from .paper.reproduce import PRESETS, reproduce

    if args.preset not in PRESETS:
        raise SystemExit(f"error: unknown preset {args.preset!r}; expected one of {', '.join(PRESETS)}")
    config = PRESETS[args.preset]
    _check_writable_directory(Path(args.out))
    try:
        if args.config:  # the file changes the preset; the flags below change it again where they are given
            config = read_config(args.config, config)
        if args.objects:
            sizes, names, meshes = config.postures, [], dict(config.meshes)
            for text, obj in zip(args.objects, named_objects(args.objects, args.scale)):  # names, or mesh files
                names.append(obj.name)
                if obj.shape == "mesh" and obj.name not in FAMILY:
                    meshes[obj.name] = {"file": text, "scale": args.scale}
            config = replace(config, postures={name: sizes.get(name, sizes["cylinder"]) for name in names},
                             meshes=meshes)
        elif args.scale != 1.0:
            raise InvalidInput("--scale is for the mesh files --object names")
        given = {"hand": args.hand, "controller": args.controller, "protocol": args.protocol, "manifold": args.manifold}
        given = {k: v for k, v in given.items() if not args.config or v != REPRODUCE_DEFAULTS[k]}
        if "controller" in given:
            given["controller"] = CONTROLLERS[given["controller"]]
        config = replace(config, **given)
    except InvalidInput as error:
        raise SystemExit(f"error: {error}") from None
    _checked(args, sum(config.postures.values()))
    summary = reproduce(args.out, config, workers=args.workers, force=args.force,
              log=lambda line: print(line, file=sys.stderr, flush=True), executor=args.cluster)
    print(f"report: {Path(args.out) / 'report.md'}")
    for row in summary["comparisons"]:  # the run's answer: experience against the plain heuristic, on the same poses
        if row["method"] == "som":
            print(f"{row['object']}: the SOM controller held {row['rate_text']}, the plain heuristic "
                  f"{row['control_text']} (McNemar p = {row['p_value']:.2g} on the same poses)")
    print(summary["verdict"])
    return 0


#: the defaults of `reproduce`'s configuration flags (a --config file's values stand unless a flag differs)
REPRODUCE_DEFAULTS = {"hand": SHADOW_HAND.name, "controller": "paper", "protocol": DEFAULT_PROTOCOL, "manifold": "som"}
PROTOCOL_HELP = ("how every grasp is judged: hold-test (gravity along six directions, the object within 2 cm), "
                 "hold-test-faded (the hold test after a support that fades over 0.3 s before the release), lift (the field's closed-loop "
                 "protocol: an arm raises the palm 0.2 m, held when the object rises 0.1 m; the hand on a flange) or "
                 "DexGraspBench's external-force test, its main version or its paper's (dexgraspbench-paper); the "
                 "names before 0.2, ours and ours-faded, still work")
CONTROLLER_HELP = ("what a recalled posture does: paper, the free fingers' target (the paper's reading); blend, the "
                   "closing heuristic's base (our earlier variant); closing-recall, the paper's reading with recalls "
                   "that only close a finger; blend-settled, the blend whose fingers squeeze together once the grasp "
                   "has settled; approach, the paper's reading executed as a verified grasp is: to the recall, on "
                   "along the way there, pressing along it (docs/studies/planned_grasps.md); approach-bounded, that with its "
                   "total grip force bounded to 15 N from the segment forces")

#: one default for every command that runs workers: the machine's cores, at most two
DEFAULT_WORKERS = default_workers()


def build_parser() -> argparse.ArgumentParser:
    """The `graspmanifold` command's parser: one subcommand each, its `run` the function that carries it out."""
    parser = argparse.ArgumentParser(prog="graspmanifold", description=__doc__, formatter_class=_FORMATTER)
    parser.add_argument("--version", action="version", version=f"graspmanifold {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_add_reproduce, _add_generate, _add_evaluate, _add_others):
        add(commands)
    return parser


_FORMATTER = argparse.ArgumentDefaultsHelpFormatter


def _protocol_name(name: str) -> str:
    """--protocol's value by its current name (`ours` before 0.2 is `hold-test`)."""
    return str(current_name("protocol", name))


def _command(commands: Any, name: str, help: str) -> argparse.ArgumentParser:
    return commands.add_parser(name, help=help, description=help, formatter_class=_FORMATTER)


def _object_options(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("--object", default="cylinder", help="a paper object (box, cylinder, sphere), a family "
                     "member (capsule_m, ring_l, bottle_s, ...: graspmanifold.sim.family.FAMILY) or a mesh file "
                     "(.stl, .obj, .ply, ...: a closed solid, or one whose holes can be filled)")
    sub.add_argument("--scale", type=float, default=1.0, help="metres per unit of a mesh file (0.001 for mm)")
    sub.add_argument("--hand", default=SHADOW_HAND.name, help=HAND_HELP)


def _workers(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("--workers", type=int, default=DEFAULT_WORKERS, help="parallel worker processes")
    sub.add_argument("--executor", help="run the jobs on a Dask cluster instead: dask://tcp://HOST:8786 (its "
                     "scheduler) or dask://local (a LocalCluster here); needs graspmanifold[cluster]")


def _add_reproduce(commands: Any) -> None:
    """`reproduce`."""
    reproduce = _command(commands, "reproduce", "regenerate every figure and table of the paper into one directory")
    reproduce.add_argument("--preset", choices=("first", "quick", "paper", "verified"), default="quick",
                           help="first (the quick preset on the cylinder alone: about a minute), quick (the "
                           "paper's procedure at small sizes on its three objects, a minute or two), paper (the paper's "
                           "procedure and dataset sizes) or verified (the paper's candidates, trained on those that hold)")
    reproduce.add_argument("--objects", "--object", nargs="+", metavar="NAME_OR_FILE",
                           help="objects to run instead of the paper's: paper or family names (e.g. cylinder ring_m "
                           "bottle_m) or mesh files of one's own (.stl, .obj, .ply: closed solids or ones whose holes can be filled, times --scale); "
                           "an object outside the paper gets the cylinder's preset size")
    reproduce.add_argument("--scale", type=float, default=1.0, help="metres per unit of the mesh files (0.001 for mm)")
    reproduce.add_argument("--hand", default=SHADOW_HAND.name, help=f"{HAND_HELP}: the postures are generated and the trials "
                           "run on it")
    reproduce.add_argument("--controller", choices=tuple(CONTROLLERS), default="paper", help=CONTROLLER_HELP)
    reproduce.add_argument("--protocol", type=_protocol_name, choices=PROTOCOL_NAMES, default=DEFAULT_PROTOCOL, help=PROTOCOL_HELP)
    reproduce.add_argument("--experience", dest="manifold", choices=("som", "ukr"), default="som",
                           help="what the controller recalls from: som (the paper's grasp manifold), or ukr: a "
                           "continuous UKR manifold trained beside the SOM on the same postures, run by the same "
                           "controller (methods ukr, ukr_all), resumed with its own grasps; the report gives its "
                           "figures beside the SOM's")
    reproduce.add_argument("--manifold", dest="manifold", choices=("som", "ukr"), default=argparse.SUPPRESS,
                           action=OldFlag, new="--experience", help=argparse.SUPPRESS)
    reproduce.add_argument("--config", metavar="FILE.toml",
                           help="an experiment file: the preset's configuration changed by its keys (ReproduceConfig's "
                           "fields; [generator] and [controller] tables); a run writes the one it used to "
                           "OUT/config.toml. --hand, --controller, --protocol and --experience change it again where given")
    reproduce.add_argument("--out", default="reproduction", help="output directory")
    _workers(reproduce)
    reproduce.add_argument("--force", action="store_true", help="replace another run's files in --out")
    reproduce.set_defaults(run=_reproduce)



def _add_generate(commands: Any) -> None:
    """`generate`."""
    generate = _command(commands, "generate", "generate grasp postures with the spring generator (verified as grasps)")
    _object_options(generate)
    generate.add_argument("--n", type=int, help="number of postures (default: the preset's size for the "
                          "object, the cylinder's for objects outside the paper); candidates are drawn until n of them "
                          "hold the object, unless --no-verify")
    generate.add_argument("--no-verify", action="store_true",
                          help="keep every candidate without replaying it as a grasp (the paper's procedure)")
    generate.add_argument("--protocol", type=_protocol_name, choices=PROTOCOL_NAMES, default=DEFAULT_PROTOCOL,
                          help="the protocol a candidate's open-loop replay must pass to be kept: hold-test (ours) "
                          "or DexGraspBench's (its physics and pushes)")
    generate.add_argument("--stages", choices=tuple(GRASP_STAGES), default=VERIFY_STAGES,
                          help="the replay's pregrasp and squeeze: made from the contacts (the default) or the open "
                          "hand's and the controller's squeeze")
    generate.add_argument("--designs", choices=DESIGN_FAMILIES,
                          help="the starting postures: every grasp type (power, precision pinch, tripod, lateral), "
                          "each start one that holds (the default), or the paper's five-fingertip grasps (the "
                          "default with --no-verify, the paper's procedure)")
    generate.add_argument("--preset", choices=("quick", "paper"), default="quick",
                          help="the generator mode and the dataset sizes when --n is not given: " + "; ".join(
                              f"{name} ({', '.join(f'{o} {n}' for o, n in sizes.items())})"
                              for name, sizes in DATASET_PRESETS.items()))
    generate.add_argument("--mode", choices=MODES, help="how candidates are taken along the walk (default: the "
                          "preset's: " + ", ".join(f"{k} {v.mode}" for k, v in PRESET_PARAMS.items()) + ")")
    generate.add_argument("--out", required=True, help="output .npz file")
    _workers(generate)
    generate.add_argument("--seed", type=int, default=0)
    generate.add_argument("--force", action="store_true", help="overwrite an existing output file")
    generate.set_defaults(run=_generate)



def _add_evaluate(commands: Any) -> None:
    """`evaluate`."""
    evaluate = _command(commands, "evaluate", "run the grasp controller over a grid of object poses and judge every grasp")
    _object_options(evaluate)
    evaluate.add_argument("--experience", default=None, metavar="KIND_OR_FILE",
                          help="what the controller recalls from: none (the plain tactile heuristic), a kind trained "
                               "on --postures (default som): " + "; ".join(f"{k}: {v}" for k, v in
                                                                          REPRESENTATIONS.items())
                               + "; or a trained SOM, UKR or linear manifold file (FILE.npz), its kind read from it")
    evaluate.add_argument("--postures", nargs="*", help="posture set file(s) the experience is made of")
    evaluate.add_argument("--map", "--som", dest="map", default=None, action=OldFlag, new="--experience FILE.npz",
                          help=argparse.SUPPRESS)
    evaluate.add_argument("--grid", choices=GRID_PRESETS, default="quick")
    evaluate.add_argument("--table", action="store_true",
                          help="the object stands on a table (gravity on) instead of a spring support")
    _workers(evaluate)
    evaluate.add_argument("--seed", type=int, default=0)
    evaluate.add_argument("--margin", action="store_true",
                          help="measure the disturbance margin of the grasps that hold "
                               "(more simulation per held grasp)")
    evaluate.add_argument("--touch", choices=TOUCH_SOURCES, default=TOUCH_SOURCES[0],
                          help="what the controller feels: the hand-object contacts' forces per segment (ours), "
                               "MuJoCo's touch sensors (a site over each segment: they feel the hand's own contacts "
                               "too) or its contact sensors between each segment and the object")
    evaluate.add_argument("--position-noise", type=float, default=0.0, help="object position noise (m)")
    evaluate.add_argument("--yaw-noise", type=float, default=0.0, help="object yaw noise (rad)")
    evaluate.add_argument("--joint-noise", type=float, default=0.0, help="joint sensing noise (rad)")
    evaluate.add_argument("--backend", choices=("cpu", "warp"), default="cpu",
                          help="physics engine: CPU MuJoCo in worker processes, or MuJoCo Warp on an NVIDIA GPU "
                               "(pip install 'graspmanifold[gpu]', from a checkout '.[gpu]')")
    evaluate.add_argument("--controller", choices=tuple(CONTROLLERS), default="paper", help=CONTROLLER_HELP)
    evaluate.add_argument("--protocol", type=_protocol_name, choices=PROTOCOL_NAMES, default=DEFAULT_PROTOCOL, help=PROTOCOL_HELP)
    evaluate.add_argument("--palm", action="store_true",
                          help="hang the hand on an arm's flange (sim.flange.FlangeLimits: the palm's six degrees of "
                               "freedom, servoed, bounded, lockable; the cpu backend); the lift protocol brings one")
    evaluate.add_argument("--palm-steering", choices=tuple(PALM_STEERINGS), default="still",
                          help="what moves the palm on the arm (it implies --palm): still, the paper's; touch, a guarded "
                               "approach of at most 2 cm, then re-centring within 3 cm on the touching segments "
                               "(control.controller.PALM_TOUCH); experience, re-centring on where the recalled grasp "
                               "had the object (PALM_EXPERIENCE: an experience that knows places)")
    evaluate.add_argument("--out", required=True, help="directory for summary.json, trials.npz and table.md")
    evaluate.add_argument("--force", action="store_true", help="overwrite results in --out")
    evaluate.set_defaults(run=_evaluate)



def _add_others(commands: Any) -> None:
    """`dataset`, `demo`, `figure` and `view`."""
    dataset = _command(commands, "dataset", "a folder of dataset objects as they ship (meshes, URDF or MJCF files) to verified "
                      "grasps, a map and a comparison of controllers on each, with a table at the end")
    dataset_arguments(dataset)
    dataset.set_defaults(run=run_dataset)

    demo = _command(commands, "demo", "close the hand on an object and print the touching segments")
    _object_options(demo)
    demo.add_argument("--seconds", type=float, default=2.0, help="simulated seconds to close")
    demo.add_argument("--clearance", type=float, default=0.01, help="palm-to-object gap in m")
    demo.set_defaults(run=_demo)

    figure = _command(commands, "figure", "redraw one figure of a finished `reproduce` run (PNG and PDF)")
    figure.add_argument("name", help=f"the figure; a run over the paper's objects has {', '.join(FIGURES)} (a run "
                        "over other objects names them after its objects)")
    figure.add_argument("run_dir", help="the output directory of `graspmanifold reproduce`")
    figure.add_argument("--out", help="directory for the figure (default: RUN_DIR/figures)")
    figure.set_defaults(run=_figure)

    view = _command(commands, "view", "open MuJoCo's interactive viewer on a scene (needs a display)")
    _object_options(view)
    view.add_argument("--clearance", type=float, default=0.01, help="palm-to-object gap in m")
    view.add_argument("--close", action="store_true", help="command the closed posture (press space to run)")
    view.set_defaults(run=_view)


#: what an interrupted command kept, and how to go on
_ON_INTERRUPT = {
    "generate": "finished jobs are kept in {out}.parts; run the same command again to resume",
    "reproduce": "finished stages are kept in {out}; run the same command again to resume",
    "evaluate": "finished trials are kept in {out}/trials.parts; run the same command again to resume",
    "dataset": "finished objects are kept in {out}; run the same command again to resume",
}


def _one_line_warning(message: Warning | str, category: type[Warning], *_: object, **__: object) -> str:
    return f"warning: {message}\n"


def main(argv: Sequence[str] | None = None) -> int:
    warnings.formatwarning = _one_line_warning  # the command's warnings as one line each, like its errors
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except KeyboardInterrupt:
        kept = _ON_INTERRUPT.get(args.command, "nothing to keep").format(out=getattr(args, "out", ""))
        print(f"\ninterrupted: {kept}", file=sys.stderr)
        return 130
    except GraspManifoldError as error:  # the library's refusals and failures: one line, no traceback
        raise SystemExit(f"error: {error}") from None
    except OSError as error:  # a file that could not be written (a full disk): one line, what is kept
        line = write_failure(error, _ON_INTERRUPT.get(args.command, "nothing to keep").format(out=getattr(args, "out", "")))
        if line is None:
            raise
        raise SystemExit(line) from None


if __name__ == "__main__":
    sys.exit(main())
