"""Figures and the report of a `reproduce` run, built from the files the run wrote."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..base.config_files import apply_table
from ..base.errors import InvalidInput, RenderingUnavailable
from ..base.io import atomic_write, json_text, markdown_table, read_json, write_text_atomic
from ..base.moved import upgrade_config
from ..base.paper_numbers import DATASET_SIZES as PAPER_DATASET_SIZES, FIGURE_OBJECT
from ..control.controller import BLEND, ControllerParams
from ..control.recall import TargetRecall
from ..judging.judge import JUDGING
from ..judging.protocols import DEFAULT_PROTOCOL, get_protocol
from ..manifold.postureset import PostureSet
from ..manifold.som import RESUME, SOM
from ..manifold.ukr import UKR
from ..sim.hand import SHADOW_HAND
from ..sim.objects import DEFAULT_FRICTION, make_object
from ..trials.evaluation import EvaluationResult, trial_count
from ..trials.grid import GRID_DESCRIPTIONS
from ..trials.stats import holm, rate_text

#: how the report names each hand model (`ReproduceConfig.hand`)
HANDS = {SHADOW_HAND.name: "our MJCF from the published kinematics, primitive collision geometry, 20 position servos",
         "gymnasium-robotics": "Gymnasium-Robotics' Shadow Hand (its MJCF, mapped onto the paper's joints)",
         "gymnasium-robotics-touch": "Gymnasium-Robotics' Shadow Hand with its 92 touch sensors (its MJCF, mapped "
                                     "onto the paper's joints)",
         "menagerie": "MuJoCo Menagerie's right Shadow Hand (its MJCF from MENAGERIE_ROOT, mapped onto the paper's "
                      "joints)"}

#: the evaluation methods of a run (its files are evaluation/<object>_<method>.npz)
RUN_METHODS = ("none", "database", "som", "som_all")
BLEND_METHODS = ("database_blend", "som_blend")  # the database and the SOM under `BLEND`, beside another controller


UKR_METHODS = ("ukr", "ukr_all")  # the UKR manifolds of a run with `--experience ukr`, beside the SOMs


def run_methods(controller: ControllerParams, manifold: str = "som") -> tuple[str, ...]:
    """The evaluation methods of a run with this controller and manifold: `BLEND_METHODS` too beside any controller
    other than `BLEND`, `UKR_METHODS` too with the UKR manifold."""
    return RUN_METHODS + (UKR_METHODS if manifold == "ukr" else ()) + (() if controller == BLEND else BLEND_METHODS)
#: the figures that draw the hand (they need offscreen OpenGL), by the paper's figure number
RENDERED_KINDS = ("fig3", "fig5", "fig7")


def figure_object(objects: list[str]) -> str:
    """The object of the single-map figures (3, 5-8): the cylinder as in the paper, else the run's first."""
    return FIGURE_OBJECT if FIGURE_OBJECT in objects else objects[0]


def figure_names(objects: list[str]) -> tuple[str, ...]:
    """The figures a run over these objects draws."""
    obj = figure_object(objects)
    return (*(f"fig4_{name}" for name in objects), f"fig6_{obj}_evaluation", f"fig8_{obj}_resumed", "rates",
            f"fig3_{obj}_extract", f"fig5_{obj}_border", f"fig7_{obj}_resumed_extract")


