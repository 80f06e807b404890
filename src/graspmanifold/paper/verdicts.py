"""A verdict per claim of the paper: its value, ours, and a stated rule that decides between them.

Each claim of the paper's Section 5 that a run can check is judged from the run's summary
(`summary.summarize`) by one rule, object by object where the claim is about every map; a claim
holds as *reproduced* when the rule holds for every object, *partly* when for some, *not
reproduced* when for none. Where the cause of a miss is measured, the verdict names it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

from ..base.paper_numbers import (
    DATASET_SIZES as PAPER_DATASET_SIZES,
    FIGURE_OBJECT,
    MAX_DISTANCE_DEG as PAPER_MAX_DISTANCE_DEG,
    MIN_DISTANCE_DEG as PAPER_MIN_DISTANCE_DEG,
)
from ..trials.stats import wilson_interval

REPRODUCED, PARTLY, NOT_REPRODUCED = "reproduced", "partly", "not reproduced"
#: the verdict of a claim about maps when every map was trained on fewer postures than it has nodes
NOT_ENOUGH_DATA = "not enough data"

MIN_DISTANCE_FACTOR = 3.0  # the minimum inter-node distance agrees within this factor
MAX_DISTANCE_TOLERANCE = 0.2  # the maximum agrees within 20 %
#: "much larger than on average": unsupported nodes' mean distance to their neighbours at least twice the
#: supported nodes'
BORDER_FACTOR = 2.0
#: Fig. 5 "interpolates nicely": no step along a run is more than this share of the map's largest
#: inter-node distance (a jump), and the largest step is at most FIG5_STEP_RATIO times the smallest
FIG5_STEP_SHARE = 0.5
FIG5_STEP_RATIO = 3.0
#: Fig. 6 "mainly": the share's 95 % Wilson interval lies above this
MAINLY = 0.5


@dataclass(frozen=True)
class Verdict:
    """One claim of the paper, judged."""

    claim: str
    paper: str
    ours: str
    verdict: str
    rule: str
    cause: str = ""


def _overall(passed: list[bool]) -> str:
    return REPRODUCED if passed and all(passed) else PARTLY if any(passed) else NOT_REPRODUCED


def _per_object(objects: dict[str, dict], test: Callable[[str, dict], bool]) -> tuple[str, list[str]]:
    """The verdict over the objects with enough data (a map trained on fewer postures than it has nodes
    says nothing about the claim), and the objects that miss."""
    judged = {name: o for name, o in objects.items() if not o.get("low_data")}
    if not judged:
        return NOT_ENOUGH_DATA, []
    passed = {name: test(name, o) for name, o in judged.items()}
    return _overall(list(passed.values())), [name for name, ok in passed.items() if not ok]


def _fmt(value: float) -> str:
    return f"{value:.3g}"


def _name(name: str, o: dict) -> str:
    """An object's name in the 'ours' column, marked where its map had too little data to judge."""
    return f"{name} (low data)" if o.get("low_data") else name


def _clusters(o: dict) -> str:
    """How many starting postures left data in the experience, and how far apart their clusters lie."""
    with_data, between = o["clusters"]["starts"], o["clusters"]["between_deg"]
    apart = f", cluster means {_fmt(between)}° apart" if between == between else ""
    return f"{with_data} of {o.get('starting_postures', '?')} starting postures kept grasps{apart}"


def _share(k: int, n: int) -> str:
    if not n:
        return "no grasps"
    low, high = wilson_interval(k, n)
    return f"{100 * k / n:.0f} % [{100 * low:.0f}, {100 * high:.0f}] of {n}"


@dataclass(frozen=True)
class _Run:
    """What the rules read of a run's summary."""

    objects: dict[str, dict]
    paper_objects: dict[str, dict]  # the objects the paper reports numbers for
    figure: str  # the object of the figures that show one map
    fig5: dict | None

    @property
    def figure_summary(self) -> dict | None:
        """The summary of the figure object, None when the run did not include it."""
        return self.objects.get(self.figure)


def _dataset_sizes(run: _Run) -> Verdict | None:
    """Section 5: the experience holds the paper's number of postures."""
    objects, paper_objects = run.objects, run.paper_objects
    if not paper_objects:
        return None
    verdict, missed = _per_object({n: {**o, "low_data": False} for n, o in paper_objects.items()},
                                  lambda n, o: o["dataset_size"] >= PAPER_DATASET_SIZES[n])
    return Verdict(
        "dataset sizes (Section 5)", ", ".join(f"{n} {PAPER_DATASET_SIZES[n]}" for n in paper_objects),
        ", ".join(f"{n} {o['dataset_size']} of {o['candidates']} candidates" for n, o in paper_objects.items()),
        verdict, "every object's experience holds at least the paper's number of postures",
        "" if not missed else "; ".join(
            f"{n}: the verification kept {objects[n]['dataset_size']} of {objects[n]['candidates']} candidates"
            if objects[n]["candidates"] >= PAPER_DATASET_SIZES[n] else
            f"{n}: {objects[n]['candidates']} candidates were asked for (ReproduceConfig.postures)" for n in missed))


