"""What every study shares: its output folder, its log, its pool of workers, the results it keeps under their
keys, its paired comparisons and its tables.

Every study runs over a `StudyRun`: the run holds the folder (locked while the study runs in its `session`), one
pool of worker processes for the whole study, the log (each line with the seconds since the start), the transcript
of what it prints (kept in its folder: a benchmark's tables too) and the count of what was computed now and what was
taken from an earlier run. A result is kept by `keep` under the key of what
made it (`checkpoints.result_key`: the configuration and the code), so a rerun takes what is still valid and
recomputes what is not, whatever the files are called. `holm_family` and `comparison_table` are the one way
a study reports paired comparisons (McNemar, Holm within a family); `base.io.markdown_table` writes every table.
`run_command` is the shell around a study's `main`: Ctrl-C ending in one line that says how to resume, a library
error (a folder another study holds among them) ending in one line.
"""

from __future__ import annotations

import errno
import io
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from contextlib import contextmanager, nullcontext, redirect_stdout
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, TypeVar

import numpy as np

from ..base.checkpoints import PartStore, remove_checkpoints, result_key
from ..base.errors import GraspManifoldError, InvalidInput
from ..base.io import (
    LOCK_FILE,
    check_writable_folder,
    json_text,
    markdown_table,
    output_lock,
    software_versions,
    write_failure,
    write_text_atomic,
)
from ..base.workers import parallel_map, worker_pool, workers_for
from ..manifold.postureset import PostureSet
from ..trials.evaluation import EvaluationResult
from ..trials.stats import PairedComparison, holm, wilson_interval

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

Result = TypeVar("Result")
Made = TypeVar("Made")  # what `keep_each` computes (and writes); its `read` may give another type


