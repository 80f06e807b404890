"""A dataset's objects as they ship to experience: verified grasps, a map and a comparison of controllers on each.

    graspmanifold dataset FOLDER [--postures 20] [--grid quick] [--poses N] [--scale 1] [--experience som|ukr|linear]
                                 [--workers 2] [--out dataset]

The objects are the files under FOLDER (`object_files`): its object files (.urdf, MJCF .xml: a robot data package's,
which name their mesh pieces) and the mesh files no object file names (parsed, not searched as text), each loaded as
it comes; nothing outside FOLDER is read (an object file that names a file outside it, through ../, an absolute path,
an include or a link, is refused) unless `--outside` says so
(`make_object`: overlapping pieces joined, holes filled, a convex decomposition kept as its pieces; what was
repaired is said). On each object that loads: `--postures` verified postures with the generator's defaults (the
start search first, for an object that ships none), a 25 x 25 map trained on them (`--experience`: or a UKR or linear
manifold, `manifold.representations`; kept in OUT/maps/<object>_<manifold>.npz), and three controllers on the same
grid poses: the plain tactile controller (`none`), the database of the postures and the map (`som`, the paper's, or
the manifold's name). A progress bar counts the objects; the table at the end gives per object how it loaded, its triangles,
its verified postures and each controller's hold rate [95 % Wilson interval], with McNemar's test of the map
against `none` (Holm over the objects). An object that is refused, or gets no starting posture, is a row that says
why. Writes OUT/dataset.md and OUT/dataset.json (with the software versions); the posture sets, maps and
evaluations are kept in OUT under keys of what made them, so a rerun (or an interrupted run run again) takes what
is done.
"""

from __future__ import annotations

import argparse
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..base.checkpoints import result_key
from ..base.errors import GenerationError, InvalidInput
from ..base.io import json_text, markdown_table, read_json, software_versions, write_text_atomic
from ..base.moved import OldFlag
from ..base.progress import progress_bar
from ..base.validation import check_int
from ..manifold.experience import Experience, check_experience
from ..manifold.postureset import PostureSet
from ..manifold.representations import fit_representation
from ..sim.meshes import MESH_FORMATS, MODEL_FORMATS
from ..sim.object_files import object_file_references
from ..sim.objects import GraspObject, make_object
from ..synthesis.generator import generate_postures
from ..trials.evaluation import evaluate
from ..trials.stats import compare
from ..trials.grid import GRID_PRESETS, grid_preset
from ..trials.stats import PairedComparison, mcnemar, rate_text
from ..trials.setup import TrialSetup
from .runner import StudyRun, comparison_table, holm_family, run_study

#: the controllers compared on each object, by the experience they recall
METHODS = ("none", "database", "som")
#: the grasp manifolds `--experience` may name instead of the SOM (`manifold.representations.REPRESENTATIONS`)
MANIFOLDS = ("som", "ukr", "linear")


def methods(manifold: str = "som") -> tuple[str, ...]:
    """The controllers compared, by the experience they recall: `METHODS` with the manifold `--manifold` names.

    Args:
        manifold: one of `MANIFOLDS`.

    Returns:
        ('none', 'database', manifold).
    """
    return (*METHODS[:2], manifold)


@dataclass(frozen=True)
class DatasetFiles:
    """What a dataset folder holds, every file with what becomes of it.

    Attributes:
        objects: the object files, in sorted order: the object files (`meshes.MODEL_FORMATS`) and the mesh files
            (`meshes.MESH_FORMATS`) no object file names.
        fates: {path under the folder: what becomes of it}: 'object', 'part of <object file>', or 'not an object
            file' (another format).
    """

    objects: list[Path]
    fates: dict[str, str]


