"""Spring-based grasp posture generation (paper Section 5): postures in thousands, in waves of parallel jobs.

The spring rig and its walk around one starting posture are `springs` (the object held fixed, each contact segment
pulled to the object by a spring while the finger servos hold the starting posture only softly; a random walk of the
palm, each step settled and tested); the starting postures, shipped or searched once and kept, are `start_cache`.
Because the walk stays near its starting posture, the data clusters around the starting postures, as the paper's
did.

The starting postures come from a family of designs (`GeneratorParams.designs`, `starts.DESIGN_FAMILIES`):
by default every grasp type (power wraps, pinch, tripod, lateral), each start one that holds when
verified, where only the design's own contact segments are pulled by springs (a fingertip by its tip,
another segment at its point nearest the object) and must touch, while the fingers that take no part
stay curled; or the paper's five-fingertip grasps (the presets of `reproduce`, the paper's procedure).

Our extension of the paper's procedure verifies every candidate as a grasp
(`GeneratorParams.verify`, on by default) by the one open-loop replay of the library
(`replay.replay_grasp`, the replay DexGraspBench's protocol judges grasps by): from a pregrasp (the open
hand 2 cm back, or the fingers backed off along the contacts' normals: `GeneratorParams.stages`) the hand moves
to the candidate and its squeeze on the free, unsupported object, and the protocol named by
`GeneratorParams.verify_protocol` judges it (ours: six gravity directions of `verify_hold_seconds` each;
DexGraspBench's: its physics and external-force test); only candidates that hold are kept, with their epsilon (at the object's friction) and largest
displacement recorded in the set. `generate_postures(obj, n)` returns n postures either way: with
verification it draws candidates in waves until n hold, at most `max_candidates_per_posture` times
n of them, and names the yield when that is not enough (`GenerationError`).

Work is cut into jobs (a starting posture and a chunk of candidates) with their own random streams,
so the set depends on the seed alone (not on the number of workers), jobs run in parallel
processes, and a run with a checkpoint directory resumes after an interruption without redoing
finished jobs.
"""

from __future__ import annotations

import itertools
import os
import warnings
from collections.abc import Iterator, Sequence
from concurrent.futures import Executor
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..base.checkpoints import JOB_PARTS, PartStore, result_key
from ..base.errors import GenerationError, InvalidInput, SimulationError
from ..base.io import library_version, load_npz, save_npz
from ..base.moved import moved_attribute, moved_keyword
from ..base.paper_numbers import DATASET_SIZES
from ..base.progress import progress_bar
from ..base.validation import check_int
from ..base.workers import parallel_map, split_workers, workers_for
from ..manifold.postureset import PostureSet
from ..sim.hand import FINGER_JOINTS, HandModel
from ..sim.hand_models import hand_model
from ..sim.objects import GraspObject, get_object
from .starts import StartingPosture, check_starting_postures, designs_for
from .springs import GeneratorParams, WalkJob, verifier_of, walk
from .start_cache import starting_postures

DATASET_PRESETS: dict[str, dict[str, int]] = {
    "paper": dict(DATASET_SIZES),
    "quick": {"box": 240, "cylinder": 240, "sphere": 160},
}
"""Postures per object: the paper's dataset sizes (Section 5), and a small set for tests and demos."""


#: postures that pay for a worker process when `workers` is not given (a pool's start costs about a second)
GENERATE_PER_WORKER = 50
VERIFY_PER_WORKER = 20
#: the most postures one call makes (the paper's sets are a few thousand; a million take a day on two cores)
MAX_POSTURES = 1_000_000
#: `verify_postures` warns when fewer than this share of the candidates hold
FEW_HOLD = 0.1



def _size_text(obj: GraspObject, hand: HandModel) -> str:
    """The object's size against the hand's, in words."""
    return (f"it is {100 * obj.narrowest_width:.1f} cm across at its narrowest and {200 * obj.half_extents.max():.1f} "
            f"cm at its longest; the {hand.name!r} hand spans {100 * hand.span:.1f} cm (thumb tip to the farthest "
            "fingertip, open)")


def _check_graspable(obj: GraspObject, hand: HandModel) -> None:
    """Refuse an object wider at its narrowest than the hand's span before any search: no design can close
    around it."""
    if obj.narrowest_width > hand.span:
        raise GenerationError(f"{obj.name} cannot be grasped by this hand: {_size_text(obj, hand)}, so no grasp "
                              "can close around it (use an object that is narrower somewhere than the hand spans)")