class StudyRun:
    """A study's output folder, log, worker pool and kept results.

    Args:
        out: the folder (made when missing).
        workers: worker processes (capped at the machine's cores; 1 runs everything in this process).
    """

    def __init__(self, out: str | Path, workers: int = 2):
        if not str(out):  # Path("") is the current folder: a study's files would land among one's own
            raise InvalidInput("--out must name a folder, got an empty path")
        self.out = Path(out)
        self.workers = workers_for(workers, 10**6, 1)  # capped at the cores: a study's trials outnumber them
        check_writable_folder(self.out, "--out")  # a file, or a folder that cannot be written, named as such
        self.out.mkdir(parents=True, exist_ok=True)  # after the checks: a refused study leaves no folder
        self.executor: Executor | None = None  # the pool, while `session()` is open
        self.started = time.perf_counter()
        self.computed, self.reused = 0, 0  # results computed now, and taken from an earlier run
        self.seconds = 0.0  # spent computing results now (not counting those taken from an earlier run)
        self._computing = 0  # results being computed now: one computed inside another counts its seconds once

    def log(self, text: str) -> None:
        """Print one line of the study's log, with the seconds since it started."""
        print(f"[{time.perf_counter() - self.started:6.0f} s] {text}", flush=True)

    def check_writable(self, *reports: str | os.PathLike | None) -> None:
        """Refuse, before any work, reports written at a study's end that could not be written there (a report
        in a folder that cannot be written was refused only after the study's hour of work; its results were
        kept, but the hour's report was not).

        Args:
            reports: the report files (None: none).

        Raises:
            InvalidInput: a report's folder cannot be written.
        """
        for report in reports:
            if report is not None:
                check_writable_folder(Path(report).parent, f"report {report}: its folder")

    @contextmanager
    def session(self) -> Iterator[StudyRun]:
        """The folder locked for this study (a second study on it is refused: `errors.OutputInUse`) and one pool
        of worker processes for everything it runs inside the block (a pool per evaluation costs seconds on small
        grids)."""
        with output_lock(self.out / LOCK_FILE, self.out), worker_pool(self.workers) as pool:
            self.executor = pool if self.workers > 1 else None
            try:
                yield self
            finally:
                self.executor = None

    @contextmanager
    def transcript(self, name: str) -> Iterator[Path]:
        """What the study prints inside the block, printed and also kept as `name` in its folder (written when the
        block ends, interrupted or not: what was printed is not lost).

        Args:
            name: the file's name in the folder ('som_speed.md').

        Yields:
            The file's path.
        """
        path, kept = self.out / name, io.StringIO()

        class Tee(io.TextIOBase):
            def __init__(self, screen: TextIO):
                self.screen = screen

            def write(self, text: str) -> int:
                kept.write(text)
                return self.screen.write(text)

            def flush(self) -> None:
                self.screen.flush()

        try:
            with redirect_stdout(Tee(sys.stdout)):
                yield path
        finally:
            write_text_atomic(path, kept.getvalue())

    def keep(self, name: str, key: str, compute: Callable[[], Result], read: Callable[[Path], tuple[Result, dict]],
             write: Callable[[Result, Path, dict], object]) -> Result:
        """A result kept in the folder under its key: read when a file of that name holds this key, else computed
        and written (a file of another key, or one that cannot be read, is replaced, with a warning naming it).

        Args:
            name: its file name in the folder (a path under it: 'evaluation/box.npz').
            key: what made it (`checkpoints.result_key`).
            compute: makes it.
            read: reads a file: the result and the file's metadata.
            write: writes the result to a path with this metadata added to the file's own.

        Returns:
            The result.
        """
        path = self.out / name
        store = PartStore(path.parent, key, read)
        stored = store.load(path.name)
        if stored:
            self.reused += 1
            return stored[path]
        start = time.perf_counter()
        self._computing += 1
        try:
            result = compute()
        finally:
            self._computing -= 1
        store.save(path.name, lambda target, meta: write(result, target, meta))
        self.computed += 1
        if not self._computing:
            self.seconds += time.perf_counter() - start
        return result

    def keep_each(self, folder: str, tasks: Sequence[tuple], compute: Callable[[tuple], Made],
                  read: Callable[[Path], tuple[Result, dict]], write: Callable[[Made, Path, dict], object],
                  describe: Callable[[tuple, Made], str] | None = None) -> dict[tuple, Made | Result]:
        """`keep` of many results at once: each task's result kept in `folder` under the task's key (its file named
        after the task), those not kept yet computed in the study's pool as they come, each logged (`describe`).

        Args:
            folder: a folder under the study's.
            tasks: picklable tuples, each what `compute` needs (and what its result is keyed on).
            compute: makes one task's result (a module-level function: it may run in a worker process).
            read: reads a file: the result (what `compute` made, or what of it is kept) and the file's metadata.
            write: writes a result to a path with this metadata added to the file's own.
            describe: a log line for a result computed now (None: none).

        Returns:
            {task: result} in the order of `tasks`.
        """
        stores = {task: PartStore(self.out / folder, result_key({"task": list(task)}), read) for task in tasks}
        files = {task: "@".join(map(str, task)).replace(" ", "_").replace("/", "-")[:120] + ".npz" for task in tasks}
        results: dict[tuple, Made | Result] = {}
        for task in tasks:
            found = stores[task].load(files[task])
            if found:
                results[task] = next(iter(found.values()))
                self.reused += 1
        missing = [task for task in tasks if task not in results]
        start = time.perf_counter()

        def kept(index: int, result: Made) -> None:
            task = missing[index]
            stores[task].save(files[task], lambda path, meta: write(result, path, meta))
            results[task] = result
            self.computed += 1
            if describe is not None:
                self.log(describe(task, result))

        parallel_map(compute, missing, self.workers, kept, self.executor)
        if missing and not self._computing:
            self.seconds += time.perf_counter() - start
        return {task: results[task] for task in tasks}

    def postures(self, name: str, key: str, make: Callable[[Path], PostureSet]) -> PostureSet:
        """A posture set kept as `<name>.npz` under its key; `make` gets a checkpoint folder of its own (removed
        once the set is written), so an interrupted generation resumes too.

        Args:
            name: the set's name in the folder.
            key: what makes it (`checkpoints.result_key`).
            make: generates it, given its checkpoint folder.

        Returns:
            The set.
        """
        parts = self.out / f"{name}.parts"
        result = self.keep(f"{name}.npz", key, lambda: make(parts), PostureSet.load_with_metadata,
                           lambda postures, target, meta: replace(
                               postures, metadata={**postures.metadata, **meta}).save(target))
        remove_checkpoints(parts)
        return result

    def evaluation(self, name: str, key: str, make: Callable[[Path], EvaluationResult]) -> EvaluationResult:
        """An evaluation kept as `<name>.npz` under its key (`TrialSetup.key`); `make` gets a checkpoint folder of
        its own, removed once the result is written.

        Args:
            name: the result's name in the folder.
            key: what makes it.
            make: runs it, given its checkpoint folder.

        Returns:
            The result.
        """
        parts = self.out / f"{name}.parts"
        result = self.keep(f"{name}.npz", key, lambda: make(parts), EvaluationResult.load_with_metadata,
                           lambda result, target, meta: result.save(target, extra=meta))
        remove_checkpoints(parts)
        return result