def _minimum_distance(run: _Run) -> Verdict | None:
    """Section 5: the smallest inter-node distance of each map."""
    objects, paper_objects = run.objects, run.paper_objects
    if not paper_objects:
        return None

    def min_ok(n: str, o: dict) -> bool:
        ratio = o["map"]["distance_min_deg"] / PAPER_MIN_DISTANCE_DEG[n]
        return 1 / MIN_DISTANCE_FACTOR <= ratio <= MIN_DISTANCE_FACTOR

    verdict, missed = _per_object(paper_objects, min_ok)
    return Verdict(
        "minimum inter-node distance (°)", ", ".join(f"{n} {PAPER_MIN_DISTANCE_DEG[n]}" for n in paper_objects),
        ", ".join(f"{_name(n, o)} {_fmt(o['map']['distance_min_deg'])} "
                  f"({_fmt(o['map']['distance_min_deg'] / PAPER_MIN_DISTANCE_DEG[n])}x the paper's)"
                  for n, o in paper_objects.items()),
        verdict, f"within a factor {MIN_DISTANCE_FACTOR:g} of the paper's for every object",
        "" if not missed else "the smallest inter-node distance follows the densest clump of near-identical "
        "training postures; our closest pair of training postures is " + ", ".join(
            f"{n} {_fmt(objects[n]['nearest_neighbour_deg']['min'])}°" for n in missed)
        + " apart (denser recording moves the minimum towards the paper's: docs/studies/data_character.md)")


def _maximum_distance(run: _Run) -> Verdict | None:
    """Section 5: the largest inter-node distance of each map."""
    objects, paper_objects = run.objects, run.paper_objects
    if not paper_objects:
        return None
    verdict, missed = _per_object(paper_objects, lambda n, o: abs(
        o["map"]["distance_max_deg"] / PAPER_MAX_DISTANCE_DEG[n] - 1) <= MAX_DISTANCE_TOLERANCE)
    return Verdict(
        "maximum inter-node distance (°)", ", ".join(f"{n} {PAPER_MAX_DISTANCE_DEG[n]}" for n in paper_objects),
        ", ".join(f"{_name(n, o)} {_fmt(o['map']['distance_max_deg'])} "
                  f"({o['map']['distance_max_deg'] / PAPER_MAX_DISTANCE_DEG[n] - 1:+.0%})"
                  for n, o in paper_objects.items()),
        verdict, f"within {MAX_DISTANCE_TOLERANCE:.0%} of the paper's for every object",
        "" if not missed else "the largest distance spans the widest gap between clusters of training data, and "
        "our clusters are few and close: " + "; ".join(f"{n}: {_clusters(objects[n])}" for n in missed)
        + " (docs/studies/data_character.md)")


def _borders(run: _Run) -> Verdict | None:
    """Section 5, Figs. 3 and 4: clusters and their borders are visible."""
    objects = run.objects
    verdict, missed = _per_object(objects, lambda n, o: o["border_distance_ratio"] >= BORDER_FACTOR)
    return Verdict(
        "clusters and borders visible: nodes without training data lie much farther from their neighbours "
        "(Section 5, Figs. 3, 4)", "much larger than on average",
        ", ".join(f"{_name(n, o)} {_fmt(o['border_distance_ratio'])}x" for n, o in objects.items()), verdict,
        f"mean inter-node distance of nodes without training data at least {BORDER_FACTOR:g}x that of nodes with data")