@dataclass
class RunData:
    """What a run produced: posture sets, maps, resumed maps and evaluation results."""

    config: dict  # the run's configuration as written to run.json
    sets: dict[str, PostureSet]
    maps: dict[str, SOM]
    resumed: dict[str, SOM]
    results: dict[tuple[str, str], EvaluationResult]
    manifolds: dict[str, UKR] = field(default_factory=dict)  # a `--experience ukr` run's, by object (and "all")
    resumed_manifolds: dict[str, UKR] = field(default_factory=dict)

    @classmethod
    def load(cls, out: str | os.PathLike) -> RunData:
        """Read a finished run's files (postures/, maps/, evaluation/)."""
        out = Path(out)
        if not (out / "run.json").exists():
            raise InvalidInput(f"{out} is not a graspmanifold reproduce run (no run.json)")
        try:
            config = read_json(out / "run.json", "the run's run.json")["config"]
            if not isinstance(config, dict) or not isinstance(config.get("postures"), dict):
                raise TypeError("its config names no objects")
            upgrade_config(config)  # the names a run before 0.2 wrote
        except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError) as error:
            raise InvalidInput(f"{out / 'run.json'} is not a graspmanifold run's record ({type(error).__name__}: "
                             f"{error})") from None
        held = "_held" if config.get("procedure") == "verified" else ""  # the training postures of the procedure
        sets = {name: PostureSet.load(out / "postures" / f"{name}{held}.npz") for name in config["postures"]}
        maps = {p.stem: SOM.load(p) for p in sorted((out / "maps").glob("*.npz")) if not p.stem.endswith("_resumed")}
        resumed = {p.stem[: -len("_resumed")]: SOM.load(p) for p in sorted((out / "maps").glob("*_resumed.npz"))}
        results = {}
        for path in sorted((out / "evaluation").glob("*.npz")):  # each result names its object and method
            result = EvaluationResult.load(path)
            results[(result.object.name, result.method)] = result
        files = sorted((out / "manifolds").glob("*.npz"))
        manifolds = {p.stem: UKR.load(p) for p in files if not p.stem.endswith("_resumed")}
        resumed_manifolds = {p.stem[: -len("_resumed")]: UKR.load(p) for p in files if p.stem.endswith("_resumed")}
        return cls(config, sets, maps, resumed, results, manifolds, resumed_manifolds)


def _figure_builders(run: RunData, render: Callable | None) -> dict[str, Callable]:
    from .figures import (
        border_figure,
        choose_extract,
        cluster_ends,
        distance_scale,
        extract_figure,
        latent_figure,
        lattice_panels,
        rates_figure,
    )

    obj = figure_object(list(run.sets))
    train_hits = {name: run.maps[name].hit_counts(s.postures) for name, s in run.sets.items()}
    successes = run.results[(obj, "som")].successful_postures()
    eval_hits = run.maps[obj].hit_counts(successes) if len(successes) else np.zeros_like(train_hits[obj])
    resumed = run.resumed[obj]
    resumed_train = resumed.hit_counts(run.sets[obj].postures)
    resumed_eval = resumed.hit_counts(successes) if len(successes) else np.zeros_like(resumed_train)
    builders: dict[str, Callable] = {
        f"fig4_{name}": (lambda name=name: lattice_panels(
            run.maps[name], [("a) inter-node distances", None), ("b) training data", train_hits[name])],
            f"Fig. 4: {name} map")) for name in run.sets}
    builders[f"fig6_{obj}_evaluation"] = lambda: lattice_panels(
        run.maps[obj], [("successful evaluation postures", eval_hits)], f"Fig. 6: {obj} map")
    builders[f"fig8_{obj}_resumed"] = lambda: lattice_panels(
        resumed, [("a) inter-node distances", None), ("b) training data", resumed_train),
                  ("c) evaluation postures", resumed_eval)], f"Fig. 8: {obj} map after resumed learning")
    methods = RUN_METHODS + tuple(m for m in (*UKR_METHODS, *BLEND_METHODS) if (obj, m) in run.results)
    builders["rates"] = lambda: rates_figure([r.summary for r in run.results.values()], methods)
    if render is not None:
        corner, scale = choose_extract(run.maps[obj]), distance_scale(run.maps[obj])  # Fig. 7 shares both
        builders[f"fig3_{obj}_extract"] = lambda: extract_figure(run.maps[obj], train_hits[obj], render, corner,
                                                                 title=f"Fig. 3: {obj} map", scale=scale)
        builders[f"fig5_{obj}_border"] = lambda: border_figure(run.maps[obj], train_hits[obj], render,
                                                               "Fig. 5: across cluster borders", scale)
        builders[f"fig7_{obj}_resumed_extract"] = lambda: extract_figure(
            resumed, resumed_train, render, corner, title=f"Fig. 7: {obj} map after resumed learning", scale=scale)
        if obj in run.manifolds:
            ends = cluster_ends(run.manifolds[obj], run.sets[obj].start_ids)
            builders[f"ukr_{obj}_latent"] = lambda: latent_figure(
                run.manifolds[obj], render, *ends, title=f"{obj}: the UKR manifold (Figs. 3 and 5 for a continuous map)")
    return builders


