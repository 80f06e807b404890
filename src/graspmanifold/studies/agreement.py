"""How far a published run's results move on this machine: a sample of its trials run again.

    python scripts/check_agreement.py [--run docs/studies/verified_run] [--sample 30] [--seed 0]
                                      [--compare docs/studies/agreement.json] [--workers 2] [--out study_agreement]
                                      [--doc docs/studies/agreement.md]

The published run's plain tactile controller (its method `none`: no experience, so nothing but the run's
configuration, its run.json, is needed) on a seeded sample of `--sample` poses of its grid for each object, judged
as the run judged them. The report gives this machine and its libraries beside the run's; each object's hold rate on
the sample (Wilson 95 %) beside the run's published rate over its whole grid, and whether the published rate lies in
the sample's interval; and, with `--compare FILE` (the `agreement.json` of this check run on another machine, e.g.
the one committed in docs/), the poses whose outcome (held, force closure) differs between the two machines and the
largest difference of epsilon and of the final posture. Every run writes its own `agreement.json` (the sampled
poses, their outcomes, the machine) into `--out`, which another machine compares with.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..base.checkpoints import result_key
from ..base.errors import InvalidInput
from ..base.io import json_text, markdown_table, read_json, software_versions, write_text_atomic
from ..base.validation import check_input_file
from ..judging.protocols import get_protocol
from ..paper.reproduce import ReproduceConfig
from ..sim.objects import get_object
from ..trials.evaluation import evaluate
from ..trials.grid import check_grid
from ..trials.stats import rate_text, wilson_interval
from .runner import StudyRun, run_command

#: the published run the check samples by default, in a checkout (`reproduce --preset verified`, docs/studies/results.md)
PUBLISHED = Path("docs") / "studies" / "verified_run"


def published_run(folder: str | Path) -> tuple[ReproduceConfig, dict, dict]:
    """A published run's configuration, the versions it ran with and its rates of the plain controller.

    Args:
        folder: the run's folder (with run.json and summary.json, as `reproduce` writes them).

    Returns:
        The configuration, its run.json's versions, and {object: {"rate", "n"}} of method `none` on the run's grid.
    """
    folder = Path(folder)
    record = read_json(folder / "run.json", "the run's run.json")
    summary = read_json(folder / "summary.json", "the run's summary.json")
    config = ReproduceConfig.from_json(record["config"])
    rates = {row["object"]: {"rate": row["hold_rate"], "n": row["trials"]} for row in summary["evaluation"]
             if row["method"] == "none"}
    return config, record.get("versions", {}), rates


def sample(config: ReproduceConfig, name: str, size: int, seed: int) -> np.ndarray:
    """`size` poses of the run's grid for an object, drawn without replacement by `seed` (sorted by their index)."""
    poses = check_grid(config.grid, get_object(name))[1]
    chosen = np.sort(np.random.default_rng([seed, sum(name.encode())]).choice(len(poses), min(size, len(poses)),
                                                                            replace=False))
    return poses[chosen]


def compared(mine: dict, theirs: dict) -> dict:
    """Per object: the poses both runs sampled, how many outcomes differ and the largest value differences."""
    found: dict[str, dict | None] = {}
    for name, ours in mine["objects"].items():
        other = theirs.get("objects", {}).get(name)
        if other is None or np.shape(other["poses"]) != np.shape(ours["poses"]) \
                or not np.allclose(other["poses"], ours["poses"], rtol=0, atol=1e-12):
            found[name] = None
            continue
        differing = [i for i in range(len(ours["hold"]))
                     if ours["hold"][i] != other["hold"][i] or ours["force_closure"][i] != other["force_closure"][i]]
        found[name] = {"n": len(ours["hold"]), "differing": differing,
                       "epsilon": float(np.max(np.abs(np.subtract(ours["epsilon"], other["epsilon"])))),
                       "posture": float(np.max(np.abs(np.subtract(ours["posture"], other["posture"]))))}
    return found


