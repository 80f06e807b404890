"""Evaluating a grasp controller over a grid of object poses (paper Section 5), with its result type.

`evaluate` runs one trial (`episode.run_trials`) at every pose of a grid (`grid.py`), in parallel
worker processes and resumably (checkpoint parts), and returns an `EvaluationResult`: the trials
with their summary (rates with Wilson intervals), saved to and loaded from .npz. A trial whose
physics failed counts as neither a success nor a failure: summaries report rates over the valid
trials and the number of invalid ones, and paired comparisons skip a pose invalid for either
method.
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from collections.abc import Callable, Mapping
from concurrent.futures import Executor
from dataclasses import asdict, dataclass, field
from typing import TypedDict
from pathlib import Path

import numpy as np

from ..base.checkpoints import TRIAL_PARTS, PartStore
from ..base.errors import InvalidInput
from ..base.io import NpzRecord, Tabular, json_text, library_version, markdown_table
from ..base.progress import progress_bar
from ..base.validation import check_int
from ..base.workers import parallel_map, split_workers, workers_for
from ..judging.judge import JUDGING
from ..manifold.experience import Experience
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS
from ..sim.objects import GraspObject, object_from_params
from .grid import check_grid
from .stats import rate_text, wilson_interval
from .episode import run_trials
from .record import TRIAL_COLUMNS, Trial
from .setup import Noise, TrialSetup

#: what each array of an evaluation file holds (stored in its metadata as "fields"), one row per trial
FIELDS = {**{column.file: column.about for column in TRIAL_COLUMNS.values()},
          "winners": "the best matches of every trial's queries, one trial after the other (matches of each)"}


def _measured_mean(values: list[float]) -> float | None:
    """The mean of the values measured (not NaN); None when none was (NaN with no trial at all)."""
    measured = [v for v in values if not math.isnan(v)]
    return float(np.mean(measured)) if measured else (None if values else float("nan"))


class EvaluationSummary(TypedDict):
    """An evaluation's summary (`EvaluationResult.summary`): names, counts, rates with their 95 % Wilson
    intervals [low, high], and means over the valid trials (`mean_margin` in N, None where not measured)."""

    object: str
    method: str
    grid: str
    trials: int
    invalid_trials: int
    hold_rate: float
    hold_interval: list[float]
    force_closure_rate: float
    force_closure_interval: list[float]
    epsilon_threshold: float
    mean_margin: float | None
    mean_epsilon: float
    mean_time_to_grasp: float
    mean_touching_segments: float
    max_penetration: float


def _number(value: float | None, digits: int) -> str:
    """A table cell: the value to `digits` decimals, or an em dash when it was not measured (None)."""
    return "—" if value is None else f"{value:.{digits}f}"


class _Valid(np.ndarray):
    """`EvaluationResult.valid`: a bool array that, called as the old method was, warns and gives itself."""

    def __new__(cls, mask: np.ndarray) -> _Valid:
        return np.asarray(mask, dtype=bool).view(cls)

    def __call__(self) -> np.ndarray:
        warnings.warn("EvaluationResult.valid is a property now, as Trial.valid is: write result.valid, not "
                      "result.valid()", DeprecationWarning, stacklevel=2)
        return np.asarray(self)


@dataclass
class EvaluationResult(Tabular, NpzRecord):
    """Trials of one controller (method) on one object, with their summary.

    Attributes:
        object: the object (a `GraspObject`; read from a file, `objects.object_from_params` makes it again).
        method: the controller's experience ('none', 'database', 'som', or a study's label).
        grid_name: the grid preset's name, or 'custom'.
        seed: the trials' seed.
        trials: one `Trial` per grid pose, in grid order.
        noise: the trial noise.
        backend: the physics engine the trials ran on (`setup.BACKENDS`).
        made_by: what made the trials (`TrialSetup.provenance`: object and mesh digest, hand, protocol, touch,
            controller and its parameters, experience kind and digest, seed, library version); {} for a result
            written before it was recorded.
    """

    object: GraspObject
    method: str
    grid_name: str
    seed: int
    trials: list[Trial]
    noise: Noise = field(default_factory=Noise)
    backend: str = "cpu"  # the physics engine the trials ran on (setup.BACKENDS)
    made_by: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if isinstance(self.object, dict):  # parameters, as a file stores them
            self.object = object_from_params(self.object)

    def __repr__(self) -> str:
        s = self.summary
        return (f"EvaluationResult({s['object']} / {self.method} on the {self.grid_name} grid: "
                f"{trial_count(s)} trials, hold {s['hold_rate']:.0%}, force closure {s['force_closure_rate']:.0%})")

    def _repr_markdown_(self) -> str:
        return self.markdown()

    @property
    def summary(self) -> EvaluationSummary:
        """Rates (with 95 % Wilson intervals) and means over the valid trials (`mean_margin` None where the
        margin was not measured); `trials` counts them, `invalid_trials` the trials whose physics failed (see the
        module doc)."""
        valid = [t for t in self.trials if t.valid]
        n, holds, closures = len(valid), sum(t.hold for t in valid), sum(t.force_closure for t in valid)

        def mean(values: list[float]) -> float:
            return float(np.mean(values)) if values else float("nan")

        return {
            "object": self.object.name, "method": self.method, "grid": self.grid_name, "trials": n,
            "invalid_trials": len(self.trials) - n,
            "hold_rate": holds / n if n else float("nan"), "hold_interval": list(wilson_interval(int(holds), n)),
            "force_closure_rate": closures / n if n else float("nan"),
            "force_closure_interval": list(wilson_interval(int(closures), n)),
            "epsilon_threshold": JUDGING.epsilon_threshold,
            "mean_margin": _measured_mean([t.margin for t in valid]),  # None: not measured
            "mean_epsilon": mean([t.epsilon for t in valid]),
            "mean_time_to_grasp": mean([t.time_to_grasp for t in valid]),
            "mean_touching_segments": mean([t.touching.sum() for t in valid]),
            "max_penetration": max([t.penetration for t in valid], default=0.0),
        }

    @property
    def valid(self) -> np.ndarray:
        """Which trials' physics worked (bool, grid order): a property, as `Trial.valid` is. The old spelling
        `result.valid()` still works and warns (a deprecation path: it goes in a later version)."""
        return _Valid(np.array([t.valid for t in self.trials], dtype=bool))

    def rows(self) -> list[dict]:
        """One row per trial, for a table: the object, the method, the grid pose (m, rad) and every outcome.

        Returns:
            A list of dicts with the same keys (`to_csv`, `to_frame`).
        """
        return [{"object": self.object.name, "method": self.method, "grid": self.grid_name, "seed": self.seed,
                 "x": float(t.grid_pose[0]), "z": float(t.grid_pose[1]), "gap": float(t.grid_pose[2]),
                 "yaw": float(t.grid_pose[3]), "valid": t.valid, "hold": bool(t.hold),
                 "force_closure": t.force_closure, "epsilon": float(t.epsilon),
                 "hold_displacement": float(t.hold_displacement), "time_to_grasp": float(t.time_to_grasp),
                 "matches": int(t.matches), "margin": float(t.margin), "penetration": float(t.penetration),
                 "attempts": int(t.attempts), "touching": " ".join(s for s, on in zip(SEGMENTS, t.touching) if on),
                 "fault": t.fault} for t in self.trials]

    def outcomes(self, measure: str = "hold") -> np.ndarray:
        """Success per trial; an invalid trial reads False here, so pair it with `valid` (or use `rate`).

        Args:
            measure: 'hold' or 'force_closure'.

        Returns:
            (n,) bool in grid order.
        """
        if measure not in ("hold", "force_closure"):
            raise InvalidInput(f"measure must be 'hold' or 'force_closure', got {measure!r}")
        return np.array([t.valid and bool(getattr(t, measure)) for t in self.trials], dtype=bool)

    def rate(self, measure: str = "hold", rows: np.ndarray | None = None) -> float:
        """The success rate over the valid trials.

        Args:
            measure: 'hold' or 'force_closure'.
            rows: a bool mask in grid order to count only some trials.

        Returns:
            The rate, 0 ... 1 (NaN without a valid trial).
        """
        keep = self.valid if rows is None else self.valid & np.asarray(rows, dtype=bool)
        return float(self.outcomes(measure)[keep].mean()) if keep.any() else float("nan")

    def successful_postures(self, require_hold: bool = True) -> np.ndarray:
        """Final postures of the successful trials: the grasps that may join the experience.

        Args:
            require_hold: count the trials that held (False: that reached force closure).

        Returns:
            Postures (m, 22), rad.
        """
        keep = [t.posture for t in self.trials if t.valid and (t.hold if require_hold else t.force_closure)]
        return np.array(keep).reshape(-1, N_FINGER_JOINTS)

    def markdown(self) -> str:
        """The summary as a one-row Markdown table: trials, hold and force-closure rates with their 95 %
        Wilson intervals, mean margin (N), mean epsilon, mean time to grasp (s).

        Returns:
            The table's header, separator and row, each ending in a newline.
        """
        s = self.summary
        n = s["trials"]
        return "\n".join(markdown_table(
            ["object", "method", "trials", "hold [95 % CI]", "force closure [95 % CI]", "mean margin (N)", "mean ε",
             "mean time to grasp (s)"],
            [[s["object"], s["method"], trial_count(s), rate_text(round(s["hold_rate"] * n), n),
              rate_text(round(s["force_closure_rate"] * n), n), _number(s["mean_margin"], 2), f"{s['mean_epsilon']:.4f}",
              f"{s['mean_time_to_grasp']:.2f}"]])) + "\n"

    NPZ_KIND = "evaluation"
    NPZ_REQUIRED = {"grid": (None, 4), "postures": (None, N_FINGER_JOINTS), "epsilon": (None,), "margin": (None,),
                    "penetration": (None,), "fault": (None,)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        """The trials, their winners and the summary."""
        t = self.trials
        arrays = {column.file: column.array([getattr(x, name) for x in t]) for name, column in TRIAL_COLUMNS.items()}
        if all(x.winners is not None for x in t):  # every trial's `matches` winners, one after the other
            arrays["winners"] = np.concatenate([np.zeros(0, dtype=int), *(x.winners for x in t)]).astype(int)
        meta = {"object": self.object.params(), "method": self.method, "grid_name": self.grid_name, "seed": self.seed,
                "noise": asdict(self.noise), "backend": self.backend, "summary": self.summary, "segments": list(SEGMENTS),
                "units": "m, rad, s, N; epsilon per unit total normal force", "fields": FIELDS,
                "made_by": self.made_by}
        return arrays, meta

    @classmethod
    def _from_npz(cls, a: dict[str, np.ndarray], meta: dict, path: Path) -> EvaluationResult:
        """The result of a file, trials and per-cycle winners included."""
        winners: list[np.ndarray] | list[None] = [None] * len(a["epsilon"])
        if "winners" in a:
            ends = np.cumsum(np.asarray(a["matches"], dtype=int))
            if len(ends) and (ends[-1] != len(a["winners"]) or (np.diff(ends, prepend=0) < 0).any()):
                raise InvalidInput(f"{path}: its {len(a['winners'])} best-match winners do not add up to its trials' "
                                 f"{int(ends[-1])} matches; the file is corrupt")
            winners = np.split(np.asarray(a["winners"], dtype=int), ends[:-1]) if len(ends) else []
        n = len(a["epsilon"])
        absent = [column.file for column in TRIAL_COLUMNS.values() if column.older is None and column.file not in a]
        if absent:
            raise InvalidInput(f"{path}: it lacks the trials' {absent}; the file is corrupt")
        for column in TRIAL_COLUMNS.values():
            if column.file in a and np.asarray(a[column.file]).dtype.kind not in column.dtype_kinds:
                raise InvalidInput(f"{path}: {column.file} must hold {column.kind} values, got "
                                   f"{np.asarray(a[column.file]).dtype}; the file is corrupt")
            if column.width and column.file in a and np.shape(a[column.file]) != (n, column.width):
                raise InvalidInput(f"{path}: {column.file} must be ({n}, {column.width}), got "
                                   f"{np.shape(a[column.file])}; the file is corrupt")
        trials = [Trial(**{name: column.value(a[column.file], i) if column.file in a else column.missing()
                           for name, column in TRIAL_COLUMNS.items()}, winners=winners[i]) for i in range(n)]
        return cls(meta["object"], meta["method"], meta["grid_name"], meta["seed"], trials, Noise(**meta["noise"]),
                   meta.get("backend", "cpu"), meta.get("made_by", {}))


def trial_count(summary: Mapping[str, object]) -> str:
    """The valid trials of a summary, and the invalid ones when there are any ("225 (+2 invalid)")."""
    invalid = summary.get("invalid_trials", 0)
    return f"{summary['trials']}" + (f" (+{invalid} invalid)" if invalid else "")


#: trials per checkpoint part of an evaluation at most (the unit of parallel work and of resuming)
CHECKPOINT_TRIALS = 16


def _run_chunk(task: tuple[list[int], np.ndarray, int], setup: TrialSetup) -> list[Trial]:
    """The trials of one chunk of grid poses, as one batch; trial i draws from the generator seeded [seed, i]."""
    indices, poses, seed = task
    return run_trials(setup, poses, [np.random.default_rng([seed, index]) for index in indices])


def _read_part(path: Path) -> tuple[tuple[int, list[Trial]], dict]:
    """A stored chunk of trials, with the index of its first trial."""
    part, meta = EvaluationResult.load_with_metadata(path)
    return (int(meta.get("first", -1)), part.trials), meta


def evaluate(obj: str | GraspObject | TrialSetup, experience: Experience | None = None,
             grid: str | np.ndarray = "quick", seed: int = 0, workers: int | Executor | None = None, *,
             checkpoint_dir: str | os.PathLike | None = None, progress: bool | None = None,
             **fields: object) -> EvaluationResult:
    """Run the controller with this experience on every grid pose, and judge each grasp.

    The object is held by a spring support with gravity off while the hand closes (or stands on a table
    with gravity on), then released and judged by the set-up's protocol (ours: the hold test, epsilon at the
    object's friction, and the disturbance margin where `margin` asks for it). What a trial is, is one
    `TrialSetup`: give it whole (`evaluate(setup, grid=...)`), or its fields by name beside the object and the
    experience (`evaluate("box", som, noise=..., protocol="dexgraspbench")`). With `checkpoint_dir`, every
    CHECKPOINT_TRIALS finished trials are saved there and a rerun with the same arguments (and the same library
    code) picks them up; parts of another configuration are discarded with a warning. The same seed gives the
    same trials, whatever the number of workers, the executor or interruptions (on one backend).

    Args:
        obj: the object, or its name; or a whole `TrialSetup`.
        experience: None (the plain tactile controller), a PostureDatabase, a SOM or a PostureSet.
        grid: a preset name (`GRID_PRESETS`), or poses (n, 4) or one pose (4,): x, z, gap in m, yaw in rad.
        seed: trial i draws its noise from the generator seeded [seed, i].
        workers: worker processes (None: `workers.default_workers()`, at most two, but this process alone
            for up to CHECKPOINT_TRIALS poses, which do not pay for a pool's start), or an executor that runs
            the trials elsewhere, e.g. on a Dask cluster (`workers.cluster_executor`).
        checkpoint_dir: where finished trials are kept until the end.
        progress: show a progress bar (None: as `progress.show_progress` says, on by default).
        **fields: the `TrialSetup` fields by name: noise (`Noise`), params (`ControllerParams`), table (the object
            on a table with gravity on; poses where the open hand would touch it are left out of presets and
            refused in a custom grid), preshape ((22,) rad), backend ('cpu': each chunk of trials one batch in
            worker processes; 'warp': `batch_size` trials at once on the GPU with MuJoCo Warp, the `gpu` extra),
            method (the result's label; empty: 'none', 'database' or 'som'), hand (a model, its name or an MJCF
            path), controller (a user's own factory `controller(n, hand)`, with a method label), margin (N of
            disturbance a held grasp resists, up to 1.8 s more simulation each; False: NaN), regrasp
            (`regrasp.Regrasp`), protocol (a name in `protocols.PROTOCOLS` or a `JudgingProtocol`; a result's `hold` is
            its success), batch_size.

    Returns:
        The result: one `Trial` per pose, in grid order, and its summary.

    Raises:
        ValueError: an unknown object, grid or set-up field, a pose no trial can start from
            (`why_unreachable`), a bad argument.
    """
    setup = TrialSetup.build(obj, experience, **fields)
    workers, executor = split_workers(workers)
    the_object, noise = setup.object, setup.noise
    seed = check_int(seed, "seed", low=0)
    batch_size, backend = setup.batch_size, setup.backend
    grid_name, poses = check_grid(grid, the_object, setup.table, setup.plan)
    workers = workers_for(workers, len(poses), CHECKPOINT_TRIALS)
    size = max(1, min(CHECKPOINT_TRIALS, -(-len(poses) // (8 * workers))))  # at least 8 chunks per worker
    chunks = [list(range(first, min(first + size, len(poses)))) for first in range(0, len(poses), size)]
    store = PartStore(checkpoint_dir, setup.key(poses, seed), _read_part) if checkpoint_dir is not None else None
    done = _saved_chunks(store, chunks) if store is not None else {}
    method = setup.method
    pending = [k for k in range(len(chunks)) if k not in done]
    tasks = [(chunks[k], poses[chunks[k]], seed) for k in pending]
    report = progress_bar(len(poses), f"evaluate {the_object.name} / {method}", "trials", enabled=progress)

    def keep(task: int, trials: list[Trial]) -> None:
        number = pending[task]
        done[number] = trials
        if store is not None:
            part = EvaluationResult(the_object, method, grid_name, seed, trials, noise, backend)
            store.save(f"part_{chunks[number][0]:05d}.npz", lambda path, meta: part.save(path, extra=meta),
                       first=chunks[number][0])
        report.update(len(trials))

    with report:
        report.update(sum(len(t) for t in done.values()))
        if backend == "cpu":
            parallel_map(functools.partial(_run_chunk, setup=setup), tasks, workers, keep, executor)
        else:
            _run_on_gpu(setup, tasks, max(1, batch_size // size), keep)
    trials = [trial for k in range(len(chunks)) for trial in done[k]]
    return EvaluationResult(the_object, method, grid_name, seed, trials, noise, backend, setup.provenance(seed))


def _saved_chunks(store: PartStore, chunks: list[list[int]]) -> dict[int, list[Trial]]:
    """The chunks a checkpoint holds, by their number; a part must be one chunk of the chunks planned now, whole."""
    firsts = {chunk[0]: k for k, chunk in enumerate(chunks)}
    fits = lambda _, part, __: part[0] in firsts and len(part[1]) == len(chunks[firsts[part[0]]])  # noqa: E731
    return {firsts[first]: trials for first, trials in store.load(TRIAL_PARTS, fits).values()}


def _run_on_gpu(setup: TrialSetup, tasks: list[tuple], per_batch: int, keep: Callable[[int, list[Trial]], None]
                ) -> None:
    """One GPU batch of `per_batch` chunks at a time, split back into chunks for the checkpoint (`keep`)."""
    for first in range(0, len(tasks), per_batch):
        group = tasks[first: first + per_batch]
        seed = group[0][2]
        trials = _run_chunk(([i for t in group for i in t[0]], np.concatenate([t[1] for t in group]), seed), setup)
        for k, task in enumerate(group):
            keep(first + k, trials[:len(task[0])])
            trials = trials[len(task[0]):]


def summary_json(results: list[EvaluationResult]) -> str:
    """The results' summaries as JSON (`evaluate`'s summary.json), each with what made it (`made_by`).

    Args:
        results: the results.

    Returns:
        The JSON text.
    """
    return json_text({"library_version": library_version(),
                      "results": [{**r.summary, "made_by": r.made_by} for r in results]}, indent=2)