#: the figures of a run over the paper's objects (what `graspmanifold figure` offers by default)
FIGURES = figure_names(list(PAPER_DATASET_SIZES))


def _renderer(run: RunData, image_size: int) -> tuple[Callable | None, str]:
    """Hand pictures for Figs. 3, 5 and 7: each posture in the figure object's scene, seen from the
    thumb side, with the object drawn faintly where the nearest training posture grasped it (a map
    node has no palm pose of its own)."""
    from ..sim.render import THUMB_SIDE, render_postures, render_states
    from ..sim.scene import OBJECT_RGBA, Scene

    try:
        render_postures(np.zeros((1, 22)), 16)
    except RenderingUnavailable as error:
        return None, str(error)
    obj = figure_object(list(run.sets))
    mesh = run.config.get("meshes", {}).get(obj)  # an object of one's own mesh file
    shown = obj if mesh is None else make_object("mesh", mesh=mesh["file"], scale=mesh["scale"], name=obj)
    training, scene = run.sets[obj], Scene(shown, hand=run.config.get("hand", SHADOW_HAND.name))
    for geom in scene.spec.geoms:
        if np.allclose(geom.rgba, OBJECT_RGBA):
            geom.rgba = [0.6, 0.75, 1.0, 0.2]
    nearest = cKDTree(training.postures)
    low, high = scene.hand.limits().T

    def render(postures: np.ndarray) -> np.ndarray:
        states = []
        for posture, k in zip(postures, nearest.query(postures)[1]):
            pose = training.hand_poses[k]
            scene.set_hand_pose(pose[:3], pose[3:])
            scene.set_posture(np.clip(posture, low, high))
            states.append(scene.state())
        return render_states(scene, np.array(states), THUMB_SIDE, image_size, image_size)

    return render, "rendered with MuJoCo's offscreen renderer"


def write_figures(directory: Path, run: RunData, log: Callable[[str], None] = print,
                  only: str | None = None) -> dict:
    """Write every figure (or only one) as PNG and PDF; hand pictures only where OpenGL works."""
    render, message = _renderer(run, run.config["image_size"])
    if render is None:
        log(f"figures: skipping the rendered hand figures: {message}")
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    builders = {name: build for name, build in _figure_builders(run, render).items() if only in (None, name)}
    for number, (name, build) in enumerate(builders.items(), start=1):
        log(f"figures: {name} ({number} of {len(builders)})")
        figure = build()  # a matplotlib Figure, no pyplot: nothing global is touched
        for suffix in ("png", "pdf"):
            with atomic_write(directory / f"{name}.{suffix}") as handle:
                figure.savefig(handle, format=suffix, dpi=110,
                               metadata={"CreationDate": None} if suffix == "pdf" else None)
        written.append(name)
    return {"rendered": render is not None, "message": message, "figures": written}


def _table(header: list[str], rows: Sequence[Sequence[object]]) -> str:
    return "\n".join(markdown_table(header, rows)) + "\n\n"


def write_report(out: Path, run: RunData, summary: dict) -> None:
    """Write a run's summary (summary.json) and report (report.md).

    Args:
        out: the run's folder.
        run: what the run produced.
        summary: its summary as JSON data (`summary.summarize(...).to_json()`).
    """
    write_text_atomic(out / "summary.json", json_text(summary) + "\n")
    write_text_atomic(out / "report.md", _markdown(run, summary))