def _allocate(n: int, capacity: list[int | None], order: list[int] | None = None) -> list[int]:
    """Split n postures over the starting postures as evenly as their capacity allows: a start with a
    capacity (it can give no more than that) gets at most that, the others share the rest evenly, one more
    each where it does not divide, taken in `order` (None: the starts' order)."""
    allocation = [0] * len(capacity)
    open_starts, remaining = list(range(len(capacity))), n
    while open_starts:
        fair = remaining / len(open_starts)
        limited = {s: most for s in open_starts if (most := capacity[s]) is not None and most <= fair}
        if not limited:
            break
        for s, most in limited.items():
            allocation[s] = int(most)
            remaining -= allocation[s]
            open_starts.remove(s)
    if open_starts:
        share, extra = divmod(remaining, len(open_starts))
        ranked = sorted(open_starts, key=(order or list(range(len(capacity)))).index)
        for k, s in enumerate(ranked):
            allocation[s] = share + (1 if k < extra else 0)
    return allocation


def _round_robin(kinds: Sequence[str]) -> list[int]:
    """Indices in the order that takes one of each kind in turn (first-seen kind first): the first of each kind,
    then the second of each, ..."""
    rank = {kind: k for k, kind in enumerate(dict.fromkeys(kinds))}
    seen: dict[str, int] = {}
    place = []
    for i, kind in enumerate(kinds):
        seen[kind] = seen.get(kind, -1) + 1
        place.append((seen[kind], rank[kind], i))
    return [i for *_, i in sorted(place)]


def _chunks(start: int, first_chunk: int, candidates: int, job_size: int) -> Iterator[WalkJob]:
    """Jobs of at most `job_size` candidates for one start, numbered on from `first_chunk` (made as they
    are taken: a wave of a billion candidates is not held in memory)."""
    return (WalkJob(start, first_chunk + k, min(job_size, candidates - done))
            for k, done in enumerate(range(0, candidates, job_size)))


def _job_file(directory: Path, job: WalkJob) -> Path:
    return directory / f"job_{job.start_index:03d}_{job.chunk:04d}.npz"


def _job_worker(args: tuple) -> tuple[WalkJob, dict[str, np.ndarray]]:
    obj, start, job, seed, params, hand = args
    return job, walk(obj, start, job, seed, params, hand)


def _read_job(path: Path) -> tuple[tuple[WalkJob | None, dict[str, np.ndarray]], dict]:
    """A stored job's result, with the job it says it is (None when its metadata names none)."""
    arrays, meta = load_npz(path, "generator_job", {"postures": (None, len(FINGER_JOINTS))})
    job = meta.get("job")
    return (WalkJob(**job) if isinstance(job, dict) and set(job) == set(WalkJob.__dataclass_fields__) else None, arrays), meta


def _hand_into_params(kwargs: dict[str, Any], hand: object) -> None:
    """`generate_postures(hand=...)` of 0.1: the hand is `GeneratorParams.hand` now."""
    params = kwargs.get("params") or GeneratorParams()
    if params.hand not in (GeneratorParams().hand, hand):
        raise InvalidInput(f"hand={hand!r} (the 0.1 keyword) and params.hand={params.hand!r} disagree: give the hand "
                           "once, as GeneratorParams(hand=...)")
    kwargs["params"] = replace(params, hand=hand)


