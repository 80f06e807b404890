"""The batch SOM's 300 epochs on an idle machine and with every core busy with other processes, with its BLAS
threads sized to the free cores (now) against one thread per core (before issue 26), in the same run.

    python scripts/bench_som_load.py [--repeats 3] [--samples 4220]

The load is one busy Python process per usable core. Prints the median seconds of each case and the loaded
time as a multiple of the idle one.
"""

from __future__ import annotations

import argparse
import multiprocessing
import statistics
import time

from graspmanifold.studies.som_speed import COLS, DIM, ROWS, synthetic_postures

import graspmanifold as gm
from graspmanifold.base import workers
from graspmanifold.manifold import som as som_module


def busy(stop) -> None:
    while not stop.is_set():
        sum(range(10_000))


def seconds(data, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        gm.SOM(ROWS, COLS, DIM, seed=0, algorithm="batch").fit(data)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--samples", type=int, default=4220)
    args = parser.parse_args()
    data = synthetic_postures(args.samples)
    gm.SOM(ROWS, COLS, DIM, seed=0, algorithm="batch").fit(data[:100], epochs=2)  # warm-up
    threads = {"free cores (now)": workers.free_cores, "every core (before)": workers.usable_cores}
    idle = {name: 0.0 for name in threads}
    for name, rule in threads.items():
        som_module.free_cores = rule
        idle[name] = seconds(data, args.repeats)
    stop = multiprocessing.Event()
    load = [multiprocessing.Process(target=busy, args=(stop,)) for _ in range(workers.usable_cores())]
    for process in load:
        process.start()
    time.sleep(65)  # the one-minute load average catches up with the load
    try:
        for name, rule in threads.items():
            som_module.free_cores = rule
            loaded = seconds(data, args.repeats)
            print(f"{name}: idle {idle[name]:.2f} s, loaded {loaded:.2f} s ({loaded / idle[name]:.1f}x); "
                  f"{args.repeats} runs each, {args.samples} samples, {workers.usable_cores()} busy processes")
    finally:
        stop.set()
        for process in load:
            process.join()
    som_module.free_cores = workers.free_cores


if __name__ == "__main__":
    main()
