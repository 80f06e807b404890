"""The reproduce pipeline end to end, on a reduced configuration."""

import json
import shutil

import matplotlib.image
import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.paper.reproduce import PRESETS, ReproduceConfig, reproduce
from graspmanifold.sim import render

REDUCED = ReproduceConfig(postures={"box": 12, "cylinder": 12, "sphere": 48},
                          grid=((0.0, 0.0, 0.01, 0.0), (0.01, 0.0, 0.02, 0.0)), map_size=(10, 10), epochs=4,
                          image_size=48, generator=gm.GeneratorParams(job_size=6, verify=False))
FIGURES = ["fig3_cylinder_extract", "fig4_box", "fig4_cylinder", "fig4_sphere", "fig5_cylinder_border",
           "fig6_cylinder_evaluation", "fig7_cylinder_resumed_extract", "fig8_cylinder_resumed", "rates"]


def run(out, config=REDUCED, **kwargs):
    lines = []
    summary = reproduce(out, config, log=lines.append, **kwargs)
    ran = [line.split("]")[0][1:] for line in lines if line.endswith("running")]
    return summary, ran, lines


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    summary, ran, _ = run(out)
    return out, summary, ran


def hand_pixels(image):
    """Fraction of pixels in the hand's beige (lit or shaded), not white background or black bars."""
    rgb = image[..., :3]
    return np.mean((rgb[..., 0] > 0.25) & (rgb[..., 0] < 0.97) & (rgb[..., 0] - rgb[..., 2] > 0.04))


def test_every_promised_file_is_there(finished):
    out, summary, ran = finished
    assert len(ran) == 29  # 3 x (generate, train, resume), train_all, 3 x 6 evaluations, figures
    sizes = {}
    for name, size in REDUCED.postures.items():
        postures = gm.PostureSet.load(out / "postures" / f"{name}.npz")
        sizes[name] = len(postures)
        assert len(postures) == size and not postures.metadata["verified"]  # every candidate, as the paper kept
        distal = [gm.SEGMENTS.index(segment) for segment in gm.DISTAL_SEGMENTS]
        assert postures.contacts[:, distal].all()  # each with its five fingertips on the object
        assert gm.SOM.load(out / "maps" / f"{name}_resumed.npz").rows == 10
        for method in ("none", "database", "som", "som_all", "database_blend", "som_blend"):
            assert len(gm.EvaluationResult.load(out / "evaluation" / f"{name}_{method}.npz").trials) == 2
    assert gm.SOM.load(out / "maps" / "all.npz").history[0]["samples"] == sum(sizes.values())
    for figure in FIGURES:
        for suffix in ("png", "pdf"):
            assert (out / "figures" / f"{figure}.{suffix}").stat().st_size > 1000, figure
    report = (out / "report.md").read_text()
    assert report.splitlines()[2].startswith("**A smoke run: too small to be evidence.**")  # a small run says so first
    from graspmanifold.base.config_files import read_config

    assert read_config(out / "config.toml", PRESETS["paper"]) == REDUCED  # the run's experiment file, custom grid too
    for text in ("63.45", "4220", "Resumed learning", "figures/fig3_cylinder_extract.png", "som_all", "Verdict",
                 "McNemar", "Target"):
        assert text in report
    saved = json.loads((out / "summary.json").read_text())
    assert saved["objects"]["cylinder"]["dataset_size"] == sizes["cylinder"] and len(saved["evaluation"]) == 18
    assert saved["verdict"].startswith("Target") and len(saved["comparisons"]) == 15  # 3 objects x 5 methods
    assert {r["method"] for r in saved["comparisons"]} == {"database", "som", "som_all", "database_blend", "som_blend"}
    assert saved["figures"]["rendered"]
    cylinder = saved["objects"]["cylinder"]
    assert cylinder["map"]["distance_max_deg"] > cylinder["map"]["distance_min_deg"] > 0
    assert cylinder["nearest_neighbour_deg"]["median"] >= cylinder["nearest_neighbour_deg"]["min"] >= 0
    assert "## Verdict per claim" in report and "Generator mode: settled" in report
    assert len(saved["claims"]) == 11
    # Fig. 6 while the controller runs: every best match the SOM controller used is counted against the map
    som_trials = gm.EvaluationResult.load(out / "evaluation" / "cylinder_som.npz").trials
    som_map = gm.SOM.load(out / "maps" / "cylinder.npz")
    hits = som_map.hit_counts(gm.PostureSet.load(out / "postures" / "cylinder.npz").postures).ravel()
    winners = np.concatenate([t.winners for t in som_trials])
    assert cylinder["control_winners"]["winners"] == len(winners) == sum(t.matches for t in som_trials) > 0
    assert cylinder["control_winners"]["winners_unsupported"] == int(np.sum(hits[winners] == 0))
    assert "more often winners" in report
    # Fig. 6 as its caption counts: the SOM controller's force-closure grasps (not the ones that held)
    closures = [t for t in som_trials if t.force_closure]
    on_unsupported = sum(hits[som_map.best_match(t.posture)] == 0 for t in closures)
    assert cylinder["force_closure_on_unsupported"] == [on_unsupported, len(closures)]
    assert {c["verdict"] for c in saved["claims"]} <= {"reproduced", "partly", "not reproduced", "not enough data"}
    # 12 or 48 postures for a 10 x 10 map: every map here is low data, and the report says so
    assert all(o["low_data"] for o in saved["objects"].values()) and "(low data: 12 postures, 100 nodes)" in report
    assert "## Our choices" in report and "force closure: ε > 0.01" in report
    assert all(f"| {c['claim']} |" in report for c in saved["claims"])
    assert [len(run["steps_deg"]) for run in saved["fig5"]["runs"]] == [3, 3]