def run_command(out: str | Path, body: Callable[[], object]) -> None:
    """Run a study's body as a command: Ctrl-C ends in one line that says how to resume (exit status 130), a
    library error (bad input, a folder another run writes) or a file that could not be written (a full disk) in one
    line (status 1).

    Args:
        out: the study's folder (named in the message).
        body: the study.
    """
    try:
        body()
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished work is kept in {out}; run the same command again to resume", file=sys.stderr)
        raise SystemExit(130) from None
    except GraspManifoldError as error:
        raise SystemExit(f"error: {error}") from None
    except OSError as error:  # a file that could not be written (a full disk): one line, as the CLI says it
        remedy = "free the space" if error.errno in (errno.ENOSPC, errno.EDQUOT) else "make it writable"
        line = write_failure(error, f"finished work is kept in {out}; {remedy} and run the same command again to "
                                    "resume")
        if line is None:
            raise
        raise SystemExit(line) from None


def study_config(make: Callable[[], Result]) -> Result:
    """A study's configuration made from its command line, every setting checked before its folder is made: a bad
    one ends the command in one line (status 1), as the library's other refusals do.

    Args:
        make: builds the configuration (a config file read, flags applied).

    Returns:
        The configuration.
    """
    try:
        return make()
    except InvalidInput as error:
        raise SystemExit(f"error: {error}") from None


def run_study(out: str | Path, workers: int, body: Callable[[StudyRun], object], transcript: str | None = None,
              pool: bool = True) -> None:
    """A study as a command: its `StudyRun` over `out` (the folder locked, and one worker pool open, while `body(run)`
    runs), what it prints kept as `transcript` in the folder (None: not kept), Ctrl-C and library errors ended as
    `run_command` ends them.

    Args:
        out: the study's folder.
        workers: worker processes (`run.workers`).
        body: the study, given its run.
        transcript: the file its printed output is kept in, or None.
        pool: open the study's pool (`run.executor`); False: what it calls brings its own (`run.workers` of them).
    """
    def within() -> None:
        run = StudyRun(out, workers)  # its worker count checked inside: a bad one ends in one line
        with run.session() if pool else output_lock(run.out / LOCK_FILE, run.out), \
                run.transcript(transcript) if transcript else nullcontext():
            body(run)

    run_command(out, within)


