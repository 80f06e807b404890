"""Benchmark the SOM's hot paths in the paper's setting, against MiniSom in the same run.

    pip install minisom   # the peer; needed for this benchmark only
    python scripts/bench_som.py [--epochs 300] [--samples 4220] [--data postures.npz] [--repeats 5] [--out DIR]

25 x 25 map, 22 dimensions, 4220 samples, 300 epochs (paper Section 5). Both online trainers start
from the same PCA-initialised weights and follow the same per-epoch schedule (learning rate
0.95 -> 0.05, sigma 6 -> 0.7, exponential decay, every sample once per epoch in random order);
MiniSom gets the schedule through its decay hooks. Without --data the samples are synthetic
posture-like clusters. Masked best match: random Partial Contact Posture masks over the trained
map. Each of our timings is the median of --repeats runs after one warm-up call (the first call
in a fresh environment compiles the kernels); the NumPy references (GRASPMANIFOLD_COMPILED=0)
are timed in the same run.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from collections.abc import Callable

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from ..base.io import markdown_row, markdown_table
from ..base.workers import usable_cores
from ..base import compiled as kernels_switch
from ..manifold.som import SOM, decay_schedule
from ..sim.hand import SEGMENTS, finger_limits
from ..sim.posture import pcp_mask
from .runner import run_study

ROWS = COLS = 25
DIM = 22


def synthetic_postures(n: int, seed: int = 0) -> np.ndarray:
    """Clusters around random postures inside the joint limits, like spring-generated data."""
    rng = np.random.default_rng(seed)
    limits = finger_limits()
    centres = rng.uniform(limits[:, 0], limits[:, 1], (12, DIM))
    return centres[rng.integers(0, len(centres), n)] + rng.normal(0.0, 0.06, (n, DIM))


def load_postures(path: str) -> np.ndarray:
    with np.load(path) as archive:
        return np.asarray(archive["postures"], dtype=float)


def train_minisom(data: np.ndarray, initial: np.ndarray, epochs: int, seed: int):
    from minisom import MiniSom

    rates = decay_schedule(0.95, 0.05, epochs)
    widths = decay_schedule(6.0, 0.7, epochs)
    som = MiniSom(ROWS, COLS, DIM, sigma=6.0, learning_rate=0.95, random_seed=seed,
                  decay_function=lambda lr, t, max_t: rates[t])
    som._sigma_decay_function = lambda sigma, t, max_t: widths[t]  # MiniSom takes only named sigma decays
    som._weights = initial.copy()
    start = time.perf_counter()
    som.train(data, epochs, random_order=True, use_epochs=True)
    return som, time.perf_counter() - start


def median_seconds(call: Callable[[], object], repeats: int) -> float:
    """Median wall time of `repeats` calls after one warm-up call."""
    call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def with_engine(compiled: bool, call: Callable[[], object]) -> Callable[[], object]:
    """`call` run with the compiled kernels or with their NumPy references."""
    def run() -> object:
        previous = kernels_switch.use_compiled(compiled)
        try:
            return call()
        finally:
            kernels_switch.use_compiled(previous)
    return run


def pcp_queries(data: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Postures near the data, each with the mask of a random Partial Contact Posture (1-5 segments)."""
    rng = np.random.default_rng(1)
    queries = data[rng.integers(0, len(data), count)] + rng.normal(0, 0.05, (count, DIM))
    segments = np.array(SEGMENTS)
    masks = np.array([pcp_mask(rng.choice(segments, rng.integers(1, 6))) for _ in range(2000)])
    masks[~masks.any(axis=1)] = True
    return queries, masks[rng.integers(0, len(masks), count)]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=300)
    parser.add_argument("--samples", type=int, default=4220)
    parser.add_argument("--data", help="a .npz with a 'postures' array (n, 22) instead of synthetic data")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--skip-minisom", action="store_true")
    parser.add_argument("--out", default="study-som-speed", help="the folder its report (som_speed.md) is kept in")
    args = parser.parse_args(argv)
    run_study(args.out, 1, lambda run: measure(args), "som_speed.md")


def measure(args: argparse.Namespace) -> None:
    """The benchmark's tables, printed (see the module doc)."""
    data = load_postures(args.data) if args.data else synthetic_postures(args.samples)
    updates = args.epochs * len(data)
    print(f"python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
          f"{len(data)} samples x {DIM}, {ROWS}x{COLS} map, {args.epochs} epochs = {updates} updates\n")

    def fit(algorithm: str) -> SOM:
        return SOM(ROWS, COLS, DIM, seed=0).fit(data, epochs=args.epochs, algorithm=algorithm)

    ours = fit("online")
    rows = [("graspmanifold online (compiled)", median_seconds(lambda: fit("online"), args.repeats),
             ours.quantization_error(data))]
    if not args.skip_minisom:
        initial = SOM(ROWS, COLS, DIM).initialize(data).weights.copy()
        peer, t_peer = train_minisom(data, initial, args.epochs, seed=0)
        rows.append(("MiniSom online (same schedule)", t_peer,
                     float(np.mean(np.linalg.norm(data - peer.quantization(data), axis=1)))))
    batch = fit("batch")
    rows.append(("graspmanifold batch", median_seconds(lambda: fit("batch"), args.repeats),
                 batch.quantization_error(data)))
    reference_epochs = max(1, args.epochs // 30)  # the NumPy reference is slow: timed on fewer epochs, scaled
    reference = with_engine(False, lambda: SOM(ROWS, COLS, DIM, seed=0).fit(data, epochs=reference_epochs))
    start = time.perf_counter()
    reference()
    rows.append((f"graspmanifold online, NumPy reference ({reference_epochs} epochs timed, scaled)",
                 (time.perf_counter() - start) * args.epochs / reference_epochs, float("nan")))

    print("\n".join(markdown_table(["trainer", "time (s)", "µs / update", "quantisation error"], [
        [name, f"{seconds:.2f}", f"{seconds / updates * 1e6:.2f}", f"{qe:.4f}"] for name, seconds, qe in rows])))
    if not args.skip_minisom:
        print(f"\nonline speed-up over MiniSom: {t_peer / rows[0][1]:.1f}x")

    product = np.random.default_rng(2).normal(size=(len(data), DIM + 1)).astype(np.float32)
    node_side = np.random.default_rng(3).normal(size=(DIM + 1, ROWS * COLS)).astype(np.float32)
    print("\nthe winner product of one batch epoch (samples x 23 @ 23 x 625, single precision):")
    for threads in sorted({1, usable_cores()}):
        with threadpool_limits(limits=threads, user_api="blas"):
            seconds = median_seconds(lambda: np.dot(product, node_side), 50)
        print(f"  {threads} BLAS thread(s): {seconds * 1e3:.2f} ms")

    queries, masks = pcp_queries(data, 100_000)
    singles = 20_000
    print(f"\nmasked best match on the trained map ({masks.sum(axis=1).mean():.1f} of {DIM} joints masked on average)")
    print("\n".join(markdown_table(["engine", "single query (µs)", "batched (queries / s)"], [])))
    for name, compiled in (("compiled", True), ("NumPy reference", False)):
        def single() -> None:
            for q, m in zip(queries[:singles], masks[:singles]):
                ours.best_match(q, m)

        one = median_seconds(with_engine(compiled, single), args.repeats) / singles
        many = median_seconds(with_engine(compiled, lambda: ours.best_match_batch(queries, masks)), args.repeats)
        print(markdown_row([name, f"{one * 1e6:.2f}", f"{len(queries) / many:,.0f}"]))


if __name__ == "__main__":
    main()