def _fig5_interpolation(run: _Run) -> Verdict | None:
    """Fig. 5: nodes without data interpolate between the clusters."""
    objects, border = run.objects, run.fig5
    if border is None:
        return None
    largest = objects[border["object"]]["map"]["distance_max_deg"]
    runs = border["runs"]
    crossing = bool(runs) and all(run["crosses_unsupported"] for run in runs)
    jumps = [max(run["steps_deg"]) for run in runs if max(run["steps_deg"]) > FIG5_STEP_SHARE * largest
             or max(run["steps_deg"]) > FIG5_STEP_RATIO * min(run["steps_deg"])]
    smooth = [all(run["middle_intermediate"]) and max(run["steps_deg"]) <= FIG5_STEP_SHARE * largest
              and max(run["steps_deg"]) <= FIG5_STEP_RATIO * min(run["steps_deg"]) for run in runs]
    if objects[border["object"]].get("low_data"):
        verdict = NOT_ENOUGH_DATA
    else:
        verdict = _overall(smooth) if crossing else NOT_REPRODUCED
    cause = ("the map has no 1 x 4 run whose ends carry data and whose middle does not" if not crossing else
             "a step of " + ", ".join(f"{j:.0f}°" for j in jumps) + " jumps across the border instead of "
             f"interpolating (the map's largest distance is {largest:.0f}°)" if jumps else "")
    return Verdict(
        "unsupported inter-cluster nodes interpolate between cluster nodes (Fig. 5)", "interpolate nicely",
        f"{border['object']}: steps " + "; ".join(", ".join(f"{s:.0f}°" for s in run["steps_deg"]) for run in runs)
        + f" (the map's largest distance {largest:.0f}°)", verdict,
        f"both runs cross a cluster border through nodes without data, each middle node lies closer to each end "
        f"than the ends lie to each other, no step exceeds {FIG5_STEP_SHARE:.0%} of the map's largest inter-node "
        f"distance, and within a run the largest step is at most {FIG5_STEP_RATIO:g}x the smallest",
        "" if verdict == REPRODUCED else cause)


def _others(texts: list[str]) -> str:
    """'; other objects: ' and the texts, or nothing when the run has no other object."""
    return "; other objects: " + ", ".join(texts) if texts else ""


def _fig6_matches(run: _Run) -> Verdict | None:
    """Fig. 6: the evaluation grasps match mainly inter-cluster nodes."""
    objects, figure, o = run.objects, run.figure, run.figure_summary
    if o is None:
        return None
    k, n = o.get("force_closure_on_unsupported", [0, 0])
    mainly = n > 0 and wilson_interval(k, n)[0] > MAINLY
    return Verdict(
        "evaluation grasps match mainly inter-cluster nodes (Fig. 6)", f"mainly ({FIGURE_OBJECT})",
        f"{figure}: {_share(k, n)} force-closure grasps of the SOM controller" + _others([
            f"{name} {_share(*objects[name].get('force_closure_on_unsupported', [0, 0]))}"
            for name in objects if name != figure]),
        NOT_ENOUGH_DATA if o.get("low_data") else REPRODUCED if mainly else NOT_REPRODUCED,
        f"on the figure's object, the 95 % Wilson interval of the share of the SOM controller's force-closure "
        f"grasps (epsilon > 0.01, as the caption counts) whose best match is a node without training data lies "
        f"above {MAINLY:.0%}")


def _fig6_winners(run: _Run) -> Verdict | None:
    """Section 5, Fig. 6: while the controller runs, inter-cluster nodes win more often."""
    figure, o = run.figure, run.figure_summary
    if o is None or o.get("control_winners") is None:
        return None
    winners = o["control_winners"]
    trials, mostly = winners["trials"], winners["mainly_unsupported"]
    more_often = trials > 0 and wilson_interval(mostly, trials)[0] > MAINLY
    return Verdict(
        "while the controller runs, inter-cluster nodes are more often winners than cluster nodes "
        "(Section 5, Fig. 6)", f"more often winners ({FIGURE_OBJECT})",
        f"{figure}: {_share(mostly, trials)} trials of the SOM controller mostly on nodes without training "
        f"data; {_share(winners['winners_unsupported'], winners['winners'])} per-cycle winners, on "
        f"{winners['unsupported_nodes']} of {winners['nodes']} nodes",
        NOT_ENOUGH_DATA if o.get("low_data") or not trials else REPRODUCED if more_often else NOT_REPRODUCED,
        f"on the figure's object, the 95 % Wilson interval of the share of the SOM controller's trials whose "
        f"per-cycle best-match winners (the matches it used) lie mostly (over half) on nodes without training "
        f"data lies above {MAINLY:.0%} (a trial is the unit: the cycles of one grasp are not independent)")


def _fig7_smooth(run: _Run) -> Verdict | None:
    """Fig. 7: after resumed learning the map is very smooth."""
    figure, o = run.figure, run.figure_summary
    if o is None:
        return None
    resumed = o["resumed_map"]
    return Verdict(
        "after resumed learning the map is very smooth (Fig. 7)", "very smooth",
        f"{figure}: mean inter-node distance {_fmt(o['map']['distance_mean_deg'])} → "
        f"{_fmt(resumed['distance_mean_deg'])}°" if "distance_mean_deg" in o["map"] else f"{figure}: –",
        NOT_ENOUGH_DATA if o.get("low_data") else REPRODUCED
        if resumed.get("distance_mean_deg", 0) < o["map"].get("distance_mean_deg", 0) else NOT_REPRODUCED,
        "on the figure's object, the mean distance between neighbouring nodes falls")


