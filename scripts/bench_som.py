"""Benchmark the SOM in the paper's setting against MiniSom, in the same run.

    pip install minisom   # the peer; needed for this benchmark only
    python scripts/bench_som.py [--epochs 300] [--samples 4220] [--data postures.npz]

25 x 25 map, 22 dimensions, 4220 samples, 300 epochs (paper Section 5). Both trainers start from
the same PCA-initialised weights and follow the same per-epoch schedule (learning rate 0.95 -> 0.05,
sigma 6 -> 0.7, exponential decay, every sample once per epoch in random order); MiniSom gets the
schedule through its decay hooks. Without --data the samples are synthetic posture-like clusters.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np
from scipy.linalg.blas import dger
from threadpoolctl import threadpool_limits

import graspmanifold as gm
from graspmanifold.som import decay_schedule

ROWS = COLS = 25
DIM = 22


def synthetic_postures(n: int, seed: int = 0) -> np.ndarray:
    """Clusters around random postures inside the joint limits, like spring-generated data."""
    rng = np.random.default_rng(seed)
    limits = gm.finger_limits()
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


def blas_floor(n_updates: int) -> float:
    """Seconds per update of the two BLAS kernels an online step cannot avoid (v.x and the rank-1 update)."""
    v = np.asfortranarray(np.random.default_rng(0).normal(size=(ROWS * COLS, DIM)))
    x, coef, out = np.ones(DIM), np.full(ROWS * COLS, 1e-9), np.empty(ROWS * COLS)
    with threadpool_limits(limits=1, user_api="blas"):
        start = time.perf_counter()
        for _ in range(n_updates):
            np.dot(v, x, out=out)
            v = dger(1.0, coef, x, a=v, overwrite_a=1)
        return (time.perf_counter() - start) / n_updates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=300)
    parser.add_argument("--samples", type=int, default=4220)
    parser.add_argument("--data", help="a .npz with a 'postures' array (n, 22) instead of synthetic data")
    parser.add_argument("--skip-minisom", action="store_true")
    args = parser.parse_args()

    data = load_postures(args.data) if args.data else synthetic_postures(args.samples)
    updates = args.epochs * len(data)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {len(data)} samples x {DIM}, "
          f"{ROWS}x{COLS} map, {args.epochs} epochs = {updates} updates\n")
    rows = []

    ours = gm.SOM(ROWS, COLS, DIM, seed=0)
    initial = ours.initialize(data).weights.copy()
    start = time.perf_counter()
    ours.fit(data, epochs=args.epochs)
    t_ours = time.perf_counter() - start
    rows.append(("graspmanifold online", t_ours, ours.quantization_error(data)))

    if not args.skip_minisom:
        peer, t_peer = train_minisom(data, initial, args.epochs, seed=0)
        peer_qe = float(np.mean(np.linalg.norm(data - peer.quantization(data), axis=1)))
        rows.append(("MiniSom online (same schedule)", t_peer, peer_qe))

    batch = gm.SOM(ROWS, COLS, DIM, seed=0)
    start = time.perf_counter()
    batch.fit(data, epochs=args.epochs, algorithm="batch")
    rows.append(("graspmanifold batch", time.perf_counter() - start, batch.quantization_error(data)))

    print("| trainer | time (s) | µs / update | quantisation error |")
    print("|---|---|---|---|")
    for name, seconds, qe in rows:
        print(f"| {name} | {seconds:.2f} | {seconds / updates * 1e6:.2f} | {qe:.4f} |")
    if not args.skip_minisom:
        print(f"\nonline speed-up over MiniSom: {t_peer / t_ours:.1f}x")
    floor = blas_floor(20000)
    print(f"BLAS floor of one online update (v.x + rank-1 update, 1 thread): {floor * 1e6:.2f} µs "
          f"-> ours runs at {floor / (t_ours / updates):.0%} of that floor")

    # masked best-match queries: random Partial Contact Posture masks over the trained map
    rng = np.random.default_rng(1)
    queries = data[rng.integers(0, len(data), 100_000)] + rng.normal(0, 0.05, (100_000, DIM))
    segments = np.array(gm.SEGMENTS)
    masks = np.array([gm.pcp_mask(rng.choice(segments, rng.integers(1, 6))) for _ in range(2000)])
    masks[~masks.any(axis=1)] = True
    masks = masks[rng.integers(0, len(masks), len(queries))]
    singles = 20_000
    start = time.perf_counter()
    for q, m in zip(queries[:singles], masks[:singles]):
        ours.best_match(q, m)
    single = (time.perf_counter() - start) / singles
    start = time.perf_counter()
    ours.best_match_batch(queries, masks)
    batched = len(queries) / (time.perf_counter() - start)
    print(f"\nmasked best match, single query: {single * 1e6:.1f} µs (mean over {singles})")
    print(f"masked best match, batched: {batched:,.0f} queries/s ({len(queries)} queries, one mask each)")


if __name__ == "__main__":
    main()