@moved_keyword("hand", "params=GeneratorParams(hand=...)", _hand_into_params)
def generate_postures(obj: str | GraspObject, n: int, seed: int = 0, workers: int | Executor | None = None, *,
                      params: GeneratorParams | None = None, checkpoint_dir: str | os.PathLike | None = None,
                      progress: bool | None = None, starts: Sequence[StartingPosture] | None = None) -> PostureSet:
    """Generate n grasp postures for an object with the spring generator.

    Without verification (`params.verify=False`, the paper's procedure) the n postures are the first
    n candidates. With it (the default) candidates are drawn in waves until n of them hold the
    object: each wave asks every starting posture that is short of its share for as many candidates
    as its yield so far says it needs; a start that used up its part of the budget
    (`max_candidates_per_posture` times n over the starts) or whose springs rarely make its contacts
    gives up, as does one none of whose first `max_candidates_per_posture` candidates held, and the
    others share its part. The shares are as even as the starts allow.

    Args:
        obj: an object or its name.
        n: postures to return (>= 1).
        seed: the random seed; the same seed gives the same set, whatever the number of workers or
            the executor the jobs run on.
        workers: worker processes (None: `workers.default_workers()`, one for fewer than
            `GENERATE_PER_WORKER` postures), or an executor that runs the jobs elsewhere (a Dask cluster's,
            `workers.cluster_executor`).
        params: generator settings (`GeneratorParams`); `params.designs` picks the starting postures, `params.hand`
            the hand model (`hand_models.HAND_MODELS`, or an MJCF path; the postures record it, `metadata["hand"]`).
        checkpoint_dir: every finished job is saved there, and a rerun with the same arguments picks
            them up.
        progress: show a progress bar of the postures found (None: as `progress.show_progress` says, on by
            default).
        starts: your own starting postures (`StartingPosture`s, palm poses in the object's frame; checked by
            `starts.check_starting_postures`), used instead of those of `params.designs`.

    Returns:
        A `PostureSet` of n postures; its metadata says how many candidates were drawn and how many
        held (`candidates`, `verified_ratio`, and per starting posture `candidates_by_start`,
        `verified_by_start`, `kept_by_start`).

    Raises:
        GenerationError: the object is wider at its narrowest than the hand spans (`HandModel.span`), no
            starting posture was found (the message gives the object's size against the hand's and the designs
            tried), or with verification fewer than n candidates held within the budget (the message gives the
            yield per starting posture).
        InvalidInput: a start of `starts` that is not a valid grasp of the object (the message names it).
    """
    seed = check_int(seed, "seed", low=0)
    obj = get_object(obj)
    n = check_int(n, "n", high=MAX_POSTURES)
    workers, executor = split_workers(workers)
    workers = workers_for(workers, n, GENERATE_PER_WORKER)
    params = params or GeneratorParams()
    model = hand_model(params.hand)  # the hand refused here when unknown
    _check_graspable(obj, model)
    own = starts is not None
    starts = _starts_on(obj, params, model, starts)
    key = result_key({"object": obj.params(), "seed": seed, "n": int(n), "params": asdict(params),
                      "starts": [s.name for s in starts], "hand": model.digest},
                     *([np.concatenate([s.hand_pos, s.hand_quat, s.posture]) for s in starts] if own else []))
    waves = _Waves(obj, starts, n, seed, params, model.name)
    with progress_bar(n, f"generate {obj.name}", "postures", enabled=progress) as report:
        waves.run(PartStore(checkpoint_dir, key, _read_job) if checkpoint_dir is not None else None, workers,
                  executor, report)
    return waves.posture_set()


def _starts_on(obj: GraspObject, params: GeneratorParams, model: HandModel,
               starts: Sequence[StartingPosture] | None) -> list[StartingPosture]:
    """One's own starts checked, or those of `params.designs` found; either in the hand's ranges."""
    family = params.designs
    assert family is not None  # GeneratorParams names the default family
    starts = check_starting_postures(starts, obj) if starts is not None else starting_postures(obj, family)
    if not starts:
        tried = ", ".join(design.name for design in designs_for(obj, family))
        raise GenerationError(f"no starting posture could be found for {obj.name}: {_size_text(obj, model)}; none of "
                              f"the {params.designs!r} designs ({tried}) "
                              "closes the hand on it with its contacts touching (an object too small for the "
                              "fingertips to meet on it, or of a shape none of them fits)")
    # the designs' postures (searched on our hand) in this hand's ranges
    return [replace(s, posture=np.clip(s.posture, *model.limits().T)) for s in starts]