def publish(study: StudyRun, doc: Path, quick: bool, info: dict, report: Callable[[dict], str],
            figure: Callable[[dict, Path], str] | None = None) -> None:
    """A study's results written out: its figure beside the report (`figure(info, path)` returns the file's name,
    kept as info['figure']), the report, OUT/study.json with the command, the software versions and the run's wall
    time (with how many results it computed and how many it took from an earlier run) and, for a full run, that JSON
    beside the report; the verdict printed.

    Args:
        study: the run.
        doc: the markdown report.
        quick: a smoke run (its JSON is not put beside a report in docs/).
        info: what the report shows; it must hold 'verdict'.
        report: the report's text from info.
        figure: draws the report's figure, or None.
    """
    if figure is not None:
        info["figure"] = figure(info, doc.with_suffix(".png"))
    write_text_atomic(doc, report(info))
    made_by = {"command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]), "versions": software_versions(),
               "run": {"wall_seconds": round(time.perf_counter() - study.started, 1), "workers": study.workers,
                       "results_computed": study.computed, "results_reused": study.reused}}
    data = json_text({**info, **made_by})  # what made it, and what it ran on
    write_text_atomic(study.out / "study.json", data)
    if not quick:
        write_text_atomic(doc.with_suffix(".json"), data)
    print(f"\n{info['verdict']}\nwrote {doc} and {study.out / 'study.json'} in {time.perf_counter() - study.started:.0f} s")


def rate_curve(ax: Axes, xs: Sequence[float] | np.ndarray, counts: Sequence[Sequence[int]], **style: Any) -> None:
    """Rates in percent with their 95 % Wilson intervals as error bars, on a matplotlib axis.

    Args:
        ax: the axis.
        xs: where each rate is drawn.
        counts: (successes, trials) per point; no trials: no point.
        style: `Axes.errorbar`'s keywords (label, fmt, ...).
    """
    rates = np.array([held / n if n else np.nan for held, n in counts])
    low, high = np.array([wilson_interval(held, n) for held, n in counts]).T
    bars = np.nan_to_num(100 * np.clip([rates - low, high - rates], 0, None))  # a rate at 0 or 1 is its own bound
    ax.errorbar(np.asarray(xs, dtype=float), 100 * rates, yerr=bars, capsize=2, **style)


def save_figure(figure: Figure, path: Path) -> str:
    """Write a matplotlib figure (its folder made) and close it; returns the file's name."""
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path.name


def holm_family(family: Sequence[tuple[str, PairedComparison]], name: str = "") -> list[dict]:
    """A family of paired comparisons with Holm's correction within it: one row each.

    Args:
        family: (label, comparison) pairs, read together.
        name: the family's name, kept in each row.

    Returns:
        Rows {family, label, n, only_a, only_b, both, p_value, p_holm, difference}.
    """
    adjusted = holm([c.p_value for _, c in family]) if family else np.zeros(0)
    return [{"family": name, "label": label, "n": c.n, "only_a": c.only_a, "only_b": c.only_b, "both": c.both,
             "p_value": c.p_value, "p_holm": float(p), "difference": c.difference}
            for (label, c), p in zip(family, adjusted)]


def comparison_table(rows: Sequence[dict], family: bool = False, bootstrap: bool = False) -> list[str]:
    """The markdown table of `holm_family`: `+` / `-` are the pairs where only the first / only the second
    held.

    Args:
        rows: the rows.
        family: whether to show each row's family in a first column.
        bootstrap: whether to show each row's cluster-bootstrap interval over plans (its "bootstrap",
            `ClusteredEstimate.to_dict`) and its plans.

    Returns:
        The table's lines.
    """
    header = (["family"] if family else []) + ["comparison", "n", "+", "-", "difference", "p", "p (Holm)"] + (
        ["95 % CI over plans", "plans"] if bootstrap else [])
    return markdown_table(header, [([r["family"]] if family else []) + [
        r["label"], r["n"], r["only_a"], r["only_b"], f"{100 * r['difference']:+.1f} pts", f"{r['p_value']:.3g}",
        f"{r['p_holm']:.3g}"] + ([f"[{100 * r['bootstrap']['low']:+.1f}, {100 * r['bootstrap']['high']:+.1f}]",
                                  r["bootstrap"]["clusters"]] if bootstrap else []) for r in rows])
