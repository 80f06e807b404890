"""`graspmanifold reproduce`: every figure and table of the paper from one command.

    spring-generated grasp postures -> SOMs (one per object, one for all) -> evaluation (none / database / SOM / SOM of all
    objects) -> resumed learning with the SOM's successful postures -> figures -> report

Each stage writes its files into the output directory and a manifest in `stages/` with a key made
from its parameters and the contents of the files it reads, and a digest of every file it wrote. A
rerun skips every stage whose key is unchanged and whose files are there with those digests, so a
run killed half-way picks up where it stopped, a missing, truncated or replaced output is made again
(and the log says why), and changing one thing (a map size, the grid) redoes only what depends on it.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import os
import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..base.checkpoints import remove_checkpoints, result_key
from ..base.config_files import apply_table, to_toml
from ..base.errors import InvalidInput
from ..base.io import LOCK_FILE, TEMPORARY_SUFFIX, library_version, output_lock, software_versions, write_text_atomic
from ..base.moved import current_name, upgrade_config
from ..base.paper_numbers import MAP_SIZE
from ..base.validation import check_choice, check_input_file, check_int
from ..base.workers import default_workers, worker_pool
from ..control.controller import BLEND, ControllerParams
from ..judging.protocols import DEFAULT_PROTOCOL, PROTOCOL_NAMES, get_protocol
from ..manifold.experience import PostureDatabase
from ..manifold.postureset import PostureSet
from ..manifold.som import MAX_EPOCHS, MAX_NODES, PAPER, RESUME, SOM, check_schedule
from ..manifold.ukr import UKR
from ..sim.hand import N_FINGER_JOINTS, SHADOW_HAND, HandModel
from ..sim.hand_models import hand_model, hand_name
from ..sim.objects import GraspObject, get_object, make_object
from ..synthesis.generator import (
    DATASET_PRESETS,
    MAX_POSTURES,
    GeneratorParams,
    generate_postures,
    verify_postures,
)
from ..synthesis.springs import PRESET_PARAMS
from ..trials.evaluation import EvaluationResult, evaluate
from ..trials.grid import check_grid
from .report import RunData, run_methods, write_figures, write_report
from .summary import summarize

#: how the training postures are made from the spring generator's candidates: `paper` keeps every one with
#: five fingertip contacts, as the paper did (Section 5 describes no verification); `verified`, our extension,
#: keeps those of them that hold when replayed (`generator.verify_postures`)
PROCEDURES: tuple[str, ...] = ("paper", "verified")
#: the grasp manifolds a run trains: the paper's SOMs, or beside them continuous UKR manifolds (`manifold.ukr.UKR`,
#: its defaults) of the same postures, evaluated and resumed as the SOMs are
MANIFOLDS: tuple[str, ...] = ("som", "ukr")


@dataclass(frozen=True)
class ReproduceConfig:
    """Everything a run depends on. `postures` names the objects (paper objects, family members,
    `graspmanifold.sim.family.FAMILY`, or objects of one's own mesh files named in `meshes`) and the candidates to
    generate for each; `meshes` gives an object of one's own its file and scale (`{"mug": {"file": "mug.stl",
    "scale": 0.001}}`: a closed solid, or one whose holes can be filled, metres per unit; a relative path is read from the working directory, or in
    a configuration file from the file's folder; the file's content keys every stage that uses it, so an
    edited file gives new results); `procedure` says which of
    them the maps are trained on (`PROCEDURES`: every one, as the paper did, or those that hold); `hand` is
    the hand model the postures are generated and the trials run on (`hand_models.HAND_MODELS`, or an MJCF file);
    `controller` the controller's (the paper's reading; beside any but `BLEND`, also `report.BLEND_METHODS`);
    `protocol` how the trials are judged (`protocols.PROTOCOLS`: our hold test, with the margin the report
    shows, or a DexGraspBench version, without it); `manifold` the grasp manifolds (`MANIFOLDS`: the paper's SOMs, or
    beside them UKR manifolds of the same postures, `report.UKR_METHODS`)."""

    postures: dict[str, int]
    grid: str | tuple = "quick"
    map_size: tuple[int, int] = MAP_SIZE
    epochs: int = PAPER.epochs
    learning_rate: tuple[float, float] = PAPER.learning_rate
    sigma: tuple[float, float] = PAPER.sigma
    seed: int = 0
    image_size: int = 120
    generator: GeneratorParams = field(default_factory=lambda: GeneratorParams(verify=False))
    procedure: str = "paper"
    hand: str = SHADOW_HAND.name
    controller: ControllerParams = field(default_factory=ControllerParams)
    protocol: str = DEFAULT_PROTOCOL
    meshes: dict[str, dict] = field(default_factory=dict)
    manifold: str = "som"

    def __post_init__(self) -> None:
        if not isinstance(self.meshes, dict):
            raise InvalidInput(f"ReproduceConfig.meshes must map object names to {{file, scale}}, got {self.meshes!r}")
        meshes = {}
        for name, mesh in self.meshes.items():
            unknown = sorted(set(mesh) - {"file", "scale"}) if isinstance(mesh, dict) else None
            if unknown is None or unknown or "file" not in mesh:
                raise InvalidInput(f"ReproduceConfig.meshes[{name!r}] must be {{file = PATH, scale = METRES_PER_UNIT}}, "
                                   f"got {mesh!r}")
            scale = mesh.get("scale", 1.0)
            if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale < 1e3:
                raise InvalidInput(f"ReproduceConfig.meshes[{name!r}].scale must be a positive number of metres per "
                                   f"unit, got {scale!r}")
            meshes[name] = {"file": str(check_input_file(mesh["file"], f"ReproduceConfig.meshes[{name!r}].file")
                                        .resolve()), "scale": float(scale)}
        object.__setattr__(self, "meshes", meshes)
        object.__setattr__(self, "protocol", current_name("protocol", self.protocol))  # a name before 0.2
        check_choice(self.protocol, PROTOCOL_NAMES, "ReproduceConfig.protocol")
        check_choice(self.manifold, MANIFOLDS, "ReproduceConfig.manifold")
        object.__setattr__(self, "hand", hand_name(self.hand, "ReproduceConfig.hand"))
        if not isinstance(self.generator, GeneratorParams):
            raise InvalidInput(f"ReproduceConfig.generator must be GeneratorParams, got {self.generator!r}")
        if self.generator.hand not in (SHADOW_HAND.name, self.hand):
            raise InvalidInput(f"ReproduceConfig.generator.hand ({self.generator.hand!r}) differs from "
                               f"ReproduceConfig.hand ({self.hand!r}): the run generates and grasps with one hand; "
                               "set `hand` alone")
        object.__setattr__(self, "generator", replace(self.generator, hand=self.hand))
        if not isinstance(self.controller, ControllerParams):
            raise InvalidInput(f"ReproduceConfig.controller must be ControllerParams (controller.CONTROLLERS names "
                               f"two), got {self.controller!r}")
        check_choice(self.procedure, PROCEDURES, "ReproduceConfig.procedure")
        if self.procedure == "verified" and self.generator.verify:
            raise InvalidInput("ReproduceConfig: procedure 'verified' verifies the generator's candidates itself; "
                             "leave generator.verify False")
        def positive_int(value: object) -> bool:
            return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and bool(value > 0)

        if not isinstance(self.postures, dict) or not self.postures \
                or not all(positive_int(v) for v in self.postures.values()):
            raise InvalidInput(f"ReproduceConfig.postures must give a positive number of postures per object "
                             f"(e.g. {dict(DATASET_PRESETS['quick'])}), got {self.postures!r}")
        for name in self.postures:
            if name == "all":
                raise InvalidInput("ReproduceConfig.postures: 'all' names the map of every object; rename the object")
            try:
                self.object(name)
            except ValueError as error:
                raise InvalidInput(f"ReproduceConfig.postures: {error}") from None
        if len(self.map_size) != 2 or not all(positive_int(v) for v in self.map_size):
            raise InvalidInput(f"ReproduceConfig.map_size must be two positive integers, got {self.map_size!r}")
        if min(self.map_size) < 2 or max(self.map_size) < 4:
            raise InvalidInput(f"ReproduceConfig.map_size must be at least 2 x 4: Figs. 3 and 5 show two 1 x 4 runs of "
                             f"nodes, got {tuple(self.map_size)}")
        for name in ("epochs", "image_size"):
            if not positive_int(getattr(self, name)):
                raise InvalidInput(f"ReproduceConfig.{name} must be a positive integer, got {getattr(self, name)!r}")
        # bounds checked here, before any stage runs (they were met only by the stage that needed them)
        check_int(self.seed, "ReproduceConfig.seed", low=0)
        check_int(self.image_size, "ReproduceConfig.image_size (pixels)", low=16, high=4096)
        check_int(self.epochs, "ReproduceConfig.epochs", high=MAX_EPOCHS)
        if self.map_size[0] * self.map_size[1] > MAX_NODES:
            raise InvalidInput(f"ReproduceConfig.map_size must have at most {MAX_NODES} nodes, got {tuple(self.map_size)}")
        for name, count in self.postures.items():
            check_int(count, f"ReproduceConfig.postures[{name!r}]", high=MAX_POSTURES)
        check_schedule(self.learning_rate, "ReproduceConfig.learning_rate", upper=1.0)
        check_schedule(self.sigma, "ReproduceConfig.sigma")

    @staticmethod
    def table_paths_from(table: dict, folder: Path) -> dict:
        """A configuration file's table with its relative mesh files read from the file's folder (`read_config`).

        Args:
            table: the file's table.
            folder: the file's folder.

        Returns:
            The table, each relative `meshes.<name>.file` joined to `folder`.
        """
        meshes = table.get("meshes")
        if not isinstance(meshes, dict):
            return table
        located = {name: mesh | {"file": str(folder / mesh["file"])}
                   if isinstance(mesh, dict) and isinstance(mesh.get("file"), str) and not Path(mesh["file"]).is_absolute()
                   else mesh for name, mesh in meshes.items()}
        return table | {"meshes": located}

    def object(self, name: str) -> GraspObject:
        """The object a name of `postures` stands for: one of the library's, or the mesh `meshes` gives it.

        Args:
            name: the name.

        Returns:
            The object.

        Raises:
            InvalidInput: an unknown name, or a mesh file that is not a graspable solid.
        """
        if name in self.meshes:
            file = self.meshes[name]["file"]
            state = os.stat(file)
            return _mesh_object(name, file, self.meshes[name]["scale"], (state.st_mtime_ns, state.st_size))
        return get_object(name)

    def to_json(self) -> dict:
        config = asdict(self)
        config["controller"] = self.controller.to_table()
        config["controller"]["max_match_distance"] = str(self.controller.max_match_distance)  # 'inf' is no JSON number
        config["grid"] = self.grid if isinstance(self.grid, str) else [list(map(float, g)) for g in self.grid]
        return config

    @classmethod
    def from_json(cls, config: dict) -> ReproduceConfig:
        """The configuration `to_json` wrote (a run's run.json holds it under "config").

        Args:
            config: the JSON object.

        Returns:
            The configuration, checked as any is.
        """
        config = json.loads(json.dumps(config))  # a copy to change
        controller = config.get("controller")
        if isinstance(controller, dict) and isinstance(controller.get("max_match_distance"), str):
            try:
                controller["max_match_distance"] = float(controller["max_match_distance"])
            except ValueError:
                raise InvalidInput(f"ReproduceConfig.controller.max_match_distance must be a number, got "
                                   f"{controller['max_match_distance']!r}") from None
        return apply_table(cls(postures=dict(config.get("postures") or {"cylinder": 1})), config, "")


@functools.lru_cache(maxsize=16)
def _mesh_object(name: str, file: str, scale: float, stamp: tuple) -> GraspObject:
    """The object of a mesh file (`make_object`), made once per file, scale, name and the file's state (`stamp`: its
    modification time and size; an edited file is read again)."""
    return make_object("mesh", mesh=file, scale=scale, name=name)


#: `quick`: the paper's procedure at small sizes (CI, a first look); `paper`: the paper's procedure and dataset
#: sizes; `verified`: the same candidates, trained on those that hold; `first`: the quick preset on the cylinder, a
#: first run in about a minute
PRESETS: dict[str, ReproduceConfig] = {
    **{name: ReproduceConfig(postures=dict(DATASET_PRESETS[name]), grid=name, generator=PRESET_PARAMS[name])
       for name in ("quick", "paper")},
    # recorded every 5 physics steps: with verification the closest to the paper's maps, where recording every
    # step leaves the sphere without one grasp that holds (docs/studies/data_character.md)
    "verified": ReproduceConfig(postures=dict(DATASET_PRESETS["paper"]), grid="paper",
                                generator=GeneratorParams(mode="recording", record_every=5, verify=False),
                                procedure="verified"),
    # a first run in about a minute: the quick preset on the cylinder (the paper's Figs. 5-8 object), the pictures
    # smaller; its report and the command's last lines give experience against the plain heuristic, with intervals
    "first": ReproduceConfig(postures={"cylinder": DATASET_PRESETS["quick"]["cylinder"]}, grid="quick",
                             generator=PRESET_PARAMS["quick"], image_size=64),
}


def _file_digests(outputs: list[Path], root: Path) -> dict[str, str] | None:
    """Digests of the output files (a directory stands for every file in it), by path relative to
    `root`; None when one is missing."""
    files: list[Path] = []
    for path in outputs:
        if path.is_dir():
            files.extend(sorted(p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")))
        elif path.is_file():
            files.append(path)
        else:
            return None
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()[:20] for p in files}


class _Stages:
    """Runs a stage unless its manifest shows the same key (`checkpoints.result_key` of the stage's
    configuration and input files: another version's or an edited checkout's stage runs again) and its
    outputs exist unchanged."""

    def __init__(self, out: Path, log: Callable[[str], None], total: int):
        self.out, self.log, self.total = out, log, total
        (out / "stages").mkdir(parents=True, exist_ok=True)
        self.ran: list[str] = []
        self.reused: list[str] = []

    def run(self, name: str, key: str, outputs: list[Path], work: Callable[[], dict | None]) -> dict:
        manifest = self.out / "stages" / f"{name}.json"
        if manifest.exists():
            try:
                record = json.loads(manifest.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError, OSError):
                self.log(f"[{name}] its manifest {manifest} is unreadable: running again")
                record = {}
            if record.get("key") == key:
                if _file_digests(outputs, self.out) == record.get("outputs"):
                    self.reused.append(name)
                    return record.get("info", {})
                self.log(f"[{name}] its outputs are missing or changed since it ran: running again")
        self.log(f"[{name}] stage {len(self.ran) + len(self.reused) + 1} of {self.total}: running")
        start = time.perf_counter()
        info = work() or {}
        record = {"key": key, "seconds": round(time.perf_counter() - start, 2), "info": info,
                  "outputs": _file_digests(outputs, self.out)}
        write_text_atomic(manifest, json.dumps(record, indent=1))
        self.ran.append(name)
        self.log(f"[{name}] done in {record['seconds']:.1f} s")
        return info


def _check_output(out: Path, config: ReproduceConfig, force: bool) -> None:
    run_file = out / "run.json"
    if run_file.exists():
        try:
            previous = json.loads(run_file.read_text()).get("config")
        except (json.JSONDecodeError, UnicodeDecodeError, AttributeError) as error:
            if not force:
                raise InvalidInput(f"{run_file} is unreadable ({error}); pass --force to start the run again") from None
            previous = None
        if isinstance(previous, dict):
            previous.setdefault("hand", SHADOW_HAND.name)  # a run.json written before the choice of hand
            upgrade_config(previous)
            previous.setdefault("controller", {**json.loads(json.dumps(BLEND.to_table())), "max_match_distance": "0.2"})
            previous["controller"] = ControllerParams.upgrade_table(previous["controller"])
        if previous != json.loads(json.dumps(config.to_json())) and not force:
            raise InvalidInput(f"{out} holds another run's files with other parameters; pass --force to "
                             "replace them, or choose another directory")
    elif out.exists() and any(p.name != LOCK_FILE for p in out.iterdir()) and not force:
        raise InvalidInput(f"{out} is not empty and holds no graspmanifold run; pass --force to write into it")


def reproduce(out: str | os.PathLike, preset: str | ReproduceConfig = "quick", workers: int | None = None, *,
              force: bool = False, log: Callable[[str], None] = print, executor: Executor | None = None) -> dict:
    """Run (or resume) the whole pipeline into `out`; returns the summary written to summary.json.
    `executor` runs the generator's jobs and the trials elsewhere (a Dask cluster:
    `workers.cluster_executor`), with the same results; without one, every stage shares one pool of `workers`
    processes (None: `workers.default_workers()`)."""
    if isinstance(preset, str):
        if preset not in PRESETS:
            raise InvalidInput(f"unknown preset {preset!r}; expected one of {tuple(PRESETS)}")
        config = PRESETS[preset]
    else:
        config = preset
    if workers is not None:
        check_int(workers, "workers")
    hand = hand_model(config.hand)  # refused here, before any file is written, when it is not a Shadow Hand
    for name in config.postures:  # a grid no object can use was refused after the maps were trained
        check_grid(_grid(config), config.object(name))
    out = Path(out)
    _check_output(out, config, force)
    with output_lock(out / LOCK_FILE):
        pool_size = default_workers() if workers is None else workers
        if executor is not None or pool_size == 1:
            return _run(out, config, hand, pool_size, log, executor)
        with worker_pool(pool_size) as pool:  # one pool for every stage: a pool's start costs about a second
            return _run(out, config, hand, pool_size, log, pool)


def _run(out: Path, config: ReproduceConfig, hand: HandModel, workers: int, log: Callable[[str], None],
         executor: Executor | None) -> dict:
    """`reproduce` with the output folder held; the stages that use the hand are keyed by its content."""
    for stale in out.rglob(f".*{TEMPORARY_SUFFIX}"):  # the library's own, left by a run killed while writing
        stale.unlink()
    run_record = {"config": config.to_json(), "library_version": library_version(), "versions": software_versions()}
    write_text_atomic(out / "run.json", json.dumps(run_record, indent=1))
    # the experiment file of this run (`--config` reads it), its mesh files named from its folder
    relative = {name: mesh | {"file": os.path.relpath(mesh["file"], out.resolve())}
                for name, mesh in config.meshes.items()}
    write_text_atomic(out / "config.toml", to_toml(config, {"meshes": relative}))
    pipeline = _Pipeline(out, config, hand, executor or workers, log)
    started = time.perf_counter()
    sets_paths = pipeline.posture_sets()  # 1. posture sets
    sets = {name: PostureSet.load(path) for name, path in sets_paths.items()}
    run_record["datasets"] = {name: {"procedure": config.procedure, "candidates": s.metadata.get("candidates", len(s)),
                                     "trained_on": len(s)} for name, s in sets.items()}
    write_text_atomic(out / "run.json", json.dumps(run_record, indent=1))  # what the maps learn
    map_paths, manifold_paths = pipeline.manifolds(sets_paths, sets)  # 2. maps and manifolds
    maps = {name: SOM.load(path) for name, path in map_paths.items()}
    manifolds = {name: UKR.load(path) for name, path in manifold_paths.items()}
    eval_paths = pipeline.evaluations({"database": sets_paths, "som": map_paths, "ukr": manifold_paths},
                                      {"database": sets, "som": maps, "ukr": manifolds})  # 3. every method
    results = {key: EvaluationResult.load(path) for key, path in eval_paths.items()}
    resumed_paths, resumed_manifold_paths = pipeline.resumed(map_paths, manifold_paths, eval_paths, maps, manifolds,
                                                             results)  # 4. resumed learning
    resumed_maps = {name: SOM.load(path) for name, path in resumed_paths.items()}
    resumed_manifolds = {name: UKR.load(path) for name, path in resumed_manifold_paths.items()}
    # 5. figures, 6. report
    run = RunData(json.loads(json.dumps(config.to_json())), sets, maps, resumed_maps, results, manifolds,
                  resumed_manifolds)
    figure_key = result_key(config.image_size, *map_paths.values(), *resumed_paths.values(), *sets_paths.values(),
                            *eval_paths.values(), *manifold_paths.values())
    figure_info = pipeline.stages.run("figures", figure_key, [out / "figures"],
                                      lambda: write_figures(out / "figures", run, log))
    summary = summarize(run, figure_info).to_json()
    write_report(out, run, summary)
    log(f"reproduce: {len(pipeline.stages.ran)} stages ran, {len(pipeline.stages.reused)} reused, "
        f"{time.perf_counter() - started:.1f} s; report in {out / 'report.md'}")
    return summary


class _Pipeline:
    """The reproduction's resumable stages over its objects: each step makes its files unless a stage of the same
    key made them before (`_Stages`), and returns their paths."""

    def __init__(self, out: Path, config: ReproduceConfig, hand: HandModel, workers: int | Executor,
                 log: Callable[[str], None]):
        self.out, self.config, self.hand, self.workers = out, config, hand, workers
        self.objects = tuple(config.postures)
        self.verified = config.procedure == "verified"
        self.methods = run_methods(config.controller, config.manifold)
        self.continuous = config.manifold == "ukr"
        self.stages = _Stages(out, log, total=(3 + self.verified + 2 * self.continuous) * len(self.objects) + 2
                              + self.continuous + len(self.objects) * len(self.methods))

    def posture_sets(self) -> dict[str, Path]:
        """Every object's postures (and those that hold, for the verified procedure): the files the maps learn."""
        config, out, workers = self.config, self.out, self.workers
        sets_paths = {name: out / "postures" / f"{name}.npz" for name in self.objects}
        for name, path in sets_paths.items():
            def generate(name=name, path=path):
                parts = path.with_name(path.name + ".parts")
                postures = generate_postures(config.object(name), config.postures[name], seed=config.seed,
                                             workers=workers, params=config.generator, checkpoint_dir=parts,
                                             progress=True)
                postures.save(path)
                remove_checkpoints(parts)
            self.stages.run(f"generate_{name}", result_key(name, config.postures[name], config.seed,
                                                           asdict(config.generator), self.hand.digest,
                                                           config.object(name).params()), [path], generate)
        if not self.verified:
            return sets_paths
        candidates_paths, sets_paths = sets_paths, {name: out / "postures" / f"{name}_held.npz" for name in self.objects}
        for name, path in sets_paths.items():
            def verify(name=name, path=path):
                held = verify_postures(PostureSet.load(candidates_paths[name]), config.object(name), workers,
                                       params=config.generator, progress=True)
                held.save(path)
                return {"candidates": int(held.metadata["candidates"]), "kept": len(held)}
            self.stages.run(f"verify_{name}", result_key(asdict(config.generator), self.hand.digest,
                                                         candidates_paths[name]), [path], verify)
        return sets_paths

    def manifolds(self, sets_paths: dict[str, Path], sets: dict[str, PostureSet]
                  ) -> tuple[dict[str, Path], dict[str, Path]]:
        """A map per object and one for all objects; the UKR manifolds likewise where the run has them."""
        config, out = self.config, self.out
        schedule = {"epochs": config.epochs, "learning_rate": config.learning_rate, "sigma": config.sigma}
        map_paths = {name: out / "maps" / f"{name}.npz" for name in (*self.objects, "all")}
        for name, path in map_paths.items():
            inputs = [sets_paths[name]] if name != "all" else list(sets_paths.values())

            def train(name=name, path=path):
                data = sets[name].postures if name != "all" else PostureSet.concatenate(list(sets.values())).postures
                if not len(data):
                    raise InvalidInput(f"no training postures for the {name} map: the {config.procedure} procedure "
                                       "kept none of the candidates; ask for more (ReproduceConfig.postures) or use "
                                       "the paper procedure")
                SOM(*config.map_size, N_FINGER_JOINTS, seed=config.seed).fit(data, **schedule, progress=True).save(
                    path, extra={"hand": config.hand})
            self.stages.run(f"train_{name}", result_key(config.map_size, schedule, config.seed, *inputs), [path], train)
        manifold_paths = ({name: out / "manifolds" / f"{name}.npz" for name in (*self.objects, "all")}
                          if self.continuous else {})
        for name, path in manifold_paths.items():
            def fit(name=name, path=path):
                data = sets[name].postures if name != "all" else PostureSet.concatenate(list(sets.values())).postures
                UKR().fit(data, progress=True).save(path, extra={"hand": config.hand})
            inputs = [sets_paths[name]] if name != "all" else list(sets_paths.values())
            self.stages.run(f"fit_ukr_{name}", result_key("ukr", *inputs), [path], fit)
        return map_paths, manifold_paths

    def evaluations(self, paths: dict[str, dict[str, Path]], made: dict[str, dict]) -> dict[tuple[str, str], Path]:
        """Every method on every object: its experience (`paths`/`made`: the posture sets, maps and manifolds by
        kind) over the run's grid."""
        config, out = self.config, self.out
        eval_paths = {(o, m): out / "evaluation" / f"{o}_{m}.npz" for o in self.objects for m in self.methods}
        sets, maps, manifolds = made["database"], made["som"], made["ukr"]
        for (name, method), path in eval_paths.items():
            kind = method.removesuffix("_blend")  # a `_blend` method: the same experience under the BLEND controller
            params = BLEND if method.endswith("_blend") else config.controller
            inputs = {"none": [], "database": [paths["database"][name]], "som": [paths["som"][name]],
                      "som_all": [paths["som"]["all"]],
                      **({"ukr": [paths["ukr"][name]], "ukr_all": [paths["ukr"]["all"]]} if self.continuous else {})}

            def run_evaluation(name=name, method=method, path=path, kind=kind, params=params):
                experience = {"none": None, "database": PostureDatabase(sets[name].postures), "som": maps[name],
                              "som_all": maps["all"], "ukr": manifolds.get(name), "ukr_all": manifolds.get("all")}[kind]
                parts = path.with_name(path.stem + ".parts")
                result = evaluate(config.object(name), experience, _grid(config), seed=config.seed,
                                  workers=self.workers, checkpoint_dir=parts, progress=True, method=method,
                                  hand=config.hand, params=params,
                                  margin=get_protocol(config.protocol).physics is None,  # the report's margin
                                  protocol=config.protocol)
                result.save(path)
                remove_checkpoints(parts)
            poses = check_grid(_grid(config), config.object(name))[1]  # keyed on the poses, not the preset's name
            self.stages.run(f"evaluate_{name}_{method}", result_key(poses.tolist(), config.seed, method,
                                                                    self.hand.digest, params.to_table(),
                                                                    config.protocol, config.object(name).params(),
                                                                    *inputs[kind]), [path], run_evaluation)
        return eval_paths

    def resumed(self, map_paths: dict[str, Path], manifold_paths: dict[str, Path],
                eval_paths: dict[tuple[str, str], Path], maps: dict[str, SOM], manifolds: dict[str, UKR],
                results: dict[tuple[str, str], EvaluationResult]) -> tuple[dict[str, Path], dict[str, Path]]:
        """Resumed learning with the SOM's (and the UKR's) successful evaluation postures."""
        out = self.out
        resumed_paths = {name: out / "maps" / f"{name}_resumed.npz" for name in self.objects}
        for name, path in resumed_paths.items():
            def resume(name=name, path=path):
                successes = results[(name, "som")].successful_postures()
                resumed = copy.deepcopy(maps[name])
                if len(successes):
                    resumed.resume(successes, **RESUME.as_dict())
                resumed.save(path, extra={"hand": self.config.hand})
                return {"postures": int(len(successes))}
            self.stages.run(f"resume_{name}", result_key(RESUME.as_dict(), map_paths[name], eval_paths[(name, "som")]),
                            [path], resume)
        resumed_manifold_paths = ({name: out / "manifolds" / f"{name}_resumed.npz" for name in self.objects}
                                  if self.continuous else {})
        for name, path in resumed_manifold_paths.items():
            def resume_manifold(name=name, path=path):
                successes = results[(name, "ukr")].successful_postures()
                resumed = copy.copy(manifolds[name])  # `resume` replaces its (read-only) arrays: the original keeps its own
                if len(successes):
                    resumed.resume(successes, progress=True)
                resumed.save(path, extra={"hand": self.config.hand})
                return {"postures": int(len(successes))}
            self.stages.run(f"resume_ukr_{name}", result_key("ukr", manifold_paths[name], eval_paths[(name, "ukr")]),
                            [path], resume_manifold)
        return resumed_paths, resumed_manifold_paths


def _grid(config: ReproduceConfig) -> str | np.ndarray:
    return config.grid if isinstance(config.grid, str) else np.asarray(config.grid, dtype=float)