def object_files(folder: str | Path, outside: bool = False) -> DatasetFiles:
    """The object files of a dataset folder and the folders under it: its object files, and its mesh files but
    those an object file names (a robot data package keeps an object's meshes beside or below the file that names
    and scales them: they are that object's pieces, not objects of their own). What an object file names is read by
    parsing it (`object_files.object_file_references`), never by searching its text.

    Args:
        folder: the dataset's folder.
        outside: an object file may name files outside the folder (otherwise such an object is refused when it
            loads; the names are read here either way).

    Returns:
        The `DatasetFiles`.

    Raises:
        InvalidInput: the folder does not exist or holds no object.
    """
    root = Path(folder)
    if not root.is_dir():
        raise InvalidInput(f"dataset folder {str(folder)!r} is not a folder")
    files = sorted(p for p in root.rglob("*") if p.is_file() or p.is_fifo())
    models = [p for p in files if p.suffix.lower().lstrip(".") in MODEL_FORMATS]
    parts: dict[Path, Path] = {}
    for model in models:
        try:
            named = object_file_references(model, None if outside else root).files
        except InvalidInput:  # refused when it loads, with the reason; its parts are unknown
            continue
        for part in named:
            parts.setdefault(part, model)
    fates: dict[str, str] = {}
    objects = []
    for path in files:
        where = str(path.relative_to(root))
        kind = path.suffix.lower().lstrip(".")
        if path.resolve() in parts and kind not in MODEL_FORMATS:
            fates[where] = f"part of {parts[path.resolve()].relative_to(root)}"
        elif kind in MODEL_FORMATS + MESH_FORMATS:
            fates[where] = "object"
            objects.append(path)
        else:
            fates[where] = "not an object file"
    if not objects:
        raise InvalidInput(f"dataset folder {str(folder)!r} holds no object file ("
                           f"{', '.join('.' + f for f in MODEL_FORMATS + MESH_FORMATS)})")
    return DatasetFiles(objects, fates)


def object_names(files: list[Path], root: Path) -> list[str]:
    """A name for each file, unique by construction: its stem, or its path under the root (folders joined by '_')
    where stems repeat, and where even those repeat (`a/b/c.obj`, `a_b/c.obj`) a digest of the path after it.

    Args:
        files: the object files.
        root: the dataset's folder.

    Returns:
        The names, in order.
    """
    stems = [p.stem for p in files]
    names = [p.stem if stems.count(p.stem) == 1 else "_".join(p.relative_to(root).with_suffix("").parts)
             for p in files]
    return [name if names.count(name) == 1 else f"{name}-{result_key(str(p.relative_to(root)))[:6]}"
            for name, p in zip(names, files)]


