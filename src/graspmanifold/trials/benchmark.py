"""A benchmark where grasp choice matters: objects that ask for different grasp types, placed near the
palm and out at the fingertips, pooled in one test set, with a selection set disjoint from it.

On the paper's grids every placement asks for a power grasp of a hand-sized object, so no choice of
finger posture can matter much there (the per-pose oracle over several strategies gains little over
the best one: `stats.headroom`). This benchmark adds ordinary small and flat things that a hand
grasps with its fingertips, and places every object both where the palm can wrap it and out where
only the fingers reach it. The controller is never told which object it grasps.

Objects, each chosen for a reason stated before any method ran on it (`OBJECTS`):

- box, cylinder, sphere: the paper's objects (100 g), hand-sized, asking for a power grasp;
- marble: a 2 cm ball of 10 g (a marble, a grape, a cherry): too small to wrap, a pinch or a tripod;
- pen: a 1 cm rod 14 cm long, 10 g (a pen, a chopstick): wrapped against the palm, a tripod at the tips;
- disc: 5 cm across and 6 mm thick, 15 g (a lid, a coaster, a large coin): flat, a lateral grasp or a pinch;
- cube: 2.5 cm, 15 g (a die, an eraser): a tripod.

Placements (`PLACEMENTS`), in the grid coordinates of `grid.py` (shift across and along the fingers,
gap in front of the palm, yaw about the palm normal): `palm`, the object's centre within 1.5 cm of
the palm's grasp centre, 1 or 2.5 cm in front of the palm, turned by up to 0.4 rad; `fingertips`,
around the point where the thumb's tip meets the index and middle fingertips (0-3 cm towards the
thumb, 2.5-5.5 cm further along the fingers, 2.5 or 4 cm in front of the palm), turned likewise. The test grid is a
lattice; the selection grid lies on the lattice's midpoints, so the two share no value on any axis:
controls and parameters are chosen on the selection grid, then judged on the test grid. A ball has no
yaw; it gets more gaps instead, so every object has about as many poses.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from ..base.checkpoints import PartStore, remove_checkpoints
from ..base.errors import InvalidInput
from ..base.validation import check_choice, check_int, check_name, file_in
from ..manifold.experience import Experience
from ..sim.objects import GraspObject, get_object, make_object
from .evaluation import EvaluationResult, evaluate
from .grid import reachable
from .setup import TrialSetup
from .stats import PairedComparison, mcnemar, stratified_split

#: where the objects are placed, and which grid: the test lattice or the selection grid between its points
PLACEMENTS: tuple[str, ...] = ("palm", "fingertips")
SPLITS: tuple[str, ...] = ("test", "selection")


@dataclass(frozen=True)
class BenchmarkObject:
    """One object of the benchmark and why it is there."""

    object: GraspObject
    grasp: str  # the grasp type one would use on it
    reason: str


OBJECTS: dict[str, BenchmarkObject] = {
    "box": BenchmarkObject(get_object("box"), "power", "the paper's box: hand-sized, wrapped"),
    "cylinder": BenchmarkObject(get_object("cylinder"), "power", "the paper's cylinder: hand-sized, wrapped"),
    "sphere": BenchmarkObject(get_object("sphere"), "power", "the paper's sphere: a ball held in the whole hand"),
    "marble": BenchmarkObject(make_object("sphere", radius=0.01, mass=0.01, name="marble"), "precision",
                              "a marble or a grape: too small to wrap, pinched or held in a tripod"),
    "pen": BenchmarkObject(make_object("cylinder", radius=0.005, length=0.14, mass=0.01, name="pen"), "tripod",
                           "a pen or a chopstick: wrapped against the palm, a tripod at the fingertips"),
    "disc": BenchmarkObject(make_object("cylinder", radius=0.025, length=0.006, mass=0.015, name="disc"), "lateral",
                            "a lid or a coaster: flat, pressed between thumb and the side of the index finger"),
    "cube": BenchmarkObject(make_object("box", size=(0.025, 0.025, 0.025), mass=0.015, name="cube"), "tripod",
                            "a die or an eraser: held by the tips of thumb, index and middle finger"),
}

#: grid axes (m, rad) of the test lattice per placement; the selection grid takes the midpoints between its
#: values. `fingertips` is centred where the designed precision grasps of the small objects hold their
#: object (`starts.PRECISION_DESIGNS` refined and walked by the generator: 1-2 cm towards the thumb,
#: about 4 cm along the fingers and 3.5 cm in front of the palm), `palm` on the palm's grasp centre.
_ACROSS = {"palm": (-0.015, 0.0, 0.015), "fingertips": (0.0, 0.015, 0.03)}
_ALONG = {"palm": (-0.015, 0.0, 0.015), "fingertips": (0.025, 0.04, 0.055)}
_GAPS = {"palm": (0.01, 0.025), "fingertips": (0.025, 0.04)}
_YAWS = (-0.4, 0.0, 0.4)
#: a ball has no yaw: three times the gaps instead, over the same range
_BALL_GAPS = {"palm": (0.005, 0.01, 0.015, 0.02, 0.025, 0.03), "fingertips": (0.02, 0.025, 0.03, 0.035, 0.04, 0.045)}


def _midpoints(values: Sequence[float]) -> list[float]:
    return [(a + b) / 2 for a, b in zip(values, values[1:])]


def benchmark_grid(name: str, placement: str, split: str = "test") -> np.ndarray:
    """The reachable grid poses (n, 4) of one benchmark object at one placement.

    Args:
        name: a key of `OBJECTS`.
        placement: 'palm' or 'fingertips' (`PLACEMENTS`).
        split: 'test' (the lattice) or 'selection' (its midpoints: no value shared with the test grid).

    Returns:
        Grid poses: shift across (x) and along (z) the fingers, palm gap (m), yaw (rad).
    """
    if name not in OBJECTS:
        raise InvalidInput(f"unknown benchmark object {name!r}; expected one of {tuple(OBJECTS)}")
    check_choice(placement, PLACEMENTS, "placement")
    check_choice(split, SPLITS, "split")
    obj = OBJECTS[name].object
    ball = obj.shape == "sphere"
    gaps = _BALL_GAPS[placement] if ball else _GAPS[placement]
    axes: list[Sequence[float]] = [_ACROSS[placement], _ALONG[placement], gaps, (0.0,) if ball else _YAWS]
    if split == "selection":
        axes = [_midpoints(a) if len(a) > 1 else list(a) for a in axes]
        if not ball:  # two gaps have one midpoint: take the gaps a quarter and three quarters of the way instead
            axes[2] = [gaps[0] + 0.25 * (gaps[1] - gaps[0]), gaps[0] + 0.75 * (gaps[1] - gaps[0])]
    poses = np.array(list(itertools.product(*axes)), dtype=np.float64)
    return poses[reachable(obj, poses)]


def benchmark_split(selection: float = 1 / 3, seed: int = 0) -> dict[str, dict[tuple[str, str], np.ndarray]]:
    """A random split of all the benchmark's poses (the test lattice and its midpoints, pooled) into a selection
    split, to fix controls and tune on, and a test split, touched once; stratified by object and placement
    (`stats.stratified_split`), so each (object, placement) gives each split the same share.

    Args:
        selection: the share of each (object, placement) in the selection split, in (0, 1).
        seed: the split's seed.

    Returns:
        {'selection': {(object, placement): poses (n, 4)}, 'test': {...}}, cells in `cells()` order.
    """

    poses = {key: np.concatenate([benchmark_grid(*key, split) for split in SPLITS]) for key in cells()}
    strata = [key for key in cells() for _ in poses[key]]
    everything = np.concatenate(list(poses.values()))
    picked, rest = stratified_split(strata, selection, seed)
    split = {}
    for name, rows in (("selection", picked), ("test", rest)):
        labels = [strata[i] for i in rows]
        split[name] = {key: everything[rows[[label == key for label in labels]]] for key in cells()}
    return split


def cells() -> list[tuple[str, str]]:
    """Every (object, placement) of the benchmark, in a fixed order."""
    return [(name, placement) for name in OBJECTS for placement in PLACEMENTS]


def run_benchmark(experience: Experience | None = None, *, split: str = "test",
                  objects: tuple[str, ...] | Mapping[tuple[str, str], np.ndarray] | None = None, every: int = 1,
                  seed: int = 0, workers: int | Executor | None = None, store: str | os.PathLike | None = None,
                  **setup: object) -> dict[tuple[str, str], EvaluationResult]:
    """One controller on every (object, placement) of the benchmark, the object never told to it. Progress bars
    show as `progress.show_progress` says.

    Args:
        experience: None (the plain heuristic), a PostureDatabase or a SOM: one for all objects.
        split: 'test' or 'selection'.
        objects: the benchmark objects to run (default: all of `OBJECTS`), on `benchmark_grid(object, placement,
            split)`; or the grid poses (n, 4) of each (object, placement) to run (a random split,
            `benchmark_split`: `split` then only names the stored files).
        every: keep every k-th pose of each grid (a smaller, CI-sized run).
        seed: the trials' seed.
        workers: worker processes, or an executor that runs the trials (as `evaluate` takes it).
        store: a directory where each finished (object, placement) is kept as `<method>_<split>_<object>_<placement>.npz`
            and taken from on a rerun (an interrupted run resumes), with its trials checkpointed meanwhile.
        **setup: the `TrialSetup` fields by name, as `evaluate` takes them (the object is the benchmark's):
            params, preshape, noise, controller (a user's own; give a `method`), regrasp, protocol, and method
            (the method's name, for the stored files and `EvaluationResult.method`; with a `store`: letters,
            digits and `_ . + -`, `validation.SAFE_NAME`).

    Returns:
        {(object, placement): EvaluationResult} in `cells()` order.
    """
    poses = dict(objects) if isinstance(objects, Mapping) else None
    if poses is not None:
        stray = [key for key in poses if key not in cells()]
        if stray:
            raise InvalidInput(f"objects: the poses' keys must be (object, placement) cells of the benchmark, got {stray}")
    names = tuple(OBJECTS) if objects is None else tuple(dict.fromkeys(k[0] for k in poses)) if poses is not None \
        else tuple(objects)
    unknown = [name for name in names if name not in OBJECTS]
    if unknown or not names:
        raise InvalidInput(f"objects must name benchmark objects ({', '.join(OBJECTS)}), got {list(names)}")
    check_choice(split, SPLITS, "split")
    every = check_int(every, "every")
    label = str(setup.get("method") or "")
    if store is not None:  # the label becomes part of the stored files' names
        check_name(label or "method", "method")
    results = {}
    for name, placement in cells():
        if name not in names:
            continue
        path = None if store is None else file_in(store, f"{label or 'method'}_{split}_{name}_{placement}.npz", "method")
        if poses is not None and (name, placement) not in poses:
            continue
        grid = (benchmark_grid(name, placement, split) if poses is None else poses[(name, placement)])[::every]
        trial_setup = TrialSetup.build(OBJECTS[name].object, experience, **setup)
        key = trial_setup.key(grid, seed)
        cell = None if path is None else PartStore(path.parent, key, EvaluationResult.load_with_metadata)
        if cell is not None and path is not None:  # stored under this label by another configuration (or code): rerun
            stored = cell.load(path.name)
            if stored:
                results[(name, placement)] = stored[path]
                continue
        parts = None if path is None else path.with_suffix(".parts")
        result = evaluate(trial_setup, grid=grid, seed=seed, workers=workers, checkpoint_dir=parts)
        result.grid_name = f"{split}/{placement}"
        if cell is not None and path is not None and parts is not None:
            cell.save(path.name, lambda target, meta: result.save(target, extra=meta))
            remove_checkpoints(parts)
        results[(name, placement)] = result
    return results


def pooled(results: dict[tuple[str, str], EvaluationResult], measure: str = "hold",
           rows: list[tuple[str, str]] | None = None,
           keep: Mapping[tuple[str, str], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Success and validity per trial, concatenated over the benchmark's cells.

    Args:
        results: {(object, placement): EvaluationResult}, as `run_benchmark` returns.
        measure: 'hold' or 'force_closure'.
        rows: the cells to pool (default: all of `results`), taken in `cells()` order.
        keep: {cell: (n,) bool over its trials}: only those trials (a subset of the poses, say the covered ones:
            `grid.covered`); default every trial.

    Returns:
        (success, valid): two bool arrays over the pooled trials.
    """
    keys = [key for key in cells() if key in results and (rows is None or key in rows)]
    if not keys:
        raise InvalidInput("results hold none of the cells asked for")
    kept = {key: slice(None) if keep is None else _kept(keep, key, len(results[key].trials)) for key in keys}
    return (np.concatenate([results[key].outcomes(measure)[kept[key]] for key in keys]),
            np.concatenate([results[key].valid[kept[key]] for key in keys]))


def _kept(keep: Mapping[tuple[str, str], np.ndarray], key: tuple[str, str], n: int) -> np.ndarray:
    """A cell's `keep` mask, checked against its trials."""
    mask = np.asarray(keep.get(key, np.zeros(0)), dtype=bool)
    if key not in keep or mask.shape != (n,):
        raise InvalidInput(f"keep must give the cell {key} one bool per trial ({n}), got "
                           f"{'none' if key not in keep else mask.shape}")
    return mask


#: what a paired comparison does with a trial whose physics failed: leave its pose out, or count it as a failure
INVALID_TRIALS = ("drop", "fail")


def compare_pooled(a: dict[tuple[str, str], EvaluationResult], b: dict[tuple[str, str], EvaluationResult],
                   rows: list[tuple[str, str]] | None = None, measure: str = "hold",
                   invalid: str = "drop", keep: Mapping[tuple[str, str], np.ndarray] | None = None
                   ) -> PairedComparison:
    """McNemar's test of method a against method b pooled over the benchmark's cells.

    Args:
        a: the first method's results ({(object, placement): EvaluationResult}, as `run_benchmark` returns).
        b: the second's, on the same poses.
        rows: the cells to pool (default: all of them).
        measure: 'hold' or 'force_closure'.
        invalid: 'drop': pair the poses valid for both (a trial whose physics failed says nothing about its
            controller); 'fail': pair every pose, a failed trial's physics counted as a failed grasp (the
            sensitivity of a comparison to what was dropped).
        keep: {cell: (n,) bool}: only those poses (`pooled`).

    Returns:
        The paired comparison.
    """
    check_choice(invalid, INVALID_TRIALS, "invalid")
    (held_a, valid_a), (held_b, valid_b) = pooled(a, measure, rows, keep), pooled(b, measure, rows, keep)
    if held_a.shape != held_b.shape:
        raise InvalidInput(f"a and b pool {len(held_a)} and {len(held_b)} trials; a paired comparison needs the same "
                           "poses")
    return mcnemar(held_a, held_b, valid=valid_a & valid_b if invalid == "drop" else None)