def _fmt(value: object, digits: int = 3) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.{digits}g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def _choices(run: RunData) -> list[list[str]]:
    """The run's own choices where the paper fixes nothing (or fixes something else), one row each."""
    g, config = run.config["generator"], run.config
    grid, c = config["grid"], _controller_params(config.get("controller"))
    trust = "every match trusted" if c.max_match_distance == float("inf") else f"matches trusted within " \
        f"{c.max_match_distance} rad RMS"
    return [
        ["posture procedure", "every spring candidate with its five fingertips on the object kept"
         if not g.get("verify") and config.get("procedure", "paper") == "paper"
         else f"only candidates that hold when replayed (hold test, {g.get('verify_hold_seconds')} s per direction)",
         "every recorded posture with five fingertip contacts (no verification described)"],
        ["spring generator", f"mode {g.get('mode')}" + (f", a posture every {g.get('record_every')} physics steps"
                                                        if g.get("mode") == "recording" else "")
         + f"; springs {g.get('spring_stiffness')} N/m up to {g.get('spring_max_force')} N on the fingertips; finger "
         f"servos at {g.get('servo_stiffness_scale')} of their stiffness; the hand wanders {100 * g.get('walk_radius', 0):.1f} "
         f"cm and {g.get('walk_angle')} rad around designed starting postures",
         "springs to the object, the hand moved by hand around manually set starting postures"],
        ["SOM training", f"{config['epochs']} epochs, learning rate {config['learning_rate'][0]} → "
         f"{config['learning_rate'][1]}, σ {config['sigma'][0]} → {config['sigma'][1]}, both decaying exponentially; "
         "initialised on the principal components; a fresh random order every epoch",
         "the same numbers; decay, initialisation and order not given"],
        ["resumed learning", f"{RESUME.epochs} epochs, learning rate {RESUME.learning_rate[0]} → "
         f"{RESUME.learning_rate[1]}, σ {RESUME.sigma[0]} → {RESUME.sigma[1]}, on the successful SOM grasps "
         "(hold test)", "the same numbers, on the grasp postures generated in testing"],
        ["evaluation grid", f"`{grid}` preset: " + GRID_DESCRIPTIONS.get(grid, "a custom grid") if isinstance(grid, str)
         else f"{len(grid)} custom poses", "a regular position/orientation grid, values not given"],
        ["controller", f"{1 / c.control_period:.0f} Hz; preshape {c.preshape_time} s; closing rate {c.closing_rate}/s; "
         f"follow speed {c.follow_speed}x; squeeze {c.squeeze} rad; release {c.release_time} s; stable "
         f"{c.stable_time} s; timeout {c.timeout} s; {trust}; the hand model's keyframes `open` and `closed`",
         "described in [15], not given"],
        ["recalled posture (Section 2, Eq. 2)", "`recall='target'`: the free fingers' target, reached at the "
         f"heuristic's joint speed; a finger closes on from it once within {c.recall.tolerance} rad of it (or at "
         "rest short of it, no contact), its closure from 0; phase B matches the whole posture; each recall at most "
         "once per finger; a finger that lost its contact closes on from where it held; `_blend` methods: `BLEND`"
         if isinstance(c.recall, TargetRecall) and c.recall.name == "target"
         else "`recall='base'` (the blend): the heuristic's base, goal = match + c (closed "
         "- match), c grown since phase B began", "\"acts as the target posture for the current control cycle\"; a "
         "generic closing heuristic finalises the grasp"],
        ["object support while the hand closes", f"a spring-damper, {JUDGING.support_stiffness:g} N/m and {JUDGING.support_damping:g} "
         "N s/m, released before judging", "not described"],
        ["success", get_protocol(config.get("protocol", DEFAULT_PROTOCOL)).summary(), "force closure: ε > 0"],
        ["friction", f"{DEFAULT_FRICTION} for every hand-object contact and for ε", "not given (Vortex)"],
        ["hand", HANDS.get(run.config.get("hand", SHADOW_HAND.name), f"the Shadow Hand of the MJCF file {run.config.get('hand')}"),
         "a model of the Shadow hand in Vortex, coarse geometry"],
    ]


def _controller_params(stored: dict | None) -> ControllerParams:
    """A run's controller from its run.json (one written before the choice of controller ran `BLEND`)."""
    if stored is None:
        return BLEND
    return apply_table(ControllerParams(), {**stored, "max_match_distance": float(stored.get("max_match_distance",
                                                                                             BLEND.max_match_distance))},
                       "controller")


