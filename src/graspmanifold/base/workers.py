"""Parallel work: one runner (`parallel_map`) for every long job, in worker processes that die
with their parent and stop at once on Ctrl-C.

`parallel_map` is what the generator and the evaluation run their independent jobs through:
results come back in task order, the runner draws no random numbers (each task carries its seed),
and workers keep no state between tasks (the function, with everything it needs bound, travels
with each task), so a result never depends on the number of workers.

A `ProcessPoolExecutor`'s workers outlive a parent killed with SIGKILL (they wait forever for work
that never comes), and on Ctrl-C the pool waits for every running task before it lets go. The pool
made here fixes both: each worker asks Linux for SIGKILL when its parent dies (prctl
PR_SET_PDEATHSIG) and also watches its parent's pid once a second (for other systems, and for a
parent that died before the worker started); workers ignore SIGINT, and on any exception in the
parent, KeyboardInterrupt included, pending tasks are cancelled and the workers terminated.
"""

from __future__ import annotations

import ctypes
import itertools
import logging
import os
import re
import signal
import sys
import threading
import time
import warnings
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import CancelledError, Executor, Future, ProcessPoolExecutor, TimeoutError as FutureTimeout
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import TYPE_CHECKING, TypeVar

from threadpoolctl import threadpool_limits

from .errors import InvalidInput, WorkersLost
from .validation import check_int

if TYPE_CHECKING:
    import distributed

Task = TypeVar("Task")
Result = TypeVar("Result")

_PR_SET_PDEATHSIG = 1
CONNECT_TRIES = 3  # connection attempts to a Dask scheduler
CONNECT_SECONDS = 10  # how long to wait for a Dask scheduler
_WATCH_SECONDS = 1.0


def usable_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def free_cores() -> int:
    """Cores not busy with other work now: the usable cores less the one-minute load average beyond this
    process's own share (at least one). Threads sized by it degrade gracefully on a shared machine instead
    of fighting the other processes for the cores."""
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # not on a Unix
        return usable_cores()
    return max(1, min(usable_cores(), round(usable_cores() - max(0.0, load - 1.0))))


def default_workers() -> int:
    """Worker processes a job uses when not told: the cores this process may run on, at most two (the
    `graspmanifold` command's default too)."""
    return max(1, min(2, usable_cores()))


#: worker processes per usable core at most (a job asked for more gets this many, with a warning)
WORKERS_PER_CORE = 4


def split_workers(workers: int | Executor | None) -> tuple[int | None, Executor | None]:
    """A long job's `workers` argument, which is a number of local processes or an executor, as both.

    Args:
        workers: worker processes (None: the job's default), or a `concurrent.futures.Executor` (a Dask
            cluster's: `cluster_executor`) that runs the job's tasks instead.

    Returns:
        (workers, executor): (None, the executor) for an executor, else (workers, None).
    """
    return (None, workers) if isinstance(workers, Executor) else (workers, None)