def load_object(path: Path, name: str, scale: float, within: Path | None = None) -> tuple[GraspObject | None, str]:
    """An object file loaded as it ships, and how: 'as shipped', what was repaired (`make_object`'s warning),
    'refused: ' and the reason, or 'failed: ' and the error that ended its loading (one object's failure is its row).

    Args:
        path: the file.
        name: the object's name.
        scale: metres per unit of a mesh file.
        within: the folder the file and every file it names must lie in (None: anywhere).

    Returns:
        The object (None when refused) and how it loaded.
    """
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            if within is not None and path.suffix.lower().lstrip(".") in MODEL_FORMATS:
                object_file_references(path, within)
            elif within is not None and not path.resolve().is_relative_to(within.resolve()):
                raise InvalidInput(f"{str(path)!r}: a link to {str(path.resolve())!r}, outside the folder: nothing "
                                   "outside it is read unless asked for (--outside)")
            obj = make_object("mesh", mesh=path, scale=scale, name=name)
        except InvalidInput as error:  # the row names the object: the reason without the file's path (a long path
            # filled the cell and cut the reason off)
            reason = str(error).replace(f"{str(path)!r}: ", "", 1).replace(repr(str(path)), repr(path.name))
            return None, f"refused: {reason}"
        except Exception as error:  # noqa: BLE001 (one object's failure, a MemoryError too, is its row, not the run's end)
            return None, f"failed: {type(error).__name__}: {error}"
    repairs = [re.sub(r"^mesh object '.*?' made one solid: ", "", str(w.message)) for w in said
               if issubclass(w.category, UserWarning) and not issubclass(w.category, DeprecationWarning)]
    return obj, "; ".join(repairs) or "as shipped"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options (`graspmanifold dataset`).

    Args:
        parser: the parser to add them to.
    """
    parser.add_argument("folder", help="the dataset's folder: object files (.urdf, .xml) or mesh files (.stl, .obj, "
                        ".ply, ...) in it and in the folders under it")
    parser.add_argument("--postures", type=int, default=20, help="verified postures per object")
    parser.add_argument("--grid", choices=GRID_PRESETS, default="quick", help="the grid of object poses")
    parser.add_argument("--poses", type=int, help="at most this many of the grid's poses, evenly spread over it "
                        "(default: all)")
    parser.add_argument("--scale", type=float, default=1.0, help="metres per unit of the mesh files (an object file "
                        "gives its own)")
    parser.add_argument("--seed", type=int, default=0, help="the generator's and the trials' seed")
    parser.add_argument("--experience", dest="manifold", choices=MANIFOLDS, default="som", help="what the "
                        "controller recalls from, trained on each object's postures: the paper's 25 x 25 SOM, a 2-d UKR "
                        "or a 5-component linear manifold (PCA)")
    parser.add_argument("--manifold", dest="manifold", choices=MANIFOLDS, default=argparse.SUPPRESS, action=OldFlag,
                        new="--experience", help=argparse.SUPPRESS)
    parser.add_argument("--workers", type=int, default=2, help="parallel worker processes")
    parser.add_argument("--outside", action="store_true", help="let object files name files outside the folder "
                        "(through ../, absolute paths, includes or links); without it such an object is refused")
    parser.add_argument("--out", default="dataset", help="output directory")


def run(args: argparse.Namespace) -> int:
    """The command: every object of the folder to experience and a comparison (module doc).

    Args:
        args: the parsed options (`add_arguments`).

    Returns:
        0 (the exit status).
    """
    for option in ("postures", "poses"):
        if getattr(args, option) is not None and getattr(args, option) < 1:
            raise SystemExit(f"error: --{option} must be at least 1, got {getattr(args, option)}")
    root = Path(args.folder)
    try:
        found = object_files(root, args.outside)
    except InvalidInput as error:
        raise SystemExit(f"error: {error}") from None
    run_study(args.out, args.workers, lambda study: _run(args, study, root, found), pool=False)
    return 0


def _run(args: argparse.Namespace, study: StudyRun, root: Path, found: DatasetFiles) -> None:
    rows: list[dict[str, Any]] = []
    tests: list[tuple[str, PairedComparison]] = []
    files = found.objects
    with progress_bar(len(files), f"dataset {root.name}", "objects") as bar:
        for path, name in zip(files, object_names(files, root)):
            obj, loaded = load_object(path, name, args.scale, None if args.outside else root)
            row: dict[str, Any] = {"object": name, "file": str(path.relative_to(root)), "loaded": loaded}
            if obj is not None:
                row |= _experience(args, study, obj)
                if args.manifold in row.get("results", {}):
                    tests.append((name, row.pop("comparison")))
            rows.append(row)
            study.log(f"{name}: {loaded}; {row.get('postures', 0)} verified postures")
            bar.update(1)
    tested = {r["label"]: r for r in holm_family(tests)}
    section = [f"## {args.manifold}", "",
               f"{len(files)} object files; {args.postures} verified postures each (seed {args.seed}), the {args.grid} "
               f"grid{f' ({args.poses} of its poses)' if args.poses else ''}; hold [95 % Wilson CI]; `{args.manifold}` "
               "against `none` on the same poses (McNemar, Holm over the objects).",
               "", *markdown_table(["object", "loaded", "triangles", "verified postures", *methods(args.manifold),
                                    f"{args.manifold} - none (p Holm)"], [_table_row(r, tested, args.manifold)
                                                                           for r in rows]), ""]
    usable = [r for r in rows if not r["loaded"].startswith(("refused", "failed"))]
    section += [f"Loaded {len(usable)} of {len(rows)}; {sum(r.get('postures', 0) >= args.postures for r in rows)} got "
                f"{args.postures} verified postures.", ""]
    pooled = pooled_rows(rows, args.manifold)
    if pooled:
        section += ["Every object's trials together (paired by pose):", "",
                    *markdown_table(["controller", "trials", "hold", "none's hold", "difference", "McNemar p"], pooled),
                    "", "Per object:", "", *comparison_table(list(tested.values()))]
    else:  # two tables without a row said nothing
        section += ["No object got trials: nothing to compare."]
    for row in rows:
        row.pop("outcomes", None)
    options = {k: v for k, v in vars(args).items() if k != "run"}
    run = {"options": options, "objects": rows, "pooled": pooled, "comparisons": list(tested.values()),
           "report": section}
    manifolds = _earlier_manifolds(study.out / "dataset.json", root) | {args.manifold: run}  # every manifold run here
    lines = [f"# Dataset {root.name}: experience and controllers on each object", "",
             f"The manifolds run into this folder: {', '.join(manifolds)}.", ""]
    for earlier in manifolds.values():
        lines += [*earlier["report"], ""]
    others = {where: fate for where, fate in found.fates.items() if fate != "object"}
    if others:
        lines += ["The folder's other files, and what became of them:", "",
                  *markdown_table(["file", "what it is"], [[where, fate] for where, fate in others.items()])]
    write_text_atomic(study.out / "dataset.md", "\n".join(lines) + "\n")
    write_text_atomic(study.out / "dataset.json", json_text(
        {"folder": str(root), **run, "trials": _setup_record(), "files": found.fates, "manifolds": manifolds,
         "versions": software_versions()}))
    print("\n".join(section))
    print(f"wrote {study.out / 'dataset.md'} and {study.out / 'dataset.json'}")


def _earlier_manifolds(path: Path, root: Path) -> dict[str, dict]:
    """The manifolds an earlier run of the same folder wrote into `dataset.json` (none where there is no such file,
    or it is of another folder or unreadable: it is then written anew)."""
    if not path.exists():
        return {}
    try:
        earlier = read_json(path, "the earlier dataset.json")
    except InvalidInput:
        return {}
    if earlier.get("folder") != str(root) or not isinstance(earlier.get("manifolds"), dict):
        return {}
    return {name: run for name, run in earlier["manifolds"].items()
            if isinstance(run, dict) and isinstance(run.get("report"), list)}


def _experience(args: argparse.Namespace, study: StudyRun, obj: GraspObject) -> dict:
    """One object's verified postures, map and controllers' trials (a row of the table, with 'comparison' the map
    against `none` when both ran)."""
    row: dict = {"triangles": 0 if obj.mesh is None else len(obj.mesh.faces), "digest": obj.mesh_digest}
    key = result_key({"object": obj.params(), "n": args.postures, "seed": args.seed})
    try:
        postures = study.postures(f"postures/{obj.name}", key, lambda parts: generate_postures(
            obj, args.postures, seed=args.seed, workers=study.workers, checkpoint_dir=parts, progress=False))
    except GenerationError as error:
        return row | {"postures": 0, "note": str(error)}
    row["postures"] = len(postures)
    experience: dict[str, PostureSet | Experience | None] = {"none": None}
    if len(postures):
        experience["database"] = postures
        try:
            made = fit_representation(args.manifold, postures.postures, seed=args.seed, progress=False)
        except InvalidInput as error:  # too few postures for the manifold: its controller does not run here
            row["note"] = f"no {args.manifold}: {error}"
        else:
            experience[args.manifold] = made
            (study.out / "maps").mkdir(exist_ok=True)
            made.save(study.out / "maps" / f"{obj.name}_{args.manifold}.npz",
                      extra={"object": obj.params(), "postures_key": key})
    grid, poses = trial_grid(args.grid, args.poses, obj)
    results = {}
    for method, recalled in experience.items():
        setup = TrialSetup(object=obj, experience=check_experience(recalled), method=method)
        results[method] = study.evaluation(f"evaluation/{obj.name}_{method}", setup.key(poses, args.seed),
                                           lambda parts: evaluate(setup, grid=grid, seed=args.seed,
                                                                  workers=study.workers, checkpoint_dir=parts,
                                                                  progress=False))
    row["results"] = {m: [int(r.outcomes("hold").sum()), len(r.trials)] for m, r in results.items()}
    row["outcomes"] = {m: (r.outcomes("hold"), r.valid) for m, r in results.items()}
    if args.manifold in results:
        row["comparison"] = compare(results[args.manifold], results["none"])
    return row


def trial_grid(preset: str, poses: int | None, obj: GraspObject) -> tuple[str | np.ndarray, np.ndarray]:
    """The grid an object's trials run on: the preset by its name (so that results say which), or at most `poses` of
    its poses, evenly spread over it.

    Args:
        preset: the grid preset (`GRID_PRESETS`).
        poses: at most this many poses (None: all).
        obj: the object.

    Returns:
        (the grid to pass to `evaluate`: the preset's name, or the chosen poses; the poses (n, 4)).
    """
    every = grid_preset(preset, obj)
    if poses is not None:
        check_int(poses, "poses")
    if poses is None or poses >= len(every):
        return preset, every
    chosen = every[np.linspace(0, len(every) - 1, poses).round().astype(int)]
    return chosen, chosen


def pooled_rows(rows: list[dict], manifold: str = "som") -> list[list]:
    """Each controller against `none` over the trials of every object that ran all three (McNemar, paired by pose).

    Args:
        rows: the table's rows, with their 'outcomes'.
        manifold: the grasp manifold of the third controller (`MANIFOLDS`).

    Returns:
        Table rows: method, trials, its hold and `none`'s [95 % Wilson CI], the difference and the p-value.
    """
    ran = [row["outcomes"] for row in rows if set(row.get("outcomes", {})) == set(methods(manifold))]
    if not ran:
        return []
    none = np.concatenate([r["none"][0] for r in ran])
    table = []
    for method in methods(manifold)[1:]:
        held = np.concatenate([r[method][0] for r in ran])
        valid = np.concatenate([r[method][1] & r["none"][1] for r in ran])
        test = mcnemar(held, none, valid=valid)
        table.append([method, int(valid.sum()), rate_text(int(held[valid].sum()), int(valid.sum())),
                      rate_text(int(none[valid].sum()), int(valid.sum())),
                      f"{100 * test.difference:+.1f} pts", f"{test.p_value:.3g}"])
    return table


def _setup_record() -> dict:
    """What the trials ran with (`TrialSetup`'s defaults, the same for every object and controller)."""
    setup = TrialSetup(object=make_object("box", size=(0.04, 0.04, 0.16)))
    return {"hand": setup.hand.name, "protocol": setup.protocol.name, "touch": setup.touch, "backend": setup.backend,
            "controller": setup.params.to_table()}


def _table_row(row: dict, tested: dict, manifold: str) -> list:
    results = row.get("results", {})
    rates = [rate_text(*results[m]) if m in results else "-" for m in methods(manifold)]
    test = tested.get(row["object"])
    versus = f"{100 * test['difference']:+.1f} pts ({test['p_holm']:.2g})" if test else "-"
    loaded = row["loaded"] if len(row["loaded"]) < 90 else row["loaded"][:87] + "..."
    if row.get("note"):  # no starting posture: the reason's first clause
        loaded += "; " + row["note"].split(":", 1)[0]
    return [row["object"], loaded, row.get("triangles", "-"),
            row.get("postures", "-"), *rates, versus]