def test_rendered_figures_show_hands(finished):
    out, _, _ = finished
    for figure in ("fig3_cylinder_extract", "fig5_cylinder_border", "fig7_cylinder_resumed_extract"):
        image = matplotlib.image.imread(out / "figures" / f"{figure}.png")
        assert image[..., :3].std() > 0.1, figure
        assert hand_pixels(image) > 0.05, figure
    pictures = render.render_postures(np.array([gm.open_posture(), gm.closed_posture()]), 64)
    assert pictures.shape == (2, 64, 64, 3)
    assert all(hand_pixels(p / 255.0) > 0.05 for p in pictures)
    assert np.abs(pictures[0].astype(int) - pictures[1]).mean() > 5  # open and closed hands differ


def test_a_second_run_reuses_everything(finished):
    out, summary, _ = finished
    again, ran, _ = run(out)
    assert ran == []
    assert again["evaluation"] == summary["evaluation"]


def test_the_verified_procedure_trains_on_the_candidates_that_hold(finished, tmp_path):
    out = tmp_path / "verified"
    shutil.copytree(finished[0], out)
    config = ReproduceConfig(**{**REDUCED.__dict__, "procedure": "verified"})
    summary, ran, _ = run(out, config, force=True)
    assert not any(name.startswith("generate") for name in ran)  # the same candidates as the paper procedure's
    assert [name for name in ran if name.startswith("verify")] == ["verify_box", "verify_cylinder", "verify_sphere"]
    for name, size in REDUCED.postures.items():
        held = gm.PostureSet.load(out / "postures" / f"{name}_held.npz")
        assert held.metadata["verified"] and held.metadata["candidates"] == size >= len(held)
        assert summary["objects"][name]["dataset_size"] == len(held)
        assert summary["objects"][name]["candidates"] == size
    assert summary["procedure"] == "verified"
    recorded = json.loads((out / "run.json").read_text())
    assert recorded["datasets"]["sphere"] == {"procedure": "verified", "candidates": 48,
                                              "trained_on": summary["objects"]["sphere"]["dataset_size"]}
    assert set(recorded["versions"]) == {"graspmanifold", "code", "mujoco", "numpy", "scipy", "numba", "blas", "python",
                                         "machine"}
    assert "only candidates that hold when replayed" in (out / "report.md").read_text()
    with pytest.raises(ValueError, match="procedure must be one of"):
        ReproduceConfig(**{**REDUCED.__dict__, "procedure": "all"})
    with pytest.raises(ValueError, match="leave generator.verify False"):
        ReproduceConfig(**{**REDUCED.__dict__, "procedure": "verified", "generator": gm.GeneratorParams()})


