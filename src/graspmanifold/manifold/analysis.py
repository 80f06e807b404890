"""Analyses of grasp manifolds behind the paper's Section 5: smoothness and data support, before and after resuming
the learning with postures from the grasp controller; for a continuous manifold (`ukr.UKR`), postures sampled on a
grid of its latent space (Fig. 3's view) and along a path between two clusters (Fig. 5's)."""

from __future__ import annotations

import copy

import numpy as np
from scipy.spatial import cKDTree

from ..base.errors import NotFittedError
from .som import RESUME, SOM
from .ukr import UKR


def node_distances(som: SOM) -> np.ndarray:
    """(rows, cols) mean distance of each node to its 4-neighbours."""
    horizontal, vertical = som.internode_distances()
    total, count = np.zeros((som.rows, som.cols)), np.zeros((som.rows, som.cols))
    for values, a, b in ((horizontal, np.s_[:, :-1], np.s_[:, 1:]), (vertical, np.s_[:-1, :], np.s_[1:, :])):
        total[a] += values
        total[b] += values
        count[a] += 1
        count[b] += 1
    return total / np.maximum(count, 1)


def border_runs(som: SOM, hits: np.ndarray, count: int = 2) -> list[list[tuple[int, int]]]:
    """The rule behind Fig. 5: 1 x 4 runs of nodes (rows or columns) whose two ends carry training data
    and whose two middle nodes carry none, so that they cross a cluster border; of those, the runs
    whose ends lie farthest apart, without sharing a node. Where the map has too few such runs, runs
    with one unsupported middle node, then any runs, fill up (`border_measures` says which kind each is)."""
    runs = []
    for r in range(som.rows):
        for c in range(som.cols):
            for dr, dc in ((0, 1), (1, 0)):
                cells = [(r + k * dr, c + k * dc) for k in range(4)]
                if all(0 <= a < som.rows and 0 <= b < som.cols for a, b in cells):
                    runs.append(cells)

    def rank(cells):
        ends = hits[cells[0]] > 0 and hits[cells[-1]] > 0
        empty_middle = sum(hits[m] == 0 for m in cells[1:3])
        span = np.linalg.norm(som.weights[cells[0]] - som.weights[cells[-1]])
        return (ends, empty_middle, span)

    runs.sort(key=rank, reverse=True)
    chosen: list[list[tuple[int, int]]] = []
    for cells in runs:
        if all(not set(cells) & set(other) for other in chosen):
            chosen.append(cells)
        if len(chosen) == count:
            break
    return chosen


def border_measures(som: SOM, hits: np.ndarray, runs: list[list[tuple[int, int]]]) -> list[dict]:
    """For each run: the step between neighbouring nodes (degrees), whether it crosses a border
    (data at both ends, none in the middle) and, per middle node, whether it is intermediate: closer
    to each end than the ends are to each other (the paper's "interpolate nicely", made measurable)."""
    measures = []
    for cells in runs:
        w = np.array([som.weights[cell] for cell in cells])
        span = np.linalg.norm(w[0] - w[-1])
        measures.append({
            "nodes": [list(map(int, cell)) for cell in cells],
            "steps_deg": np.degrees(np.linalg.norm(np.diff(w, axis=0), axis=1)).tolist(),
            "crosses_unsupported": bool(hits[cells[0]] > 0 and hits[cells[-1]] > 0
                                        and all(hits[m] == 0 for m in cells[1:3])),
            "middle_intermediate": [bool(np.linalg.norm(m - w[0]) < span and np.linalg.norm(m - w[-1]) < span)
                                    for m in w[1:3]]})
    return measures


def nearest_neighbour_deg(postures: np.ndarray) -> dict[str, float]:
    """How densely a set is sampled: each posture's distance (degrees over all joints) to its nearest
    other posture, summarised as min (the closest pair), median and 90th percentile."""
    if len(postures) < 2:
        return {"min": float("nan"), "median": float("nan"), "p90": float("nan")}
    distances = np.degrees(cKDTree(postures).query(postures, k=2)[0][:, 1])
    return {"min": float(distances.min()), "median": float(np.median(distances)),
            "p90": float(np.percentile(distances, 90))}