def _config_text(config: dict) -> str:
    """The run's configuration in one line (a custom grid by its size, the generator by its mode; all of
    it is in run.json)."""
    shown = {k: f"{len(v)} custom poses" if k == "grid" and isinstance(v, list) else v for k, v in config.items()
             if not (k == "meshes" and not v)}  # objects of one's own mesh files, where there are
    if config.get("meshes"):  # by their file's name (run.json has the whole path)
        shown["meshes"] = {name: {**mesh, "file": Path(mesh["file"]).name} for name, mesh in config["meshes"].items()}
    shown["generator"] = f"mode {config['generator'].get('mode', 'settled')}"
    shown["controller"] = f"recall {_controller_params(config.get('controller')).recall.name}"
    return ", ".join(f"{k} {json.dumps(v) if isinstance(v, dict) else v}" for k, v in shown.items())


def _markdown(run: RunData, summary: dict) -> str:
    """The reproduction's report.md: the verdict per claim, the data, the maps, the trials and the figures."""
    objects = summary["objects"]
    parts = [*_opening(run, summary), *_data_and_maps(run, objects), *_grasp_success(summary),
             *_landing_and_resuming(objects), "## Figures\n\n"]
    info = summary["figures"]
    if not info.get("rendered"):
        parts.append(f"The hand pictures (Figs. 3, 5, 7) were skipped: {info.get('message')}\n\n")
    for name in info.get("figures", []):
        parts.append(f"![{name}](figures/{name}.png)\n\n")
    return "".join(parts)




def _opening(run: RunData, summary: dict) -> list[str]:
    """The title, the run's configuration and the verdict per claim, and our choices."""
    small = run.config.get("grid") != "paper" or any(
        n < PAPER_DATASET_SIZES.get(name, 0) for name, n in run.config.get("postures", {}).items())
    return [
             "# graspmanifold: reproduction of *SOM-based experience representation for dextrous grasping*\n\n",
             *(["**A smoke run: too small to be evidence.** Smaller datasets or a smaller grid than the paper's "
                "(`--preset paper` runs its sizes): the verdicts below say whether the pipeline runs, not whether the "
                "paper's claims hold.\n\n"] if small else []),
             f"Library {summary['library_version']}. Every number below comes from this run; the paper's values "
             "stand beside ours where it gives them. Configuration: "
             + _config_text(run.config) + " (all of it in run.json).\n\n",
             "## Verdict per claim\n\n",
             "Each claim of the paper's Section 5, judged by the stated rule (`graspmanifold.paper.verdicts`): reproduced "
             "when the rule holds for every object, partly when for some, not reproduced when for none, not enough "
             "data when every map had fewer training postures than nodes (an object with too little data is left "
             "out of a claim and marked). The claims the paper makes about its cylinder map (Figs. 5-8) are judged "
             "on the cylinder. Where the paper leaves a choice open, ours are listed under \"Our choices\" below.\n\n",
             _table(["claim", "paper", "ours", "verdict", "rule", "cause"],
                    [[c["claim"], c["paper"], c["ours"], f"**{c['verdict']}**", c["rule"], c["cause"] or "–"]
                     for c in summary["claims"]]),
             "## Our choices\n\n",
             "What the paper does not fix, and what this run used:\n\n",
             _table(["choice", "ours", "the paper"], _choices(run))]