def test_the_ukr_manifold_runs_beside_the_som_and_the_report_gives_its_figures(finished, tmp_path):
    out = tmp_path / "ukr"
    shutil.copytree(finished[0], out)
    summary, ran, _ = run(out, ReproduceConfig(**{**REDUCED.__dict__, "manifold": "ukr"}), force=True)
    assert not any(name.startswith(("generate", "train", "resume_box")) for name in ran)  # the SOM's stages kept
    assert {"fit_ukr_all", "fit_ukr_cylinder", "evaluate_box_ukr_all", "resume_ukr_sphere"} <= set(ran)
    assert set(summary["manifolds"]) == {"box", "cylinder", "sphere", "all"}
    for name in ("box", "cylinder", "sphere"):
        fitted = gm.UKR.load(out / "manifolds" / f"{name}.npz")
        assert fitted.latent_dim == 2 and summary["manifolds"][name]["loo"] < summary["manifolds"][name]["loo_start"]
        assert (out / "manifolds" / f"{name}_resumed.npz").exists()
    assert {(r["method"], r["control"]) for r in summary["manifold_comparisons"]} == {("ukr", "som"),
                                                                                      ("ukr_all", "som_all")}
    report = (out / "report.md").read_text()
    assert "## The continuous manifold beside the SOM" in report and "| ukr |" in report
    if summary["figures"]["rendered"]:
        assert "ukr_cylinder_latent" in summary["figures"]["figures"]
        assert (out / "figures" / "ukr_cylinder_latent.png").exists()
    assert 'manifold = "ukr"' in (out / "config.toml").read_text()
    with pytest.raises(ValueError, match="manifold must be one of"):
        ReproduceConfig(**{**REDUCED.__dict__, "manifold": "gtm"})


def test_a_run_interrupted_during_evaluation_resumes(finished):
    out, _, _ = finished
    # as if killed while evaluating the sphere with the SOM: no manifest, no result file
    (out / "stages" / "evaluate_sphere_som.json").unlink()
    (out / "evaluation" / "sphere_som.npz").unlink()
    _, ran, _ = run(out)
    # only the unfinished stage runs; it is deterministic, so what depends on its file is still valid
    assert ran == ["evaluate_sphere_som"]


def test_another_runs_directory_is_refused_unless_forced(finished, tmp_path):
    out, _, _ = finished
    other = ReproduceConfig(**{**REDUCED.__dict__, "epochs": 5})
    with pytest.raises(ValueError, match="another run"):
        reproduce(out, other, log=lambda _: None)
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty"):
        reproduce(tmp_path, REDUCED, log=lambda _: None)
    with pytest.raises(ValueError, match="unknown preset"):
        reproduce(tmp_path / "new", "huge", log=lambda _: None)


def test_without_a_gl_context_the_pipeline_completes_and_says_how_to_render(finished, tmp_path, monkeypatch):
    out, _, _ = finished
    monkeypatch.setattr(render, "BACKENDS", ("no-such-backend",))
    (out / "stages" / "figures.json").unlink()
    target = tmp_path / "copy"
    import shutil

    shutil.copytree(out, target)
    for rendered in ("fig3_cylinder_extract", "fig5_cylinder_border", "fig7_cylinder_resumed_extract"):
        for suffix in ("png", "pdf"):
            (target / "figures" / f"{rendered}.{suffix}").unlink()
    summary, ran, lines = run(target)
    assert ran == ["figures"]
    assert not summary["figures"]["rendered"]
    assert not (target / "figures" / "fig3_cylinder_extract.png").exists()
    assert (target / "figures" / "fig4_cylinder.png").exists()
    assert "apt-get install" in (target / "report.md").read_text()
    assert any("skipping the rendered hand figures" in line for line in lines)


KILLED_RUN = """
import os, sys
sys.path.insert(0, {tests!r})
from test_reproduce import REDUCED
from graspmanifold.paper.reproduce import reproduce

seen, real_replace = [], os.replace

def replace(source, target):  # a kill right after a file's bytes are written, before its rename
    seen.append(str(target))
    if {pattern!r} in str(target) and sum({pattern!r} in s for s in seen) == {nth}:
        os._exit(9)
    real_replace(source, target)

os.replace = replace
reproduce({out!r}, REDUCED, log=lambda line: None)
"""


def data_files(out):
    return sorted(p.relative_to(out) for d in ("postures", "maps", "evaluation") for p in (out / d).glob("*.npz"))