def workers_for(workers: int | None, units: int, per_worker: int) -> int:
    """The worker processes for a job of `units` pieces of work (trials, postures).

    Args:
        workers: the caller's choice, kept as given up to `WORKERS_PER_CORE` per usable core and one per unit
            of work (above that, capped with a warning that says so); None: `default_workers()`, but no more
            than the job fills (one, this process, below `per_worker` units: a pool's start costs about a second).
        units: the job's size.
        per_worker: the units that pay for one worker process.

    Returns:
        The number of worker processes (1: this process).
    """
    if workers is not None:
        workers = check_int(workers, "workers")
        cap = max(1, min(WORKERS_PER_CORE * usable_cores(), units))
        if workers > cap:
            warnings.warn(f"workers={workers} is more than this job can use ({units} unit(s) of work, "
                          f"{usable_cores()} usable core(s), at most {WORKERS_PER_CORE} workers per core): "
                          f"running {cap}", stacklevel=3)
        return min(workers, cap)
    return max(1, min(default_workers(), units // per_worker))


def _die_with_parent(parent: int) -> None:
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):
            pass  # the watchdog below still ends the worker

    def watch() -> None:
        while True:
            if os.getppid() != parent:
                os._exit(1)
            time.sleep(_WATCH_SECONDS)

    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


def _start_worker(parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    threadpool_limits(limits=1)  # the workers fill the cores already: BLAS threads would only compete
    _die_with_parent(parent)


@contextmanager
def worker_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A process pool whose workers die with this process; leaving the block by an exception
    (Ctrl-C included) cancels what has not started and terminates the workers at once."""
    pool = ProcessPoolExecutor(workers, initializer=_start_worker, initargs=(os.getpid(),))
    try:
        yield pool
    except BaseException:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.kill()  # SIGKILL: a stopped worker ignores SIGTERM until continued
        for process in processes:
            process.join(timeout=5)
        manager = getattr(pool, "_executor_manager_thread", None)
        if manager is not None:  # its wakeup pipe closed before the interpreter's exit hook writes to it (that
            manager.join(timeout=5)  # race printed a traceback after a Ctrl-C, once in many)
        raise
    pool.shutdown(wait=True)


class ClusterExecutor(Executor):
    """A `concurrent.futures.Executor` on a Dask cluster that can say when the cluster is gone.

    `parallel_map` asks it while it waits for a result: a cluster whose scheduler is gone, or that has
    had no worker for `CLUSTER_PATIENCE` seconds, ends the job with `WorkersLost` instead of a
    wait without end. Made by `cluster_executor`; wraps any connected `distributed.Client`.

    Args:
        client: a connected `distributed.Client`.
        owned: objects to close with the executor (the `LocalCluster` it started), besides the client.
    """

    def __init__(self, client: "distributed.Client", owned: tuple = ()):
        self.client = client
        self._owned = owned
        self._executor = client.get_executor()

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """Runs `fn(*args, **kwargs)` on a worker of the cluster.

        Returns:
            the task's future.
        """
        return self._executor.submit(fn, *args, **kwargs)

    def workers(self) -> int | None:
        """The worker processes connected to the cluster now.

        Returns:
            their number, or None when the scheduler cannot be reached.
        """
        if self.client.status not in ("running", "connecting"):
            return None
        try:
            return len(self.client.nthreads())
        except Exception:  # noqa: BLE001 - any failure to reach the scheduler means the same
            return None

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Closes the connection to the cluster (and the cluster itself, when it was started here)."""
        self._executor.shutdown(wait=wait)
        if self.client.status != "running":  # the scheduler is gone: its cancelled reconnection would log
            logging.getLogger("distributed.client").setLevel(logging.CRITICAL)  # tracebacks, now and later
        self.client.close(timeout=CONNECT_SECONDS)
        for thing in self._owned:
            thing.close()


#: a Dask scheduler's address: [scheme://]host:port
_SCHEDULER_ADDRESS = re.compile(r"(?:(?:tcp|tls|ws|wss|ucx)://)?(?:[A-Za-z0-9_.-]+|\[[0-9A-Fa-f:.]+\]):\d{1,5}")


def cluster_executor(address: str) -> ClusterExecutor:
    """An executor that runs tasks on a Dask cluster (dask.distributed).

    Needs `pip install 'graspmanifold[cluster]'`.

    Args:
        address: the scheduler's (`tcp://host:8786`, with or without `dask://` in front), or `local` for
            a `LocalCluster` of one single-threaded worker process per core on this machine.

    Returns:
        a `ClusterExecutor` connected to it.

    Raises:
        InvalidInput: an address of no known form, or one where no Dask scheduler answers (one line).
    """
    if not isinstance(address, str) or not address:
        raise InvalidInput(f"executor address must be a string such as 'dask://tcp://host:8786' or 'local', "
                         f"got {address!r}")
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError("running on a Dask cluster needs dask.distributed: pip install 'graspmanifold[cluster]' "
                          "(from a checkout: pip install '.[cluster]')") from None
    address = address.removeprefix("dask://")
    if address == "local":
        cluster = LocalCluster(processes=True, threads_per_worker=1)
        return ClusterExecutor(Client(cluster), owned=(cluster,))
    if not _SCHEDULER_ADDRESS.fullmatch(address):
        raise InvalidInput(f"executor address must be 'dask://local' or a scheduler's 'dask://tcp://HOST:PORT' (tcp, "
                           f"tls, ws, wss or ucx; a port of 1-65535), got {address!r}")
    if not 0 < int(address.rsplit(":", 1)[1]) < 65536:
        raise InvalidInput(f"executor address: the port must be 1-65535, got {address!r}")
    for attempt in range(CONNECT_TRIES):
        try:
            return ClusterExecutor(Client(address, timeout=CONNECT_SECONDS))
        except AssertionError:  # distributed's handshake now and then reads two messages as one: try again
            if attempt == CONNECT_TRIES - 1:
                raise InvalidInput(f"no Dask scheduler answers as one at {address}") from None
        except Exception as error:  # noqa: BLE001 - refused, timed out, or junk read as a 3 EiB frame (MemoryError)
            raise InvalidInput(f"cannot connect to a Dask scheduler at {address}: "
                               f"{type(error).__name__}: {str(error)[:200]}") from None
    raise AssertionError("unreachable")  # pragma: no cover


#: tasks handed to the workers ahead of the results taken, per worker: the work in flight (and its
#: memory) stays bounded however many tasks there are
TASKS_AHEAD = 4
#: s a task may take, counted from when its result is the next one awaited: beyond it its worker is taken
#: as stopped, and the pool is started again with the unfinished tasks
TASK_TIMEOUT = 1800.0
#: how often a local pool whose worker died or stalled is started again before the job gives up
POOL_RESTARTS = 2
#: s a Dask cluster may have no worker before a job on it gives up (workers that come back in time resume it)
CLUSTER_PATIENCE = 120.0
#: s between looks at a Dask cluster's health while a result is awaited
CLUSTER_LOOK_SECONDS = 5.0


class _PoolBroke(Exception):
    """A local pool lost a worker (killed, or stalled past TASK_TIMEOUT): these tasks did not finish."""

    def __init__(self, unfinished: list, why: str):
        super().__init__(why)
        self.unfinished, self.why = unfinished, why


def _result(future: Future[Result], timeout: float | None, executor: Executor) -> Result:
    """The future's result; on a `ClusterExecutor`, `_PoolBroke` once the cluster's scheduler is gone
    or it has had no worker for `CLUSTER_PATIENCE` s (with a warning when the wait begins)."""
    if not isinstance(executor, ClusterExecutor):
        return future.result(timeout=timeout)
    without_workers: float | None = None
    while True:
        try:
            return future.result(timeout=CLUSTER_LOOK_SECONDS)
        except FutureTimeout:
            pass
        workers = executor.workers()
        if workers is None:
            raise _PoolBroke([], "the cluster's scheduler cannot be reached")
        if workers:
            without_workers = None
        elif without_workers is None:
            without_workers = time.monotonic()
            warnings.warn(f"the Dask cluster has no worker: waiting up to {CLUSTER_PATIENCE:g} s for one",
                          stacklevel=4)
        elif time.monotonic() - without_workers > CLUSTER_PATIENCE:
            raise _PoolBroke([], f"the Dask cluster has had no worker for {CLUSTER_PATIENCE:g} s")


def _bounded_map(executor: Executor, function: Callable[[Task], Result], tasks: Iterable[Task],
                 ahead: int, timeout: float | None = None) -> Iterator[Result]:
    """`executor.map`, but with at most `ahead` tasks submitted and not yet taken back (the executors'
    own `map` submits every task at once); a local pool that breaks raises `_PoolBroke` with the tasks
    it had not finished, in order, and so does a `ClusterExecutor` whose cluster is gone."""
    pending: deque[tuple[Task, Future]] = deque()
    remaining = iter(tasks)
    try:
        for task in itertools.islice(remaining, ahead):
            pending.append((task, executor.submit(function, task)))
        while pending:
            task, future = pending[0]
            try:
                result = _result(future, timeout, executor)
            except (BrokenProcessPool, FutureTimeout) as error:
                why = ("a worker process died" if isinstance(error, BrokenProcessPool)
                       else f"a task ran past {timeout:g} s (a stopped worker?)")
                raise _PoolBroke([t for t, _ in pending], why) from None
            except _PoolBroke as broke:
                raise _PoolBroke([t for t, _ in pending], broke.why) from None
            pending.popleft()
            for task in itertools.islice(remaining, 1):
                pending.append((task, executor.submit(function, task)))
            yield result
    finally:
        for _, future in pending:
            future.cancel()


def parallel_map(function: Callable[[Task], Result], tasks: Iterable[Task], workers: int = 1,
                 on_result: Callable[[int, Result], None] | None = None, executor: Executor | None = None
                 ) -> list[Result]:
    """`function(task)` for every task, in this process (`workers=1`), in a `worker_pool`, or on
    `executor` when one is given (any `concurrent.futures.Executor`, e.g. `cluster_executor(...)`).

    Results are returned, and handed to `on_result(index, result)` as they arrive (for progress
    and checkpoints), in task order. `function` must be picklable: a module-level function, or a
    `functools.partial` of one with the shared inputs bound. Every task carries what it needs, seed
    included, so the results are the same wherever the tasks run. `tasks` may be a generator: they are
    drawn only as workers become free (`TASKS_AHEAD` per worker in flight), so memory does not grow
    with their number. A local worker that dies or stalls (`TASK_TIMEOUT`) costs only its unfinished
    tasks: the pool starts again with them, up to `POOL_RESTARTS` times; a cluster that loses its
    scheduler or workers ends the job with `WorkersLost`.
    """
    check_int(workers, "workers")
    results: list[Result] = []

    def keep(result: Result) -> None:
        if on_result is not None:
            on_result(len(results), result)
        results.append(result)

    if executor is not None:
        if not isinstance(executor, Executor):
            raise TypeError(f"executor must be a concurrent.futures.Executor, got {type(executor).__name__}")
        try:
            for result in _bounded_map(executor, function, tasks, TASKS_AHEAD * max(workers, 8)):
                keep(result)
        except (CancelledError, _PoolBroke) as error:  # the cluster's scheduler or workers went away
            why = error.why if isinstance(error, _PoolBroke) else "its scheduler or workers are gone"
            if isinstance(executor, ClusterExecutor) and executor.client.status != "running":
                executor.shutdown(wait=False)  # the scheduler is gone: stop the client's attempts to reconnect
            raise WorkersLost(f"the cluster stopped running this job ({why}); finished work is kept where the "
                              "job checkpoints it: run the same command again once the cluster is back") from None
    elif workers == 1:
        for task in tasks:
            keep(function(task))
    else:
        remaining: Iterator[Task] = iter(tasks)
        for restart in range(POOL_RESTARTS + 1):
            try:
                with worker_pool(workers) as pool:
                    for result in _bounded_map(pool, function, remaining, TASKS_AHEAD * workers, TASK_TIMEOUT):
                        keep(result)
                break
            except _PoolBroke as broke:
                if restart == POOL_RESTARTS:
                    raise WorkersLost(f"{broke.why}, and again after {POOL_RESTARTS} fresh starts of the "
                                      f"{workers} worker processes; finished work is kept where the job "
                                      "checkpoints it") from None
                warnings.warn(f"{broke.why}: starting the worker processes again for the {len(broke.unfinished)} "
                              "unfinished tasks", stacklevel=2)
                remaining = itertools.chain(broke.unfinished, remaining)
    return results