def _fig8a_homogeneous(run: _Run) -> Verdict | None:
    """Fig. 8a: resumed learning homogenises the inter-node distances."""
    objects, figure, o = run.objects, run.figure, run.figure_summary
    if o is None:
        return None
    resumed = o["resumed_map"]
    return Verdict(
        "resumed learning homogenises the inter-node distances (Fig. 8a)", "very homogeneous",
        f"{figure}: CV {_fmt(o['map']['distance_cv'])} → {_fmt(resumed['distance_cv'])}, max "
        f"{_fmt(o['map']['distance_max_deg'])} → {_fmt(resumed['distance_max_deg'])}°"
        + _others([f"{name} CV {_fmt(p['map']['distance_cv'])} → {_fmt(p['resumed_map']['distance_cv'])}"
                   for name, p in objects.items() if name != figure]),
        NOT_ENOUGH_DATA if o.get("low_data") else REPRODUCED
        if resumed["distance_cv"] < o["map"]["distance_cv"]
        and resumed["distance_max_deg"] < o["map"]["distance_max_deg"] else NOT_REPRODUCED,
        "on the figure's object, the coefficient of variation and the maximum of the inter-node distances "
        "both fall")


def _fig8b_more_unsupported(run: _Run) -> Verdict | None:
    """Fig. 8b: after resumed learning more nodes lack training data."""
    objects = run.objects
    verdict, _ = _per_object(objects, lambda n, o: o["resumed_map"]["unsupported_by_training"]
                             > o["map"]["unsupported_by_training"])
    return Verdict(
        "after resumed learning more nodes lack original training data (Fig. 8b)", "more nodes",
        ", ".join(f"{_name(n, o)} {o['map']['unsupported_by_training']} → {o['resumed_map']['unsupported_by_training']}"
                  for n, o in objects.items()), verdict,
        "the number of nodes without training data rises (holds almost by construction: training on other "
        "postures moves nodes away from the original data)")


def _fig8c_evaluation(run: _Run) -> Verdict | None:
    """Fig. 8c: the resumed map represents the evaluation postures better."""
    objects = run.objects
    verdict, _ = _per_object(objects, lambda n, o: o["resumed_map"].get("unsupported_by_evaluation", 0)
                             < o["map"].get("unsupported_by_evaluation", 0))
    return Verdict(
        "the resumed map represents the evaluation postures better (Fig. 8c)", "better",
        ", ".join(f"{_name(n, o)} {o['map'].get('unsupported_by_evaluation', '–')} → "
                  f"{o['resumed_map'].get('unsupported_by_evaluation', '–')} nodes without evaluation data"
                  for n, o in objects.items()),
        verdict, "the number of nodes without evaluation data falls (holds almost by construction: the map is "
                 "trained on those very postures)")


#: one rule per claim, in the order of the verdict table; a rule returns None where the run cannot judge it
CLAIMS: tuple[Callable[[_Run], Verdict | None], ...] = (
    _dataset_sizes, _minimum_distance, _maximum_distance, _borders, _fig5_interpolation, _fig6_matches,
    _fig6_winners, _fig7_smooth, _fig8a_homogeneous, _fig8b_more_unsupported, _fig8c_evaluation)


def judge_claims(summary: dict) -> list[Verdict]:
    """The verdict table of a run from its summary (`summary.json`), one rule (`CLAIMS`) per claim.

    Claims about every map are judged per object (an object whose map had fewer training postures than
    nodes is left out and marked "low data"); the claims the paper makes about its figure object (the
    cylinder: Figs. 5-8) are judged on that object alone.

    Args:
        summary: the run's summary, as `summary.json` holds it.

    Returns:
        The verdicts, in the order of `CLAIMS`.
    """
    objects: dict[str, dict] = summary["objects"]
    run = _Run(objects, {n: o for n, o in objects.items() if n in PAPER_DATASET_SIZES},
               summary.get("figure_object") or (summary.get("fig5") or {}).get("object") or next(iter(objects)),
               summary.get("fig5"))
    return [verdict for rule in CLAIMS if (verdict := rule(run)) is not None]


def verdict_rows(verdicts: list[Verdict]) -> list[dict]:
    """Plain dictionaries for summary.json."""
    return [asdict(v) for v in verdicts]