def _data_and_maps(run: RunData, objects: dict) -> list[str]:
    """The posture datasets and the SOM grasp manifolds (Fig. 4)."""
    return [
             "## Posture datasets\n\n",
             f"Generator mode: {run.config['generator'].get('mode', 'settled')} (`GeneratorParams.mode`). The data's "
             "character: each posture's distance to its nearest other posture (min: the closest pair; median; "
             "90th percentile), the spread of each starting posture's cluster (mean distance to its mean) and the "
             "distance between cluster means; all in degrees over the 22 joints.\n\n",
             f"Procedure: {run.config.get('procedure', 'paper')} (`ReproduceConfig.procedure`): trained on "
             + ("every candidate" if run.config.get("procedure", "paper") == "paper" and not run.config["generator"].get(
                 "verify") else "the candidates that hold") + "; the springs' yield is candidates per placement tried.\n\n",
             _table(["object", "trained on", "candidates", "paper", "springs' yield", "starting postures with data",
                     "nearest neighbour min / median / p90 (°)", "within-start (°)", "between starts (°)"],
                    [[n, o["dataset_size"], o["candidates"], _fmt(o["paper_dataset_size"]), _fmt(o["acceptance_ratio"], 2),
                      f"{o['clusters']['starts']} of {o['starting_postures']}", " / ".join(_fmt(o["nearest_neighbour_deg"][k]) for k in
                                                         ("min", "median", "p90")),
                      _fmt(o["clusters"]["within_deg"]), _fmt(o["clusters"]["between_deg"])]
                     for n, o in objects.items()]),
             "## SOM grasp manifolds (Fig. 4)\n\n",
             "Inter-node distances over the 22 finger joints, in degrees, as in the paper's Section 5. A map "
             "trained on fewer postures than it has nodes is marked low data: its numbers say nothing about the "
             "paper's claims, and the verdicts leave it out.\n\n",
             _table(["object", "min distance (°)", "paper min", "max distance (°)", "paper max", "distance CV",
                     "quantisation error (rad)", "topographic error", "nodes without training data"],
                    [[f"{n} (low data: {o['dataset_size']} postures, {o['map']['nodes']} nodes)" if o.get("low_data")
                      else n, _fmt(o["map"]["distance_min_deg"]), _fmt(o["paper_min_distance_deg"], 4),
                      _fmt(o["map"]["distance_max_deg"]), _fmt(o["paper_max_distance_deg"], 4),
                      _fmt(o["map"]["distance_cv"]), _fmt(o["map"].get("quantization_error")),
                      _fmt(o["map"].get("topographic_error")),
                      f"{o['map'].get('unsupported_by_training')} of {o['map']['nodes']}"] for n, o in objects.items()])]


def _grasp_success(summary: dict) -> list[str]:
    """Grasp success per object and method (Fig. 6), the verdict against the heuristic, the manifolds."""
    return [
             "## Grasp success per object and method (Fig. 6 data)\n\n",
             "hold (the primary measure): the object stays within 2 cm under gravity along ±x, ±y, ±z; margin: the "
             "extra force it then withstands (N, up to 5); force closure: Ferrari–Canny ε of the L1 grasp wrench "
             f"space > {JUDGING.epsilon_threshold} at the simulated friction. Rates with 95 % Wilson intervals. `som_all` is "
             "one map trained on all three objects.\n\n",
             _table(["object", "method", "trials", "hold", "force closure", "mean margin (N)", "mean ε",
                     "time to grasp (s)"],
                    [[s["object"], s["method"], trial_count(s),
                      rate_text(round(s["hold_rate"] * s["trials"]), s["trials"]),
                      rate_text(round(s["force_closure_rate"] * s["trials"]), s["trials"]), _fmt(s["mean_margin"]),
                      _fmt(s["mean_epsilon"]), _fmt(s["mean_time_to_grasp"])] for s in summary["evaluation"]]),
             "## Verdict: does experience beat the plain heuristic?\n\n",
             "Each method against the heuristic (`none`) on the same poses, hold test, McNemar's exact test, and "
             "Holm's correction over the table's comparisons (the verdict reads it, at 0.05). The library's full "
             "study with the stronger controls is `scripts/study_experience.py`.\n\n",
             _table(["object", "method", "hold", "heuristic", "only method held", "only heuristic held", "p",
                     "Holm p", "verdict"],
                    [[r["object"], r["method"], r["rate_text"], r["control_text"], r["only_method"], r["only_control"],
                      f"{r['p_value']:.3g}", f"{h:.3g}", r["verdict"] if h < 0.05 else "no difference"] for r, h in
                     zip(summary["comparisons"], holm([r["p_value"] for r in summary["comparisons"]]))]),
             f"{summary['verdict']}\n\n",
             *_manifold_section(summary)]