def report(mine: dict, run: Path, versions: dict, rates: dict, comparison: dict | None, theirs: dict | None) -> str:
    """The markdown report."""
    lines = ["# A published run's trials, run again (issue 50)", "",
             f"The plain tactile controller of `{run}` on {mine['sample']} poses of its grid per object (seed "
             f"{mine['seed']}), made by `python scripts/check_agreement.py`.", "",
             f"- the run ran on: {json.dumps(versions)}", f"- this check ran on: {json.dumps(mine['versions'])}"]
    if theirs is not None:
        lines.append(f"- compared with a check that ran on: {json.dumps(theirs.get('versions', {}))}")
    rows = []
    for name, ours in mine["objects"].items():
        held, n = int(np.sum(ours["hold"])), len(ours["hold"])
        low, high = wilson_interval(held, n)
        published = rates.get(name)
        inside = "–" if published is None else ("yes" if low <= published["rate"] <= high else "no")
        other = (comparison or {}).get(name)
        rows.append([name, rate_text(held, n), "–" if published is None else
                     f"{100 * published['rate']:.0f} % of {published['n']}", inside,
                     "–" if other is None else f"{len(other['differing'])} of {other['n']}",
                     "–" if other is None else f"{other['epsilon']:.1e}",
                     "–" if other is None else f"{other['posture']:.1e}"])
    header = ["object", "held on the sample", "published (whole grid)", "published in the interval",
              "outcomes differing", "epsilon, largest difference", "posture, largest difference (rad)"]
    return "\n".join(lines + ["", *markdown_table(header, rows)]) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", default=str(PUBLISHED), help="a published run's folder (run.json, summary.json)")
    parser.add_argument("--sample", type=int, default=30, help="poses per object")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compare", help="the agreement.json of this check run on another machine")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="study_agreement")
    parser.add_argument("--doc", help="also write the report here (e.g. docs/studies/agreement.md)")
    args = parser.parse_args(argv)
    if args.sample < 1:
        parser.error(f"--sample must be a positive number of poses, got {args.sample}")
    try:
        config, versions, rates = published_run(args.run)
        theirs = None if args.compare is None else json.loads(
            check_input_file(Path(args.compare), "--compare").read_text())
    except (InvalidInput, json.JSONDecodeError, KeyError) as error:
        raise SystemExit(f"error: {error}") from None
    study = StudyRun(args.out, workers=args.workers)

    def body() -> None:
        study.check_writable(args.doc)
        mine = {"run": str(args.run), "sample": args.sample, "seed": args.seed, "versions": software_versions(),
                "objects": {}}
        with study.session():
            for name in config.postures:
                poses = sample(config, name, args.sample, args.seed)
                key = result_key(config.to_json(), name, poses, "none")
                result = study.evaluation(f"{name}_none", key, lambda parts: evaluate(
                    name, None, poses, seed=config.seed, workers=study.executor or study.workers,
                    checkpoint_dir=parts, progress=False, method="none", hand=config.hand, params=config.controller,
                    margin=get_protocol(config.protocol).physics is None, protocol=config.protocol))
                mine["objects"][name] = {
                    "poses": poses.tolist(), "hold": result.outcomes("hold").astype(int).tolist(),
                    "force_closure": result.outcomes("force_closure").astype(int).tolist(),
                    "epsilon": [float(t.epsilon) for t in result.trials],
                    "posture": [np.asarray(t.posture, dtype=float).tolist() for t in result.trials]}
                study.log(f"{name}: {rate_text(int(np.sum(mine['objects'][name]['hold'])), len(poses))} held")
        comparison = None if theirs is None else compared(mine, theirs)
        text = report(mine, Path(args.run), versions, rates, comparison, theirs)
        write_text_atomic(study.out / "agreement.json", json_text(mine, indent=None))
        write_text_atomic(study.out / "report.md", text)
        if args.doc:
            write_text_atomic(Path(args.doc), text)
        study.log(f"wrote {study.out / 'report.md'} and {study.out / 'agreement.json'}")

    run_command(study.out, body)
