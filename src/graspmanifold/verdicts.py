"""A verdict per claim of the paper: its value, ours, and a stated rule that decides between them.

Each claim of the paper's Section 5 that a run can check is judged from the run's summary
(`report.write_report`) by one rule, object by object where the claim is about every map; a claim
holds as *reproduced* when the rule holds for every object, *partly* when for some, *not
reproduced* when for none. Where the cause of a miss is measured, the verdict names it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

from .generator import PRESETS

REPRODUCED, PARTLY, NOT_REPRODUCED = "reproduced", "partly", "not reproduced"

#: The paper's numbers (Section 5).
PAPER_DATASET_SIZES = dict(PRESETS["paper"])
PAPER_MIN_DISTANCE_DEG = {"box": 0.013, "cylinder": 0.013, "sphere": 0.007}
PAPER_MAX_DISTANCE_DEG = {"box": 55.06, "cylinder": 63.45, "sphere": 66.23}
MIN_DISTANCE_FACTOR = 3.0  # the minimum inter-node distance agrees within this factor
MAX_DISTANCE_TOLERANCE = 0.2  # the maximum agrees within 20 %
BORDER_FACTOR = 1.5  # "much larger than on average": unsupported nodes' distances at least 1.5x the supported ones'


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
    passed = {name: test(name, o) for name, o in objects.items()}
    return _overall(list(passed.values())), [name for name, ok in passed.items() if not ok]


def _fmt(value: float) -> str:
    return f"{value:.3g}"


def _clusters(o: dict) -> str:
    """How many starting postures left data in the experience, and how far apart their clusters lie."""
    with_data, between = o["clusters"]["starts"], o["clusters"]["between_deg"]
    apart = f", cluster means {_fmt(between)}° apart" if between == between else ""
    return f"{with_data} of {o.get('starting_postures', '?')} starting postures kept grasps{apart}"


def judge_claims(summary: dict) -> list[Verdict]:
    """The verdict table of a run from its summary (`summary.json`)."""
    objects: dict[str, dict] = summary["objects"]
    paper_objects = {n: o for n, o in objects.items() if n in PAPER_DATASET_SIZES}
    verdicts = []

    if paper_objects:
        verdict, missed = _per_object(paper_objects, lambda n, o: o["dataset_size"] >= PAPER_DATASET_SIZES[n])
        verdicts.append(Verdict(
            "dataset sizes (Section 5)", ", ".join(f"{n} {PAPER_DATASET_SIZES[n]}" for n in paper_objects),
            ", ".join(f"{n} {o['dataset_size']} of {o['candidates']} candidates" for n, o in paper_objects.items()),
            verdict, "every object's experience holds at least the paper's number of postures",
            "" if not missed else "fewer postures were asked for than the paper used (ReproduceConfig.postures)"))

        def min_ok(n: str, o: dict) -> bool:
            ratio = o["map"]["distance_min_deg"] / PAPER_MIN_DISTANCE_DEG[n]
            return 1 / MIN_DISTANCE_FACTOR <= ratio <= MIN_DISTANCE_FACTOR

        verdict, missed = _per_object(paper_objects, min_ok)
        verdicts.append(Verdict(
            "minimum inter-node distance (°)", ", ".join(f"{n} {PAPER_MIN_DISTANCE_DEG[n]}" for n in paper_objects),
            ", ".join(f"{n} {_fmt(o['map']['distance_min_deg'])}" for n, o in paper_objects.items()), verdict,
            f"within a factor {MIN_DISTANCE_FACTOR:g} of the paper's for every object",
            "" if not missed else "the smallest inter-node distance follows the densest clump of near-identical "
            "training postures; our closest pair of training postures is " + ", ".join(
                f"{n} {_fmt(objects[n]['nearest_neighbour_deg']['min'])}°" for n in missed)
            + " apart (denser recording moves the minimum towards the paper's: docs/data_character.md)"))

        verdict, missed = _per_object(paper_objects, lambda n, o: abs(
            o["map"]["distance_max_deg"] / PAPER_MAX_DISTANCE_DEG[n] - 1) <= MAX_DISTANCE_TOLERANCE)
        verdicts.append(Verdict(
            "maximum inter-node distance (°)", ", ".join(f"{n} {PAPER_MAX_DISTANCE_DEG[n]}" for n in paper_objects),
            ", ".join(f"{n} {_fmt(o['map']['distance_max_deg'])}" for n, o in paper_objects.items()), verdict,
            f"within {MAX_DISTANCE_TOLERANCE:.0%} of the paper's for every object",
            "" if not missed else "the largest distance spans the widest gap between clusters of training data, and "
            "our clusters are few and close: " + "; ".join(f"{n}: {_clusters(objects[n])}" for n in missed)
            + " (the paper kept every posture of every starting posture; docs/data_character.md)"))

    verdict, missed = _per_object(objects, lambda n, o: o["border_distance_ratio"] >= BORDER_FACTOR)
    verdicts.append(Verdict(
        "clusters and borders visible: nodes without training data lie much farther from their neighbours "
        "(Section 5, Figs. 3, 4)", "much larger than on average",
        ", ".join(f"{n} {_fmt(o['border_distance_ratio'])}x" for n, o in objects.items()), verdict,
        f"mean inter-node distance of nodes without training data at least {BORDER_FACTOR:g}x that of nodes with data"))

    border = summary.get("fig5")
    if border is not None:
        middles = [flag for run in border["runs"] for flag in run["middle_intermediate"]]
        crossing = all(run["crosses_unsupported"] for run in border["runs"])
        verdicts.append(Verdict(
            "unsupported inter-cluster nodes interpolate between cluster nodes (Fig. 5)",
            "interpolate nicely", f"{border['object']}: {sum(middles)} of {len(middles)} middle nodes intermediate; "
            "steps " + "; ".join(", ".join(f"{s:.0f}°" for s in run["steps_deg"]) for run in border["runs"]),
            _overall(middles) if crossing else NOT_REPRODUCED,
            "both runs cross a cluster border through nodes without data, and every middle node lies closer to each "
            "end than the ends lie to each other",
            "" if crossing else "the map has no 1 x 4 run whose ends carry data and whose middle does not"))

    verdict, _ = _per_object(objects, lambda n, o: (o["evaluation_on_unsupported_nodes"] or 0.0) > 0.5)
    verdicts.append(Verdict(
        "evaluation grasps match mainly inter-cluster nodes (Fig. 6)", "mainly (cylinder)",
        ", ".join(f"{n} {_fmt(100 * (o['evaluation_on_unsupported_nodes'] or 0.0))} %" for n, o in objects.items()),
        verdict, "more than half of the successful SOM grasps best-match a node without training data"))

    verdict, _ = _per_object(objects, lambda n, o: o["resumed_map"]["distance_cv"] < o["map"]["distance_cv"]
                             and o["resumed_map"]["distance_max_deg"] < o["map"]["distance_max_deg"])
    verdicts.append(Verdict(
        "resumed learning homogenises the inter-node distances (Fig. 8a)", "very homogeneous",
        ", ".join(f"{n} CV {_fmt(o['map']['distance_cv'])} → {_fmt(o['resumed_map']['distance_cv'])}, max "
                  f"{_fmt(o['map']['distance_max_deg'])} → {_fmt(o['resumed_map']['distance_max_deg'])}°"
                  for n, o in objects.items()),
        verdict, "the coefficient of variation and the maximum of the inter-node distances both fall"))

    verdict, _ = _per_object(objects, lambda n, o: o["resumed_map"]["unsupported_by_training"]
                             > o["map"]["unsupported_by_training"])
    verdicts.append(Verdict(
        "after resumed learning more nodes lack original training data (Fig. 8b)", "more nodes",
        ", ".join(f"{n} {o['map']['unsupported_by_training']} → {o['resumed_map']['unsupported_by_training']}"
                  for n, o in objects.items()), verdict, "the number of nodes without training data rises"))

    verdict, _ = _per_object(objects, lambda n, o: o["resumed_map"].get("unsupported_by_evaluation", 0)
                             < o["map"].get("unsupported_by_evaluation", 0))
    verdicts.append(Verdict(
        "the resumed map represents the evaluation postures better (Fig. 8c)", "better",
        ", ".join(f"{n} {o['map'].get('unsupported_by_evaluation', '–')} → "
                  f"{o['resumed_map'].get('unsupported_by_evaluation', '–')} nodes without evaluation data"
                  for n, o in objects.items()),
        verdict, "the number of nodes without evaluation data falls"))
    return verdicts


def verdict_rows(verdicts: list[Verdict]) -> list[dict]:
    """Plain dictionaries for summary.json."""
    return [asdict(v) for v in verdicts]
