"""Analyses of SOM grasp manifolds behind the paper's Section 5: smoothness and data support,
before and after resuming the learning with postures from the grasp controller."""

from __future__ import annotations

import copy

import numpy as np

from .som import RESUME, SOM


def smoothness(som: SOM, training: np.ndarray | None = None, evaluation: np.ndarray | None = None
               ) -> dict[str, float | int]:
    """Inter-node distance statistics (degrees over all joints), errors and data support.

    With `training` / `evaluation` postures: quantisation and topographic error on the training
    data, how many nodes no training (evaluation) posture falls on, and which fraction of the
    evaluation postures land on nodes that no training posture supports (the paper's observation
    that evaluation grasps match mainly inter-cluster nodes).
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
    """A copy of `som` trained further on `postures` (the paper's second phase), with the
    smoothness report before and after. `som` itself is left unchanged."""
    before = smoothness(som, training, postures)
    resumed = copy.deepcopy(som).resume(postures, epochs=epochs, learning_rate=learning_rate, sigma=sigma)
    return resumed, {"before": before, "after": smoothness(resumed, training, postures)}
