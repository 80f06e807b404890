"""The fourth hardening round (RELIABILITY.md, "Round four", issue 50): the surfaces added last, tried as an attacker
and as a hurried user would: grasp files, experiment files, the studies' runner and locks, regrasp arguments, two
runs on one output, a kill and a resume, a full disk. Each case failed (or misled) before its fix."""

from __future__ import annotations

import io
import pickle
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.judging.plans import MAX_REACH, OpenLoopGrasp
from graspmanifold.synthesis.grasp_files import grasp_object, read_grasp_file, read_grasp_files, write_grasp_files


@pytest.fixture(scope="module")
def grasp_content(tmp_path_factory) -> dict:
    """A valid grasp file's dict (our box grasp, written by `write_grasp_files`)."""
    postures = gm.generate_postures("box", 1, seed=0, workers=1, progress=False)
    pose, posture = postures.hand_poses[0], postures.postures[0]
    grasp = OpenLoopGrasp(np.tile(pose, (3, 1)), np.array([gm.open_posture(), posture, posture]))
    folder = tmp_path_factory.mktemp("grasp")
    return read_grasp_file(write_grasp_files(folder, [grasp], "box_core")[0])


def _one_file(folder: Path, content: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "g.npy"
    np.save(path, np.array(content, dtype=object), allow_pickle=True)
    return folder


@pytest.mark.parametrize("change, message", [
    ({"obj_pose": np.full(7, np.nan)}, r"obj_pose holds non-finite values"),  # was read, and replayed as held
    ({"obj_pose": np.zeros(2)}, r"obj_pose must hold 7 values, got 2"),  # was read
    ({"obj_pose": np.zeros(7)}, r"obj_pose's quaternion .* has zero length"),  # a divide warning, no file named
    ({"obj_scale": np.zeros(0)}, r"obj_scale must hold 1 value, got 0"),  # a bare IndexError
    ({"obj_scale": "large"}, r"obj_scale must be real numbers, got text"),  # 'could not convert string to float'
    ({"obj_scale": np.nan}, r"obj_scale holds non-finite values"),  # read, refused later without the file's name
    ({"obj_scale": -1.0}, r"obj_scale must be a positive number, got -1.0"),  # the same
    ({"obj_path": 3.0}, r"obj_path must be the text of a folder"),
    ("nan qpos", r"grasp_qpos holds non-finite values"),  # 'got 7 and 24 values': the right counts, no word of NaN
    ("complex qpos", r"grasp_qpos must be real numbers, got complex numbers"),  # NumPy's warning only
    ("zero root quaternion", r"grasp's root pose's quaternion .* has zero length"),
    ("far grasp", r"the grasp's palm lies 1e\+06 m from the object's centre"),  # replayed as held
])
def test_a_grasp_file_with_a_bad_entry_is_refused_naming_the_file_and_the_entry(tmp_path, grasp_content, change,
                                                                                  message):
    content = dict(grasp_content)
    if isinstance(change, dict):
        content.update(change)
    else:
        qpos = np.array(content["grasp_qpos"], dtype=float)
        if change == "nan qpos":
            qpos[9] = np.nan
        elif change == "complex qpos":
            qpos = qpos + 1j
        elif change == "zero root quaternion":
            qpos[3:7] = 0.0
        else:
            qpos[:3] += [1e6, 0.0, 0.0]
        content["grasp_qpos"] = qpos
    with pytest.raises(ValueError, match=rf"grasp file .*g\.npy: .*{message}"):
        read_grasp_files(_one_file(tmp_path, content))


def test_the_objects_pose_places_the_grasp_in_its_frame(tmp_path, grasp_content):
    """The roots' poses are in the world, as the object's is: the object and the hand moved together (a turn and a
    shift) read as the same grasp. Before, `obj_pose` was never read."""
    from graspmanifold.base.poses import compose

    moved = dict(grasp_content)
    shift, turn = np.array([0.1, -0.2, 0.05]), np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    moved["obj_pose"] = np.r_[shift, turn]
    for stage in ("pregrasp", "grasp", "squeeze"):
        qpos = np.array(grasp_content[f"{stage}_qpos"], dtype=float)
        qpos[:3], qpos[3:7] = compose(shift, turn, qpos[:3], qpos[3:7])
        moved[f"{stage}_qpos"] = qpos
    here = read_grasp_files(_one_file(tmp_path / "here", grasp_content))[0].grasp
    there = read_grasp_files(_one_file(tmp_path / "there", moved))[0].grasp
    assert np.allclose(here.postures, there.postures) and np.allclose(here.poses[:, :3], there.poses[:, :3], atol=1e-9)
    assert np.allclose(np.abs(np.sum(here.poses[:, 3:] * there.poses[:, 3:], axis=1)), 1.0)


class _Declared:
    """A pickle of an array that declares far more elements than it brings."""

    def __reduce__(self):
        from numpy._core.multiarray import _reconstruct
        return _reconstruct, (np.ndarray, (0,), b"b"), (1, (2**28,), np.dtype(object), False, [1.0])


def test_a_small_file_declaring_a_huge_array_is_refused_before_it_is_built(tmp_path):
    """A file of a few hundred bytes declaring 2**28 object elements took 2.2 GB and 3 s before it was refused."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "|O", "fortran_order": False, "shape": ()})
    pickle.dump({"obj_path": _Declared()}, buffer, protocol=3)
    path = tmp_path / "bomb.npy"
    path.write_bytes(buffer.getvalue())
    assert path.stat().st_size < 400
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"bomb\.npy: refused.*declares an array of 268435456 elements"):
            read_grasp_file(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6


def test_an_object_path_that_leaves_the_objects_folder_is_refused_not_searched(tmp_path, grasp_content):
    """obj_path '../../../../..' made `grasp_object` walk the whole filesystem (19 s) and load a mesh found there."""
    (tmp_path / "objects").mkdir()
    for escape in ("../../../../..", str(Path("/").resolve()), "..", "."):
        content = dict(grasp_content, obj_path=escape)
        grasp = read_grasp_files(_one_file(tmp_path / "files", content))[0]
        with pytest.raises(ValueError, match="leads outside"):
            grasp_object(grasp, root=tmp_path / "objects")
    assert MAX_REACH == 1.0


@pytest.mark.parametrize("toml, message", [
    ("map_size = [100000, 100000]", r"map_size must have at most 250000 nodes"),  # a traceback: 149 GiB asked for
    ("epochs = 1000000000000", r"epochs must be a whole number in 1 \.\.\. 100000"),  # a traceback: 7 TiB asked for
    ("image_size = 100000", r"image_size \(pixels\) must be a whole number in 16 \.\.\. 4096"),  # met at the figures
    ("seed = -1", r"seed must be a whole number >= 0"),  # met only once the first stage ran
    ("[postures]\nbox = 100000000", r"postures\['box'\] must be a whole number in 1 \.\.\. 1000000"),  # the same
    ("[controller]\nclosing_rate = 1e300", r"closing_rate must be a finite number > 0 and at most 50"),  # taken
    ('grid = "nowhere"', r"unknown grid preset 'nowhere'"),  # met after the maps were trained
    ('grid = [[0.0, 0.0, 0.0, "nan"]]', r"grid poses must be finite"),  # the same
])
def test_an_experiment_file_out_of_bounds_is_refused_before_any_stage_runs(tmp_path, toml, message):
    from graspmanifold.cli import main as cli

    (tmp_path / "c.toml").write_text(toml + "\n")
    with pytest.raises(SystemExit) as ended:
        cli(["reproduce", "--config", str(tmp_path / "c.toml"), "--out", str(tmp_path / "out")])
    assert ended.value.code != 0 and pytest.importorskip("re").search(message, str(ended.value.code))
    assert not (tmp_path / "out").exists()  # nothing written, not even run.json


def test_a_som_or_a_schedule_beyond_any_study_is_refused_with_its_bound():
    with pytest.raises(ValueError, match="at most 250000"):
        gm.SOM(1000, 1000, 22)
    with pytest.raises(ValueError, match=r"epochs must be a whole number in 1 \.\.\. 100000"):
        gm.SOM(4, 4, 22, epochs=10**9)


def test_regrasp_arguments_out_of_bounds_are_refused_before_any_trial():
    """A million attempts (each failing its probe) ran a two-pose evaluation for minutes; a preshape of 100 rad
    was taken (the servos clip it); grasp types that do not fit the experience were met only inside a trial."""
    with pytest.raises(ValueError, match=r"attempts must be a whole number >= 1 and at most 10"):
        gm.Regrasp(attempts=10**6)
    with pytest.raises(ValueError, match=r"probe_seconds must be .* at most 5"):
        gm.Regrasp(attempts=2, probe_seconds=1e4)
    with pytest.raises(ValueError, match=r"min_force must be .* at most 1000"):
        gm.Regrasp(attempts=2, min_force=1e300)
    with pytest.raises(ValueError, match=r"within ±π rad"):
        gm.Regrasp(attempts=2, preshapes=np.full((1, 22), 100.0))
    outside = np.tile(gm.open_posture(), (1, 1))
    outside[0, 1] = 3.0  # FFJ3 beyond its 1.57 rad
    grid = gm.grid_preset("quick", "box")[:1]
    with pytest.raises(ValueError, match=r"row 0: FFJ3 = 3 rad lies outside its range"):
        gm.evaluate("box", None, grid, regrasp=gm.Regrasp(attempts=2, preshapes=outside), workers=1, progress=False)
    database = gm.PostureDatabase(np.tile(gm.closed_posture(), (5, 1)))
    with pytest.raises(ValueError, match="3 types for an experience of 5 reference postures"):
        gm.TrialSetup(object="box", experience=database, regrasp=gm.Regrasp(attempts=2, grasp_types=np.array(["power"] * 3)))


def test_a_study_whose_report_cannot_be_written_is_refused_before_its_work(tmp_path, capsys):
    """A report in a folder that cannot be written was refused only at the study's end, after its work."""
    from graspmanifold.studies.experience_study import main as study

    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    with pytest.raises(SystemExit, match="cannot write results to"):
        study(["--quick", "--out", str(tmp_path / "study"), "--doc", str(blocked / "report.md")])
    assert not list((tmp_path / "study").glob("*.npz"))


def test_grasp_files_on_a_full_disk_leave_nothing_half_written(tmp_path, monkeypatch, grasp_content):
    """A full disk while a grasp file was written left a '.npy.partial' behind."""
    import os

    grasp = read_grasp_files(_one_file(tmp_path / "in", grasp_content))[0].grasp

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError, match=r"cannot write .*grasp_00000\.npy: No space left on device"):
        write_grasp_files(tmp_path / "out", [grasp], "box_core")
    assert list((tmp_path / "out").iterdir()) == []


def test_the_agreement_check_resumes_and_keeps_its_folder_to_itself(tmp_path, capsys):
    """`scripts/check_agreement.py` run again takes its kept evaluations (a kill loses only the one running), and a
    second run on the same folder while one holds it is refused, naming it."""
    from graspmanifold.base.io import LOCK_FILE, output_lock
    from graspmanifold.studies.agreement import main as check

    out, run = tmp_path / "agreement", str(Path(__file__).resolve().parents[1] / "docs" / "studies" / "verified_run")
    check(["--run", run, "--sample", "2", "--workers", "1", "--out", str(out)])
    kept = {p.name: p.stat().st_mtime_ns for p in out.glob("*_none.npz")}
    report = (out / "report.md").read_text()
    assert len(kept) == 3 and "| box |" in report
    check(["--run", run, "--sample", "2", "--workers", "1", "--out", str(out), "--compare", str(out / "agreement.json")])
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*_none.npz")} == kept  # nothing evaluated again
    assert "| 0 of 2 |" in (out / "report.md").read_text()  # the same outcomes as itself
    with output_lock(out / LOCK_FILE, out), pytest.raises(SystemExit, match="in use|being written|holds"):
        check(["--run", run, "--sample", "2", "--workers", "1", "--out", str(out)])