def _landing_and_resuming(objects: dict) -> list[str]:
    """Where the evaluation grasps land, and the resumed learning (Figs. 7, 8)."""
    return [
             "## Where the evaluation grasps land (Section 5)\n\n",
             "The paper observed that successful grasps of the experience-based controller match mostly "
             "inter-cluster nodes, which no training posture falls on.\n\n",
             _table(["object", "successful SOM grasps", "nodes with training data",
                     "successful grasps on nodes without training data"],
                    [[n, o["successful_som_postures"], f"{o['supported_nodes']} of {o['map']['nodes']}",
                      _fmt(o["evaluation_on_unsupported_nodes"])] for n, o in objects.items()]),
             "And while the controller runs (the paper: inter-cluster nodes \"are more often winners\"): the SOM "
             "controller's best match in every control cycle whose match it used.\n\n",
             _table(["object", "trials with matches", "trials mostly on nodes without training data",
                     "winners", "winners on nodes without training data", "nodes without training data"],
                    [[n, w["trials"], rate_text(w["mainly_unsupported"], w["trials"]), w["winners"],
                      rate_text(w["winners_unsupported"], w["winners"]), f"{w['unsupported_nodes']} of {w['nodes']}"]
                     for n, o in objects.items() if (w := o.get("control_winners"))]),
             "## Resumed learning (Figs. 7, 8)\n\n",
             f"{RESUME.epochs} epochs with the successful evaluation postures, learning rate "
             f"{RESUME.learning_rate[0]:g} → {RESUME.learning_rate[1]:g}, σ {RESUME.sigma[0]:g} → {RESUME.sigma[1]:g}.\n\n",
             _table(["object", "distance CV before → after", "max distance (°) before → after",
                     "nodes without training data before → after", "nodes without evaluation data before → after"],
                    [[n, f"{_fmt(o['map']['distance_cv'])} → {_fmt(o['resumed_map']['distance_cv'])}",
                      f"{_fmt(o['map']['distance_max_deg'])} → {_fmt(o['resumed_map']['distance_max_deg'])}",
                      f"{o['map'].get('unsupported_by_training')} → {o['resumed_map'].get('unsupported_by_training')}",
                      f"{o['map'].get('unsupported_by_evaluation', '–')} → {o['resumed_map'].get('unsupported_by_evaluation', '–')}"]
                     for n, o in objects.items()])]


def _manifold_section(summary: dict) -> list[str]:
    """The report's section on a `--experience ukr` run's continuous manifolds (none for a SOM-only run)."""
    manifolds = summary.get("manifolds") or {}
    if not manifolds:
        return []
    return ["## The continuous manifold beside the SOM (UKR, the paper's future work)\n\n",
            "A UKR manifold (`manifold.ukr.UKR`) trained on each map's postures, run by the same controller "
            "(`ukr`, `ukr_all`) and resumed with its own successful grasps as the SOM is. Its fit: the spectral "
            "start it chose and the leave-one-out reconstruction error (rad², mean squared norm) from that start, "
            "fitted, and after the resumed learning.\n\n",
            _table(["postures of", "postures", "latent dimensions", "start", "leave-one-out start → fitted",
                    "resumed: postures added, leave-one-out"],
                   [[n, m["postures"], m["latent_dim"], m["start"], f"{_fmt(m['loo_start'])} → {_fmt(m['loo'])}",
                     f"{m.get('resumed_postures', '–')}, {_fmt(m.get('loo_resumed'))}"] for n, m in manifolds.items()]),
            "Each UKR method against the SOM method of the same postures, on the same poses (McNemar's exact test, "
            "Holm over these rows):\n\n",
            _table(["object", "method", "hold", "SOM's", "only UKR held", "only SOM held", "p", "Holm p", "verdict"],
                   [[r["object"], f"{r['method']} vs {r['control']}", r["rate_text"], r["control_text"],
                     r["only_method"], r["only_control"], f"{r['p_value']:.3g}", f"{h:.3g}",
                     r["verdict"] if h < 0.05 else "no difference"]
                    for r, h in zip(summary["manifold_comparisons"],
                                    holm([r["p_value"] for r in summary["manifold_comparisons"]]))])]


def figure_from_run(run_dir: str | os.PathLike, name: str, out_dir: str | os.PathLike | None = None) -> dict:
    """Redraw one figure of a finished `reproduce` run (`graspmanifold figure NAME RUN_DIR`)."""
    run = RunData.load(run_dir)
    info = write_figures(Path(out_dir or Path(run_dir) / "figures"), run, only=name)
    if name not in info["figures"]:
        rendered = name.split("_")[0] in RENDERED_KINDS and name in figure_names(list(run.sets))
        reason = info["message"] if rendered and not info["rendered"] else (
            f"unknown figure name; this run draws {', '.join(figure_names(list(run.sets)))}")
        raise InvalidInput(f"figure {name!r} was not drawn: {reason}")
    return info
