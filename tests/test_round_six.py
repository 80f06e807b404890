"""Hardening, round six (issue 69): the surfaces issues 65-68 added (the planned-grasp benchmark, the palm's flange
and phases, dataset objects and their repair, the continuous manifold's files and completion). Each case of
RELIABILITY.md's round-six table that was poor has its test here, failing before its fix."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.manifold.ukr import UKR
from graspmanifold.sim.flange import FlangeLimits

LIMITS = gm.SHADOW_HAND.limits()
POSTURES = np.random.default_rng(0).uniform(LIMITS[:, 0], LIMITS[:, 1], (40, 22))


@pytest.mark.parametrize("field, value", [("speed", 1e300), ("stiffness", 1e30), ("travel", 100.0),
                                          ("turn", np.pi), ("force", np.nan), ("torque", True)])
def test_an_arm_beyond_any_arm_is_refused(field, value):
    """A flange travelling 100 m at 1e300 m/s with a 1e30 N/m servo was taken (only > 0 was checked)."""
    with pytest.raises(gm.InvalidInput, match=rf"FlangeLimits\.{field} must be a finite number > 0 and at most"):
        FlangeLimits(**{field: value})


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "graspmanifold.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_evaluate_runs_the_experience_its_flags_name(tmp_path):
    """`evaluate --experience ukr --map som.npz` ran the SOM, and `--experience none --map/--postures` ran without
    the experience given; both without a word."""
    from graspmanifold.cli import main

    gm.SOM(3, 3, seed=0).fit(POSTURES, epochs=2, progress=False).save(tmp_path / "som.npz")
    with pytest.raises(SystemExit, match=r"holds a som, not a ukr: pass --experience som"):
        main(["evaluate", "--object", "box", "--experience", "ukr", "--map", str(tmp_path / "som.npz"),
              "--out", str(tmp_path / "a")])
    with pytest.raises(SystemExit, match=r"--experience none runs without one"):
        main(["evaluate", "--object", "box", "--experience", "none", "--map", str(tmp_path / "som.npz"),
              "--out", str(tmp_path / "b")])
    with pytest.raises(SystemExit, match=r"--experience none runs without one"):
        main(["evaluate", "--object", "box", "--experience", "none", "--postures", str(tmp_path / "som.npz"),
              "--out", str(tmp_path / "c")])
    assert not any((tmp_path / name).exists() for name in "abc")  # refused before anything was written


@pytest.mark.parametrize("script, arguments, message", [
    ("study_planned_grasps.py", ["--plans", "0"], "error: plans must be a whole number in 1 ... 1000, got 0"),
    ("study_palm.py", ["--displaced", "-1"], "error: displaced must be a whole number in 1 ... 1000, got -1"),
    ("study_completion.py", ["--workers", "0"], "error: workers must be a positive whole number, got 0"),
])
def test_a_studys_bad_argument_ends_in_one_line(tmp_path, script, arguments, message):
    """The planned-grasp, palm and completion studies ended a bad argument in a traceback."""
    from pathlib import Path

    scripts = Path(__file__).resolve().parents[1] / "scripts"
    done = subprocess.run([sys.executable, str(scripts / script), *arguments, "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 1 and done.stderr.strip() == message
    assert not (tmp_path / "out").exists()


def test_the_null_experience_and_coverage_name_their_arguments():
    """`scrambled(seed=-1)` ended in NumPy's "expected non-negative integer"; `coverage` with (m, 3) palm poses in
    "cannot reshape array of size 6 into shape (7)"."""
    from graspmanifold.manifold.experience import scrambled
    from graspmanifold.trials.grid import covered, grid_preset

    with pytest.raises(gm.InvalidInput, match=r"seed must be a whole number >= 0, got -1"):
        scrambled(POSTURES, seed=-1)
    with pytest.raises(gm.InvalidInput, match=r"hand_poses must be at least one finite .* \(m, 7\).* got shape \(2, 3\)"):
        covered("box", grid_preset("quick", "box"), np.zeros((2, 3)))
    one = np.array([0.0, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0])  # one pose alone is still taken
    assert covered("box", grid_preset("quick", "box"), one).dtype == bool


def test_a_corrupt_ukr_file_is_named_for_what_is_wrong(tmp_path):
    """A UKR file with a NaN latent point was refused as "latent must be finite (40, 2), got (40, 2)"."""
    from graspmanifold.base.io import save_npz

    ukr = UKR(2, scales=2, iterations=3).fit(POSTURES, progress=False)
    arrays, meta = ukr._to_npz()
    arrays["latent"] = arrays["latent"].copy()
    arrays["latent"][3] = np.nan
    save_npz(tmp_path / "nan.npz", "ukr", arrays, meta)
    with pytest.raises(gm.InvalidInput, match=r"latent row 3 is not a finite point .* the file is corrupt"):
        UKR.load(tmp_path / "nan.npz")
    arrays["latent"] = arrays["latent"][:-1]
    save_npz(tmp_path / "short.npz", "ukr", arrays, meta)
    with pytest.raises(gm.InvalidInput, match=r"latent must be \(40, 2\), one point per posture, got \(39, 2\)"):
        UKR.load(tmp_path / "short.npz")


def test_a_dataset_report_without_trials_says_so(tmp_path):
    """A folder whose every object was refused got a report with two tables without a row, and a long folder's path
    filled the row's cell and cut the reason off."""
    from graspmanifold.cli import main

    folder = tmp_path / "junk"
    folder.mkdir()
    (folder / "cup.obj").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    assert main(["dataset", str(folder), "--out", str(tmp_path / "out")]) == 0
    report = (tmp_path / "out" / "dataset.md").read_text()
    assert "| cup | refused: mesh file 'cup.obj' is a PNG image, not a .obj mesh |" in report  # not cut off
    assert "No object got trials: nothing to compare." in report and "Every object's trials" not in report


def test_a_ukr_too_large_for_memory_is_refused_before_any_work():
    """A UKR fit of 30,000 postures ran out of memory (Isomap's n x n geodesics: 8,000 took 2.7 GB)."""
    from graspmanifold.manifold.ukr import MAX_POSTURES

    with pytest.raises(gm.InvalidInput, match=rf"at most {MAX_POSTURES} postures .* about 38 GB\); fit it on a subset"):
        UKR().fit(np.zeros((30_000, 22)))
    ukr = UKR(2, scales=2, iterations=3).fit(POSTURES, progress=False)
    with pytest.raises(gm.InvalidInput, match=rf"at most {MAX_POSTURES} postures"):
        ukr.resume(np.zeros((MAX_POSTURES, 22)))


def test_an_open_loop_of_no_grasp_and_places_that_are_not_finite_are_named():
    """`OpenLoop("plan")` was taken and refused only when the trials made their controllers; NaN places were refused
    as "got shape (40, 3)", the shape they had."""
    from graspmanifold.trials.open_loop import OpenLoop

    with pytest.raises(gm.InvalidInput, match=r"OpenLoop\.grasp must be an OpenLoopGrasp .* got str"):
        OpenLoop("plan")
    som = gm.SOM(3, 3, seed=0).fit(POSTURES, epochs=2, progress=False)
    places = np.zeros((40, 3))
    places[7, 1] = np.nan
    with pytest.raises(gm.InvalidInput, match=r"places must be finite positions in m, got \[0.0, nan, 0.0\] in row 7"):
        som.carry_places(POSTURES, places)