def test_kills_and_tampered_outputs_end_in_a_clean_runs_bytes(finished, tmp_path):
    """Killed at five places (a generator checkpoint, a map, an evaluation checkpoint, a figure, the
    summary), then with a map replaced by another object's, an evaluation truncated, a figure deleted
    and a manifest truncated: the run that follows equals a clean run byte for byte."""
    import subprocess
    import sys
    from pathlib import Path

    clean, _, _ = finished
    out = tmp_path / "run"
    tests = str(Path(__file__).parent)
    for pattern, nth in (("job_", 2), ("maps/cylinder.npz", 1), ("part_", 3), ("fig4_sphere.pdf", 1),
                         ("summary.json", 1)):
        code = KILLED_RUN.format(tests=tests, pattern=pattern, nth=nth, out=str(out))
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
        assert done.returncode == 9, (pattern, done.stderr[-2000:])
    (out / "maps" / "box.npz").write_bytes((out / "maps" / "sphere.npz").read_bytes())
    truncated = out / "evaluation" / "box_som.npz"
    truncated.write_bytes(truncated.read_bytes()[:300])
    (out / "figures" / "rates.png").unlink()
    manifest = out / "stages" / "train_all.json"
    manifest.write_text(manifest.read_text()[:20])
    _, ran, lines = run(out)
    assert {"train_box", "evaluate_box_som", "figures", "train_all"} <= set(ran)
    assert any("outputs are missing or changed" in line for line in lines)
    assert data_files(out) == data_files(clean) and len(data_files(out)) == 3 + 7 + 18
    for name in data_files(clean):
        assert (out / name).read_bytes() == (clean / name).read_bytes(), name
    assert (out / "summary.json").read_bytes() == (clean / "summary.json").read_bytes()
    assert (out / "figures" / "rates.png").exists()
    assert not list(out.rglob(".*.graspmanifold.tmp"))  # the killed runs' temporary files are cleared


def test_a_second_writer_is_refused_and_only_the_librarys_temporary_files_are_removed(finished, tmp_path):
    """Two runs on one folder used to destroy each other (the second removed the first's temporary file),
    and a forced run removed every hidden *.tmp file under the folder, the user's own included."""
    from graspmanifold.base.io import LOCK_FILE, OutputInUse, output_lock
    from graspmanifold.cli import main as cli

    out = tmp_path / "run"
    shutil.copytree(finished[0], out)
    users = [out / ".notes.tmp", out / "figures" / ".draft.png.tmp"]
    for path in users:
        path.write_text("the user's")
    with output_lock(out / LOCK_FILE):  # a run in progress
        with pytest.raises(OutputInUse, match="being written by another graspmanifold run \\(process \\d+"):
            run(out)
        with pytest.raises(SystemExit, match="being written by another"):
            cli(["reproduce", "--out", str(out), "--force"])
    (out / "figures" / ".rates.png.k3j_x.graspmanifold.tmp").write_text("left by a killed run")
    run(out)
    assert all(path.read_text() == "the user's" for path in users)
    assert not list(out.rglob("*.graspmanifold.tmp"))
    evaluation = tmp_path / "evaluation"
    with output_lock(evaluation / LOCK_FILE):
        with pytest.raises(SystemExit, match="being written by another"):
            cli(["evaluate", "--object", "box", "--experience", "none", "--grid", "quick", "--out", str(evaluation)])
    postures = tmp_path / "box.npz"
    with output_lock(tmp_path / ".box.npz.lock"):
        with pytest.raises(SystemExit, match="being written by another"):
            cli(["generate", "--object", "box", "--n", "4", "--out", str(postures)])


def test_the_figure_command_redraws_one_figure(finished, tmp_path):
    from graspmanifold.cli import main as cli

    out, _, _ = finished
    assert cli(["figure", "fig4_box", str(out), "--out", str(tmp_path)]) == 0
    assert (tmp_path / "fig4_box.png").stat().st_size > 1000 and (tmp_path / "fig4_box.pdf").exists()
    with pytest.raises(SystemExit):
        cli(["figure", "fig99", str(out)])
    with pytest.raises(SystemExit, match="error"):
        cli(["figure", "rates", str(tmp_path / "no-run")])


def test_a_run_is_the_same_run_twice_whatever_the_workers_and_its_figures_regenerate(finished, tmp_path):
    """A second run from nothing, with two worker processes where the first had one: the same summary
    and data files byte for byte; a figure of the finished run is drawn again from its files alone. (The
    quick preset is the same pipeline at larger sizes: the README's first command, timed in BENCHMARKS.md.)"""
    from graspmanifold.paper.report import figure_from_run

    first, second = finished[0], tmp_path / "second"
    run(second, workers=2)
    assert (first / "summary.json").read_bytes() == (second / "summary.json").read_bytes()
    assert data_files(first) == data_files(second) and len(data_files(first)) == 3 + 7 + 18
    for name in data_files(first):
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    redrawn = tmp_path / "redrawn"
    figure_from_run(first, "rates", redrawn)
    assert (redrawn / "rates.png").stat().st_size > 1000


