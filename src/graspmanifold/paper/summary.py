"""The summary of a `reproduce` run, typed: every number the report and the verdicts read, computed
from the files the run wrote (`report.RunData`), beside the paper's. `summary.json` is its `to_json()`;
the report only writes it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..base.io import library_version
from ..base.paper_numbers import (
    DATASET_SIZES as PAPER_DATASET_SIZES,
    MAX_DISTANCE_DEG as PAPER_MAX_DISTANCE_DEG,
    MIN_DISTANCE_DEG as PAPER_MIN_DISTANCE_DEG,
)
from ..manifold.analysis import border_measures, border_runs, nearest_neighbour_deg, node_distances, smoothness
from ..manifold.som import SOM
from ..manifold.ukr import UKR
from ..trials.evaluation import EvaluationResult
from ..trials.experience_pays import comparison_rows, judge_target
from .report import BLEND_METHODS, UKR_METHODS, RunData, figure_object
from .verdicts import judge_claims, verdict_rows


@dataclass
class ObjectSummary:
    """One object of a run: its experience, its map before and after resumed learning, the paper's values.

    Attributes:
        dataset_size: postures the map was trained on.
        paper_dataset_size: the paper's (None for an object the paper did not use).
        candidates: the spring generator's candidates they were taken from.
        acceptance_ratio: candidates per placement tried.
        clusters: how many starting postures left data, and how far apart their clusters lie (degrees).
        starting_postures: starting postures of the generator.
        nearest_neighbour_deg: distances of training postures to their nearest other one, degrees.
        map: `analysis.smoothness` of the map.
        resumed_map: the same after resumed learning.
        paper_min_distance_deg: the paper's smallest inter-node distance, degrees.
        paper_max_distance_deg: the paper's largest, degrees.
        border_distance_ratio: mean inter-node distance of nodes without training data over that of nodes with.
        successful_som_postures: force-closure grasps of the SOM controller (resumed learning's data).
        evaluation_on_unsupported_nodes: of those, how many best-match a node without training data.
        supported_nodes: nodes with training data.
        force_closure_on_unsupported: [k, n]: of the n force-closure grasps, k match a node without training data (Fig. 6).
        control_winners: the SOM controller's per-cycle best matches against the training support (None: not recorded).
        low_data: the map had fewer training postures than nodes (its verdicts are void).
    """

    dataset_size: int
    paper_dataset_size: int | None
    candidates: int
    acceptance_ratio: float | None
    clusters: dict
    starting_postures: int
    nearest_neighbour_deg: dict
    map: dict
    resumed_map: dict
    paper_min_distance_deg: float | None
    paper_max_distance_deg: float | None
    border_distance_ratio: float
    successful_som_postures: int
    evaluation_on_unsupported_nodes: object
    supported_nodes: int
    force_closure_on_unsupported: list[int]
    control_winners: dict | None
    low_data: bool


@dataclass
class RunSummary:
    """A run's summary: what `summary.json` holds, in its order.

    Attributes:
        library_version: the library that made the run.
        procedure: how the training postures were made (`reproduce.PROCEDURES`).
        objects: per object, its `ObjectSummary`.
        evaluation: every evaluation's summary (`EvaluationResult.summary`).
        figures: what the figures stage drew.
        figure_object: the object of the figures that show one map.
        fig5: the border runs of Fig. 5 on that object.
        comparisons: the paired comparisons of the experience-based methods against the plain controller.
        verdict: does experience beat the plain controller (`study.judge_target`).
        claims: the verdict per claim of the paper (`verdicts.judge_claims`).
        manifolds: a `--experience ukr` run's UKR manifolds per object: their fit and resumed learning.
        manifold_comparisons: each UKR method against the SOM method of the same data on the same poses.
    """

    library_version: str
    procedure: str
    objects: dict[str, ObjectSummary]
    evaluation: list[dict]
    figures: dict
    figure_object: str
    fig5: dict
    comparisons: list[dict]
    verdict: str
    claims: list[dict]
    manifolds: dict = field(default_factory=dict)
    manifold_comparisons: list[dict] = field(default_factory=list)

    def to_json(self) -> dict:
        """The summary as plain data, as `summary.json` holds it.

        Returns:
            The dictionary.
        """
        return asdict(self)


def _mean_ratio(numerator: np.ndarray, denominator: np.ndarray) -> float:
    """mean(numerator) / mean(denominator); NaN when either is empty or the denominator's mean is 0
    (a map collapsed onto identical training data has no distances to compare)."""
    if not len(numerator) or not len(denominator) or denominator.mean() == 0:
        return float("nan")
    return float(numerator.mean() / denominator.mean())


def _on_unsupported(som: SOM, hits: np.ndarray, postures: np.ndarray) -> list[int]:
    """[k, n]: of n postures, k best-match a node that no training posture supports."""
    if not len(postures):
        return [0, 0]
    winners = som.best_match_batch(postures)
    return [int(np.sum(hits.ravel()[winners] == 0)), int(len(postures))]


def _control_winners(result: EvaluationResult, hits: np.ndarray) -> dict | None:
    """The SOM controller's per-cycle best-match winners (`Trial.winners`) against the map's training
    support `hits`: over the valid trials that matched at all, how many had mostly (over half) winners
    without training data, and over all winners, how many lack it; None when the trials did not record them."""
    if any(t.winners is None for t in result.trials):
        return None
    unsupported = hits.ravel() == 0
    trials = [t.winners for t in result.trials if t.valid and t.winners is not None and len(t.winners)]
    events = np.concatenate([np.zeros(0, dtype=int), *trials])
    return {"trials": len(trials), "mainly_unsupported": int(sum(unsupported[w].mean() > 0.5 for w in trials)),
            "winners": int(len(events)), "winners_unsupported": int(unsupported[events].sum()),
            "unsupported_nodes": int(unsupported.sum()), "nodes": int(len(unsupported))}


def summarize(run: RunData, figure_info: dict) -> RunSummary:
    """Every number of a run, beside the paper's, and the verdicts they give.

    Args:
        run: what the run produced.
        figure_info: what the figures stage drew.

    Returns:
        The summary.
    """
    names = list(run.sets)
    objects = {}
    for name in names:
        postures = run.sets[name]
        successes = run.results[(name, "som")].successful_postures()
        before = smoothness(run.maps[name], postures.postures, successes if len(successes) else None)
        after = smoothness(run.resumed[name], postures.postures, successes if len(successes) else None)
        hits = run.maps[name].hit_counts(postures.postures)
        distance = node_distances(run.maps[name])
        objects[name] = ObjectSummary(
            dataset_size=len(postures), paper_dataset_size=PAPER_DATASET_SIZES.get(name),
            candidates=postures.metadata.get("candidates", len(postures)),
            acceptance_ratio=postures.metadata.get("acceptance_ratio"),
            clusters=postures.cluster_separation(), starting_postures=len(postures.start_names),
            nearest_neighbour_deg=nearest_neighbour_deg(postures.postures),
            map=before, resumed_map=after,
            paper_min_distance_deg=PAPER_MIN_DISTANCE_DEG.get(name),
            paper_max_distance_deg=PAPER_MAX_DISTANCE_DEG.get(name),
            border_distance_ratio=_mean_ratio(distance[hits == 0], distance[hits > 0]),
            successful_som_postures=int(len(successes)),
            evaluation_on_unsupported_nodes=before.get("evaluation_on_unsupported_nodes"),
            supported_nodes=int(np.sum(hits > 0)),
            # Fig. 6 as the paper's caption counts: the force-closure grasps of the SOM controller, and how
            # many of them best-match a node without training data
            force_closure_on_unsupported=_on_unsupported(run.maps[name], hits,
                                                         run.results[(name, "som")].successful_postures(False)),
            # "more often winners" while the controller runs: its per-cycle best matches
            control_winners=_control_winners(run.results[(name, "som")], hits),
            low_data=bool(len(postures) < run.maps[name].n_nodes),  # fewer postures than nodes: verdicts void
        )
    obj = figure_object(names)
    obj_hits = run.maps[obj].hit_counts(run.sets[obj].postures)
    keyed = {(o, run.results[(o, m)].grid_name, m): r for (o, m), r in run.results.items()}
    rows = comparison_rows(keyed, ("database", "som", "som_all", *UKR_METHODS, *BLEND_METHODS), ("none",))
    summary = RunSummary(
        library_version=library_version(), procedure=run.config.get("procedure", "paper"), objects=objects,
        evaluation=[dict(result.summary) for result in run.results.values()], figures=figure_info, figure_object=obj,
        fig5={"object": obj, "runs": border_measures(run.maps[obj], obj_hits, border_runs(run.maps[obj], obj_hits))},
        comparisons=rows, verdict=judge_target(rows).text, claims=[])
    summary.claims = verdict_rows(judge_claims(summary.to_json()))
    if run.manifolds:
        summary.manifolds = {name: _manifold_summary(run.manifolds[name], run.resumed_manifolds.get(name))
                             for name in run.manifolds}
        summary.manifold_comparisons = [*comparison_rows(keyed, ("ukr",), ("som",)),
                                        *comparison_rows(keyed, ("ukr_all",), ("som_all",))]
    return summary


def _manifold_summary(ukr: UKR, resumed: UKR | None) -> dict:
    """A UKR manifold's fit (its start, leave-one-out errors) and its resumed learning."""
    fit = ukr.history[0]
    assert ukr.postures is not None  # a fitted manifold's
    out = {"postures": len(ukr.postures), "latent_dim": ukr.latent_dim, "start": fit.get("start"),
           "scale": fit.get("scale"), "loo_start": fit.get("loo_start"), "loo": fit.get("loo")}
    if resumed is not None and resumed.postures is not None:
        out |= {"resumed_postures": len(resumed.postures) - len(ukr.postures), "loo_resumed": resumed.loo_error()}
    return out