def smoothness(som: SOM, training: np.ndarray | None = None, evaluation: np.ndarray | None = None
               ) -> dict[str, float | int]:
    """Inter-node distance statistics (degrees over all joints), errors and data support of a map.

    With `training` / `evaluation` postures: quantisation and topographic error on the training data, how
    many nodes no training (evaluation) posture falls on, and which fraction of the evaluation postures
    land on nodes that no training posture supports (the paper's observation that evaluation grasps match
    mainly inter-cluster nodes).

    Args:
        som: a fitted map.
        training: its training postures (n, dim), rad.
        evaluation: postures from an evaluation (m, dim), rad.

    Returns:
        The statistics by name (distances in degrees, errors in rad, counts of nodes).
    """
    stats = som.distance_stats(degrees=True)
    report: dict[str, float | int] = {f"distance_{k}_deg" if k != "cv" else "distance_cv": v
                                      for k, v in stats.items() if k != "edges"}
    report["nodes"] = som.n_nodes
    if training is not None and len(training):
        hits = som.hit_counts(training).ravel()
        report.update(quantization_error=som.quantization_error(training),
                      topographic_error=som.topographic_error(training),
                      unsupported_by_training=int(np.sum(hits == 0)))
    if evaluation is not None and len(evaluation):
        eval_hits = som.hit_counts(evaluation).ravel()
        report["unsupported_by_evaluation"] = int(np.sum(eval_hits == 0))
        if training is not None and len(training):
            winners = som.best_match_batch(evaluation)
            report["evaluation_on_unsupported_nodes"] = float(np.mean(hits[winners] == 0))
    return report


def resume_learning(som: SOM, postures: np.ndarray, *, epochs: int = RESUME.epochs,
                    learning_rate: tuple[float, float] = RESUME.learning_rate,
                    sigma: tuple[float, float] = RESUME.sigma, training: np.ndarray | None = None
                    ) -> tuple[SOM, dict[str, dict]]:
    """A copy of `som` trained further on `postures` (the paper's second phase), with the smoothness
    report before and after; `som` itself is left unchanged.

    Args:
        som: a fitted map.
        postures: the new postures (n, dim), e.g. the successful grasps of an evaluation, rad.
        epochs: epochs of the resumed learning (the paper: 10).
        learning_rate: (start, end) (the paper: 0.1 -> 0.05).
        sigma: neighbourhood width (start, end), lattice units (the paper: 3 -> 0.7).
        training: the original training postures, for the report's data support.

    Returns:
        The resumed map and {"before": smoothness, "after": smoothness} (`smoothness`).
    """
    before = smoothness(som, training, postures)
    resumed = copy.deepcopy(som).resume(postures, epochs=epochs, learning_rate=learning_rate, sigma=sigma)
    return resumed, {"before": before, "after": smoothness(resumed, training, postures)}


def latent_grid(ukr: UKR, size: int = 6, spread: float = 90.0) -> tuple[np.ndarray, np.ndarray]:
    """Fig. 3 for a continuous manifold: its postures on a size x size grid over the central `spread` percent of the
    training latent points along the first two latent axes (a 1-d manifold: one row; a 3-d one: the third axis at
    its median).

    Args:
        ukr: the fitted manifold.
        size: grid points along an axis.
        spread: percent of the latent points the grid spans along each axis.

    Returns:
        The latent points (rows, size, q) and the postures there (rows, size, dim), rad.
    """
    latent = ukr.latent
    if latent is None:
        raise NotFittedError("the UKR manifold is not fitted yet: call fit first")
    low, high = np.percentile(latent, [50 - spread / 2, 50 + spread / 2], axis=0)
    axes = [np.linspace(low[a], high[a], size) for a in range(latent.shape[1])]
    if latent.shape[1] == 1:
        points = axes[0][None, :, None]
    else:
        rows, cols = np.meshgrid(axes[1], axes[0], indexing="ij")
        rest = np.broadcast_to(np.median(latent[:, 2:], axis=0), (size, size, latent.shape[1] - 2))
        points = np.concatenate([cols[..., None], rows[..., None], rest], axis=2)
    return points, ukr.manifold(points.reshape(-1, latent.shape[1])).reshape(*points.shape[:2], -1)


def latent_path(ukr: UKR, start: np.ndarray, end: np.ndarray, steps: int = 6) -> dict:
    """Fig. 5 for a continuous manifold: postures along the straight latent path between two latent points (two
    clusters' centres), with the steps between neighbours and whether each inner posture is intermediate (closer to
    each end than the ends are to each other: `border_measures`' rule).

    Args:
        ukr: the fitted manifold.
        start: (q,) a latent point.
        end: (q,) another.
        steps: postures along the path, ends included (>= 3).

    Returns:
        {latent (steps, q), postures (steps, dim) rad, steps_deg (steps - 1,), intermediate (steps - 2,) bool,
        support (steps,): the latent distance to the nearest training latent point (kernel bandwidths)}.
    """
    points = np.linspace(np.asarray(start, dtype=float), np.asarray(end, dtype=float), steps)
    postures = ukr.manifold(points)
    span = np.linalg.norm(postures[0] - postures[-1])
    return {"latent": points, "postures": postures,
            "steps_deg": np.degrees(np.linalg.norm(np.diff(postures, axis=0), axis=1)),
            "intermediate": np.array([np.linalg.norm(p - postures[0]) < span and np.linalg.norm(p - postures[-1]) < span
                                      for p in postures[1:-1]]),
            "support": cKDTree(ukr.latent).query(points)[0]}