def test_an_experiment_files_relative_mesh_path_is_read_from_its_folder_whatever_the_working_directory(
        tmp_path, monkeypatch):
    """A configuration file that names its mesh by a relative path finds it beside itself (it was read from the
    working directory, so a folder of a file and its mesh worked only when run from inside it); an absolute path
    stays as it is, and a missing relative one is refused with the path it was looked for at."""
    import trimesh

    from graspmanifold.base.config_files import read_config

    folder, elsewhere = tmp_path / "experiment", tmp_path / "elsewhere"
    (folder / "meshes").mkdir(parents=True)
    elsewhere.mkdir()
    trimesh.creation.capsule(height=100.0, radius=22.0).export(folder / "meshes" / "part.stl")
    config = folder / "part.toml"
    config.write_text('postures = { part = 12 }\nmeshes = { part = { file = "meshes/part.stl", scale = 0.001 } }\n')
    monkeypatch.chdir(elsewhere)
    read = read_config(config, PRESETS["quick"])
    assert read.meshes == {"part": {"file": str((folder / "meshes" / "part.stl").resolve()), "scale": 0.001}}
    assert read.object("part").shape == "mesh"
    absolute = folder / "absolute.toml"
    absolute.write_text(f'postures = {{ part = 12 }}\nmeshes = {{ part = {{ file = "{folder / "meshes" / "part.stl"}", scale = 0.001 }} }}\n')
    assert read_config(absolute, PRESETS["quick"]).meshes["part"]["file"] == str((folder / "meshes" / "part.stl").resolve())
    (folder / "gone.toml").write_text('postures = { part = 12 }\nmeshes = { part = { file = "gone.stl" } }\n')
    with pytest.raises(ValueError, match=r"gone\.toml.*meshes\['part'\]\.file.*experiment/gone\.stl"):
        read_config(folder / "gone.toml", PRESETS["quick"])


def test_an_object_of_ones_own_mesh_file_runs_from_the_command_line_and_its_experiment_file(tmp_path):
    """`graspmanifold reproduce --object part.stl --scale 0.001` runs a reproduction on one's own mesh (here a capsule
    in millimetres); the run's config.toml names the file and reads back to the same configuration; run from it
    after the file was edited, the run gives new results (the file's content keys the stages), not the old file's;
    a study that takes object names takes the file too."""
    import trimesh

    from graspmanifold.base.config_files import read_config
    from graspmanifold.cli import main

    mesh = tmp_path / "part.stl"
    trimesh.creation.capsule(height=100.0, radius=22.0).export(mesh)
    small = tmp_path / "small.toml"
    small.write_text('postures = { cylinder = 12 }\nmap_size = [2, 4]\nepochs = 2\nimage_size = 16\n'
                     'grid = [[0.0, 0.0, 0.01, 0.0]]\n[generator]\njob_size = 6\n')
    out = tmp_path / "run"
    command = ["reproduce", "--config", str(small), "--object", str(mesh), "--scale", "0.001", "--out", str(out),
               "--workers", "1"]
    assert main(command) == 0
    first = gm.PostureSet.load(out / "postures" / "part.npz")
    assert first.metadata["object"]["shape"] == "mesh" and len(first) == 12
    written = read_config(out / "config.toml", PRESETS["quick"])
    assert written.meshes == {"part": {"file": str(mesh.resolve()), "scale": 0.001}} and written.postures == {"part": 12}
    for name in ("config.toml", "report.md"):  # the file named from the run's folder, not by this machine's path
        assert str(tmp_path) not in (out / name).read_text(), name
    assert '"file" = "../part.stl"' in (out / "config.toml").read_text()
    assert "(cylinder)" in (out / "report.md").read_text() and "other objects: |" not in (out / "report.md").read_text()
    assert written.object("part").mesh_digest == first.metadata["object"]["mesh_digest"]
    trimesh.creation.capsule(height=110.0, radius=20.0).export(mesh)  # the file edited in place; the run again from
    assert main(["reproduce", "--config", str(out / "config.toml"), "--out", str(out), "--workers", "1"]) == 0  # its file
    second = gm.PostureSet.load(out / "postures" / "part.npz")
    assert second.metadata["object"]["mesh_digest"] != first.metadata["object"]["mesh_digest"]
    assert not np.array_equal(second.postures, first.postures)
    from graspmanifold.studies import spring_holds

    spring_holds.main(["--objects", str(mesh), "--scale", "0.001", "--n", "3", "--workers", "1",
                       "--out", str(tmp_path / "holds"), "--doc", str(tmp_path / "holds.md")])
    assert "| part |" in (tmp_path / "holds.md").read_text()
    with pytest.raises(ValueError, match=r"meshes\['part'\].file"):
        ReproduceConfig(postures={"part": 12}, meshes={"part": {"file": str(tmp_path / "gone.stl")}})
    with pytest.raises(ValueError, match="unknown object 'part'"):
        ReproduceConfig(postures={"part": 12})