class _Waves:
    """The generator's scheduler: waves of jobs over the starting postures until n candidates held (or the budget
    is spent), then the posture set built from what the jobs found (`posture_set`).

    Each wave asks every start short of its share (`_allocate`) for as many candidates as its yield so far says it
    needs; a start past its part of the budget, or none of whose first `max_candidates_per_posture` candidates
    held, gives up, and the others share its part.
    """

    def __init__(self, obj: GraspObject, starts: list[StartingPosture], n: int, seed: int, params: GeneratorParams,
                 hand: str):
        self.obj, self.starts, self.n, self.seed, self.params, self.hand = obj, starts, n, seed, params, hand
        self.results: list[list[dict[str, np.ndarray]]] = [[] for _ in starts]  # per start, in chunk order
        self.given_up = [False] * len(starts)
        self.budget = params.max_candidates_per_posture * n if params.verify else None
        self.spread = _round_robin([s.grasp_type for s in starts])  # fewer postures than starts: every type first

    def held(self, s: int) -> int:
        return sum(len(r["postures"]) for r in self.results[s])

    def drawn(self, s: int) -> int:
        return sum(int(r["candidates"]) for r in self.results[s])

    def allocation(self) -> list[int]:
        return _allocate(self.n, [self.held(s) if self.given_up[s] else None for s in range(len(self.starts))],
                         self.spread)

    def plan(self) -> list[tuple[int, int, int]] | None:
        """The next wave: (start, its first chunk in this wave, candidates to draw); [] when some start gave up
        now (the shares change), None when nothing is left to draw."""
        allocation = self.allocation()
        short = [s for s in range(len(self.starts)) if not self.given_up[s] and self.held(s) < allocation[s]]
        if not short:
            return None
        params, budget = self.params, self.budget
        for s in short:  # a start past its part of the budget gives up, and one none of whose first
            # max_candidates_per_posture candidates held (by the rule of three its yield is then below
            # 3 / max_candidates_per_posture, 6 % by default, with 95 % confidence)
            if budget is not None and (self.drawn(s) >= budget / len(self.starts)
                                       or (self.held(s) == 0 and self.drawn(s) >= params.max_candidates_per_posture)):
                self.given_up[s] = True
        if any(self.given_up[s] for s in short):
            return None if all(self.given_up) else []
        plan = []
        for s in short:
            wanted = allocation[s] - self.held(s)
            if params.verify and budget is not None and self.results[s]:  # as many as the yield so far says,
                # and a tenth more, but at most as many again as drawn so far (a start whose first few candidates
                # all dropped is not sent for tenfold that many at once)
                rate = (self.held(s) + 1) / (self.drawn(s) + 2)
                wanted = min(int(np.ceil(1.1 * wanted / rate)), max(wanted, self.drawn(s)),
                             int(budget / len(self.starts)) - self.drawn(s))
            plan.append((s, len(self.results[s]), max(1, wanted)))
        return plan

    def run(self, store: PartStore | None, workers: int, executor: Executor | None, report: Any) -> None:
        """Every wave, its jobs on `workers` processes or `executor`, each finished job kept in `store` (a rerun
        takes it from there; a job's file must be where its name says: a renamed file is not taken for another)."""
        saved: dict[tuple[int, int], dict[str, np.ndarray]] = {}
        if store is not None:
            stored = store.load(JOB_PARTS, lambda path, part, _: part[0] is not None
                                and path == _job_file(store.directory, part[0])).values()
            saved = {(job.start_index, job.chunk): arrays for job, arrays in stored}
        while (plan := self.plan()) is not None:
            if plan:
                self.run_wave(plan, saved, store, workers, executor, report)

    def run_wave(self, plan: list[tuple[int, int, int]], saved: dict, store: PartStore | None, workers: int,
                 executor: Executor | None, report: Any) -> None:
        """One wave's jobs (those saved by an earlier run taken as they are), their results kept per start."""
        job_size = self.params.job_size

        def jobs() -> Iterator[WalkJob]:
            return itertools.chain.from_iterable(_chunks(*step, job_size) for step in plan)

        pending = ((self.obj, self.starts[job.start_index], job, self.seed, self.params, self.hand)
                   for job in jobs() if (job.start_index, job.chunk) not in saved)
        finished = {key: result for key, result in saved.items() if any(
            key[0] == s and first <= key[1] < first + -(-wanted // job_size) for s, first, wanted in plan)}

        def keep(_: int, done: tuple[WalkJob, dict[str, np.ndarray]]) -> None:
            job, result = done
            finished[(job.start_index, job.chunk)] = result
            if store is not None:  # written here, where a rerun reads it, not on a cluster worker's disk
                store.save(_job_file(store.directory, job).name,
                           lambda path, meta: save_npz(path, "generator_job", result, meta), job=asdict(job))
            report.update(min(len(result["postures"]), self.n - report.n))  # a job may find more than is kept

        report.update(min(sum(len(r["postures"]) for r in finished.values()), self.n - report.n))
        parallel_map(_job_worker, pending, workers, keep, executor)
        for job in jobs():
            result = finished[(job.start_index, job.chunk)]
            self.results[job.start_index].append(result)
            if bool(result.get("exhausted", False)):
                self.given_up[job.start_index] = True

    def posture_set(self) -> PostureSet:
        """The first `kept` postures of each start, start after start, with what made them; GenerationError when
        fewer than n held (the message says why: the simulation's faults, or the yield per start)."""
        obj, starts, n, params = self.obj, self.starts, self.n, self.params
        allocation, indices = self.allocation(), range(len(starts))
        kept = [min(self.held(s), allocation[s]) for s in indices]
        candidates = sum(self.drawn(s) for s in indices)
        held = sum(self.held(s) for s in indices)
        self.check_enough(sum(kept), candidates, held)
        present = [s for s in indices if self.results[s]]

        def take(key: str) -> np.ndarray:
            """Each start's first `kept` rows of a result array, start after start."""
            return np.concatenate([np.concatenate([r[key] for r in self.results[s]])[: kept[s]] for s in present])

        tries = sum(int(r["tries"]) for rs in self.results for r in rs)
        faults = sum(int(r.get("faults", 0)) for rs in self.results for r in rs)
        return PostureSet(
            postures=take("postures"), hand_poses=take("hand_poses"),
            start_ids=np.concatenate([np.full(kept[s], s) for s in present]).astype(np.int64),
            contacts=take("contacts").astype(bool), epsilon=take("epsilon"),
            hold_displacement=take("hold_displacement"), start_names=tuple(f"{obj.name}:{s.name}" for s in starts),
            metadata={"object": obj.params(), "seed": self.seed, "generator": asdict(params), "n": int(n),
                      "acceptance_ratio": candidates / tries, "simulation_faults": faults, "verified": params.verify,
                      "candidates": int(candidates), "verified_ratio": held / candidates,
                      "verified_by_start": {starts[s].name: self.held(s) / self.drawn(s) for s in present
                                            if self.drawn(s)},
                      "candidates_by_start": {starts[s].name: self.drawn(s) for s in present},
                      "kept_by_start": {starts[s].name: kept[s] for s in present},
                      "grasp_types": {start.name: start.grasp_type for start in starts},
                      "library_version": library_version(), "hand": self.hand,
                      "starting_postures": {s.name: {"hand_pos": s.hand_pos.tolist(),
                                                     "hand_quat": s.hand_quat.tolist(), "posture": s.posture.tolist(),
                                                     "contacts": list(s.contacts), "grasp_type": s.grasp_type}
                                            for s in starts}},
        )

    def check_enough(self, kept: int, candidates: int, held: int) -> None:
        """GenerationError when fewer than n postures were kept."""
        if kept >= self.n:
            return
        obj, params, n = self.obj, self.params, self.n
        tries = sum(int(r["tries"]) for rs in self.results for r in rs)
        faults = sum(int(r.get("faults", 0)) for rs in self.results for r in rs)
        if faults:
            first = next(str(r["first_fault"]) for rs in self.results for r in rs if str(r.get("first_fault", "")))
            raise GenerationError(
                f"only {kept} of the {n} {obj.name} postures asked for were found, and the simulation failed "
                f"{faults} times in {tries} walk steps (first: {first}): check GeneratorParams (spring_stiffness "
                f"{params.spring_stiffness:g} N/m, spring_max_force {params.spring_max_force:g} N, "
                f"servo_stiffness_scale {params.servo_stiffness_scale:g}) and the object's mass and size")
        by_start = ", ".join(f"{start.name} {self.held(s)} of {self.drawn(s)}" + (" (gave up)" if self.given_up[s]
                                                                                   else "")
                             for s, start in enumerate(self.starts))
        raise GenerationError(
            f"only {kept} of the {n} {obj.name} postures asked for were found: of {candidates} candidates "
            f"{held} held (yield {held / max(1, candidates):.1%}; by starting posture: {by_start}). Ask for fewer "
            "postures, raise GeneratorParams.max_candidates_per_posture"
            + (", or keep every candidate (verify=False)" if params.verify else ", or max_tries_per_posture"))


def _verify_chunk(task: tuple[GraspObject, GeneratorParams, np.ndarray, np.ndarray, str]) -> np.ndarray:
    """(hold, epsilon, displacement) rows of the verifier for a chunk of postures (m, 22) and palm poses (m, 7) on
    a hand."""
    obj, params, postures, poses, hand = task
    verifier = verifier_of(obj, params, hand)
    rows = []
    for posture, pose in zip(postures, poses):
        try:
            judgement = verifier(posture, pose[:3], pose[3:])
            rows.append((float(judgement.hold), judgement.epsilon, judgement.displacement))
        except SimulationError:  # the replay's physics failed: not a verified grasp
            rows.append((0.0, np.nan, np.nan))
    return np.array(rows).reshape(-1, 3)


def verify_postures(postures: PostureSet, obj: str | GraspObject, workers: int | Executor | None = None, *,
                    params: GeneratorParams | None = None, progress: bool | None = None) -> PostureSet:
    """Keep the postures of a set that hold the object, judged as the generator verifies a candidate.

    Each posture is replayed open loop at its palm pose as the generator verifies a candidate
    (`replay.replay_grasp` with the stages, protocol and hold of `params`). `generate_postures(obj, n, params=GeneratorParams(verify=False))` followed
    by this keeps exactly the candidates that the generator with verification keeps among its first
    n (the walk does not depend on the verification).

    Args:
        postures: the set to verify (its palm poses are in the object frame of `obj`).
        obj: the object the set was generated on, or its name.
        workers: worker processes (None: `workers.default_workers()`, one for fewer than `VERIFY_PER_WORKER`), or
            an executor that runs the replays elsewhere (a Dask cluster: `workers.cluster_executor`), with the same
            result.
        params: the verification's settings (`verify_protocol`, `stages`, `verify_hold_seconds`, `squeeze`); the
            defaults otherwise.
        progress: show a progress bar (None: as `progress.show_progress` says, on by default).

    Returns:
        The postures that held, with their epsilon and largest hold displacement (m); the metadata
        counts the candidates (`candidates`, `verified_ratio`, `verified_by_start`).
    """
    obj = get_object(obj)
    params = params or GeneratorParams()
    workers, executor = split_workers(workers)
    workers = workers_for(workers, len(postures), VERIFY_PER_WORKER)
    chunks = np.array_split(np.arange(len(postures)), max(1, min(len(postures), 8 * workers)))
    hand = postures.hand
    tasks = [(obj, params, postures.postures[c], postures.hand_poses[c], hand) for c in chunks if len(c)]
    with progress_bar(len(postures), f"verify {obj.name}", "postures", enabled=progress) as report:
        rows = np.concatenate(parallel_map(_verify_chunk, tasks, workers, lambda _, r: report.update(len(r)), executor)
                              or [np.zeros((0, 3))])
    held = rows[:, 0] > 0
    kept = postures.subset(held)
    if len(held) and held.mean() < FEW_HOLD:
        warnings.warn(f"only {int(held.sum())} of {len(held)} {obj.name} candidates hold ({held.mean():.0%}): too few to "
                      "map a grasp manifold on; more candidates, another mode or design family "
                      "(GeneratorParams.mode, .designs), or the paper's procedure (every candidate) give more",
                      stacklevel=2)
    names = [name.split(":", 1)[-1] for name in postures.start_names]
    by_start = {names[i]: float(held[postures.start_ids == i].mean()) for i in np.unique(postures.start_ids)}
    made = {**postures.metadata.get("generator", {}), "verify": True, "verify_protocol": params.verify_protocol,
            "stages": params.stages, "squeeze": params.squeeze, "verify_hold_seconds": params.verify_hold_seconds}
    metadata = {**postures.metadata, "generator": made, "verified": True, "candidates": len(postures),
                "verified_ratio": float(held.mean()) if len(held) else float("nan"), "verified_by_start": by_start,
                "verify_hold_seconds": params.verify_hold_seconds}
    return PostureSet(kept.postures, kept.hand_poses, kept.start_ids, kept.contacts, kept.start_names, metadata,
                      rows[held, 1], rows[held, 2])


def __getattr__(name: str) -> object:
    """The names that left this module in 0.3 (the spring rig, its walk and settings' presets, the start cache), with
    a warning (`base.moved.MOVED_NAMES`)."""
    return moved_attribute(__name__, name)
