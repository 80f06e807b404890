"""Hardening, round five (issue 69): each case of RELIABILITY.md's round-five table, bad ones first; every test
failed before its fix."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.judging.protocols import DEXGRASPBENCH, PhysicsProfile, JudgingProtocol, pushed
from graspmanifold.judging.judge import JUDGING
from graspmanifold.judging.stages import JudgingRules
from graspmanifold.trials.grid import grid_preset


# bad 1: a step after the episode ended was judged again and paid again
def test_a_step_after_the_end_is_refused_until_reset():
    from graspmanifold.envs.tactile_grasp import EpisodeEnded, TactileGraspEnv

    env = TactileGraspEnv("box")
    with pytest.raises(EpisodeEnded, match="call reset"):
        env.step(env.action_space.sample())
    observation, _ = env.reset(seed=0)
    action = np.append(observation[:22], 1.0)  # hold still, and done: judged at once
    _, reward, terminated, _, info = env.step(action)
    assert terminated and info["judged"]
    with pytest.raises(EpisodeEnded, match="episode ended .* call reset"):
        env.step(action)
    import gymnasium
    with pytest.raises(gymnasium.error.ResetNeeded):  # Gymnasium's own error, for code written against it
        env.step(action)
    env.reset(seed=1)
    assert env.step(np.append(observation[:22], 0.0))[2] is False  # a new episode steps again


# bad 2: judging rules were never checked (a NaN stiffness, a negative hold ran to hold 100 %)
@pytest.mark.parametrize("field, value, message", [
    ("support_stiffness", math.nan, r"JudgingRules\.support_stiffness must be a finite number >= 0"),
    ("hold_seconds", -1.0, r"JudgingRules\.hold_seconds must be a finite number > 0"),
    ("hold_limit", 0.0, r"JudgingRules\.hold_limit must be a finite number > 0"),
    ("epsilon_threshold", math.inf, r"JudgingRules\.epsilon_threshold"),
    ("margin", "yes", r"JudgingRules\.margin must be True or False"),
    ("stages", (), r"JudgingRules\.stages must be a non-empty tuple"),
])
def test_judging_rules_are_checked_when_made(field, value, message):
    with pytest.raises(gm.InvalidInput, match=message):
        JudgingRules(**{field: value})
    with pytest.raises(gm.InvalidInput, match=message):  # a protocol of one's own is made of them
        JudgingProtocol("mine", replace(JUDGING, **{field: value}))


# bad 3: a test of zero length passed every grasp
@pytest.mark.parametrize("field, value, message", [
    ("hold_chunks", 0, r"DexGraspBenchProtocol\.hold_chunks must be a whole number >= 1"),
    ("steps_per_chunk", 2.5, r"DexGraspBenchProtocol\.steps_per_chunk must be a whole number"),
    ("directions", (), r"DexGraspBenchProtocol\.directions must hold at least one direction"),
    ("force_per_kg", math.nan, r"DexGraspBenchProtocol\.force_per_kg"),
    ("translation_limit", -0.05, r"DexGraspBenchProtocol\.translation_limit"),
])
def test_a_push_test_that_tests_nothing_is_refused(field, value, message):
    with pytest.raises(gm.InvalidInput, match=message):
        pushed(replace(DEXGRASPBENCH, **{field: value}))


def test_judging_directions_are_unit_vectors():
    """Poor: directions=() ended in an IndexError in stages.py; a direction of length 2 doubled the push."""
    with pytest.raises(gm.InvalidInput, match=r"JudgingRules\.directions must hold at least one direction"):
        JudgingRules(directions=())
    with pytest.raises(gm.InvalidInput, match=r"JudgingRules\.directions must be unit vectors"):
        JudgingRules(directions=((2.0, 0.0, 0.0),))
    assert JudgingRules(directions=[[0, 0, 1]]).directions == ((0.0, 0.0, 1.0),)


@pytest.mark.parametrize("field, value, message", [
    ("timestep", 0.0, r"PhysicsProfile\.timestep must be a finite number > 0"),
    ("integrator", "leapfrog", r"PhysicsProfile\.integrator must be one of"),
    ("condim", 5, r"PhysicsProfile\.condim must be one of"),
    ("friction", (0.6,), r"PhysicsProfile\.friction must be \(sliding, torsional\)"),
    ("friction", (-0.6, 0.02), r"PhysicsProfile\.friction\[0\]"),
    ("object_mass", 0.0, r"PhysicsProfile\.object_mass"),
    ("gravity", "off", r"PhysicsProfile\.gravity must be True or False"),
])
def test_a_physics_profile_is_checked_when_made(field, value, message):
    """Poor: a push physics with timestep=0 ended in a ZeroDivisionError in trial.py."""
    with pytest.raises(gm.InvalidInput, match=message):
        replace(DEXGRASPBENCH.physics, **{field: value})
    assert isinstance(replace(DEXGRASPBENCH.physics, timestep=0.002), PhysicsProfile)


def test_one_mechanism_checks_every_configuring_value():
    """The controller's, the regrasp's and the judging's settings say their ranges alike."""
    for make, message in ((lambda: gm.ControllerParams(closing_rate=math.nan), r"ControllerParams\.closing_rate"),
                          (lambda: gm.Regrasp(probe_seconds=-1.0), r"Regrasp\.probe_seconds"),
                          (lambda: JudgingRules(push=-1.0), r"JudgingRules\.push")):
        with pytest.raises(gm.InvalidInput, match=message + r" must be a finite number >[=]? 0"):
            make()


@pytest.mark.parametrize("action, message", [
    (np.zeros(22), r"an action must be 23 real numbers: the 22 joint targets .* shape \(22,\)"),
    (np.zeros(23, dtype=complex), r"an action must be 23 real numbers.* complex128"),
    (np.full(23, np.nan), r"actions must be finite"),
])
def test_single_environment_actions_are_checked(action, message):
    from graspmanifold.envs.tactile_grasp import TactileGraspEnv

    env = TactileGraspEnv("box")
    env.reset(seed=0)
    with pytest.raises(gm.InvalidInput, match=message):
        env.step(action)


@pytest.mark.parametrize("options, message", [
    ({"poses": [0.0, 0.0, 0.0, 0.0]}, r"unknown reset option\(s\) \['poses'\]; the options are \['pose'\]"),
    ({"pose": np.zeros((2, 4))}, r'options\["pose"\] must have shape \(4,\) or \(1, 4\).* got shape \(2, 4\)'),
    ("pose", r"options must be a dict"),
])
def test_single_environment_options_are_checked(options, message):
    from graspmanifold.envs.tactile_grasp import TactileGraspEnv

    with pytest.raises(gm.InvalidInput, match=message):
        TactileGraspEnv("box").reset(seed=0, options=options)


@pytest.mark.parametrize("arguments, message", [
    ({"table": "no"}, r"table must be True or False, got 'no'"),
    ({"pcp": 1}, r"pcp must be True or False"),
    ({"max_seconds": True}, r"max_seconds must be a finite number > 0 and at most 600 s, got True"),
    ({"camera": "bogus"}, r"camera must be one of .*'hand'.* got 'bogus'"),
])
def test_environment_arguments_are_checked_when_made(arguments, message):
    from graspmanifold.envs.tactile_grasp import TactileGraspEnv, TactileGraspVectorEnv

    with pytest.raises(gm.InvalidInput, match=message):
        TactileGraspEnv("box", **arguments)
    with pytest.raises(gm.InvalidInput, match="does not render" if "camera" in arguments else message):
        TactileGraspVectorEnv(2, object="box", **arguments)  # a camera given to it was dropped without a word


def test_vector_environment_poses_and_options_are_checked():
    """A (4, 2) pose array of a 2-world environment was reshaped to (2, 4), mixing the numbers."""
    from graspmanifold.envs.tactile_grasp import TactileGraspVectorEnv

    envs = TactileGraspVectorEnv(2, object="box")
    with pytest.raises(gm.InvalidInput, match=r'options\["poses"\] must have shape \(2, 4\).* got shape \(4, 2\)'):
        envs.reset(seed=0, options={"poses": np.zeros((4, 2))})
    with pytest.raises(gm.InvalidInput, match=r"unknown reset option\(s\) \['pose'\]"):
        envs.reset(seed=0, options={"pose": np.zeros(4)})
    observations, _ = envs.reset(seed=0)
    with pytest.raises(gm.InvalidInput, match=r"actions must have shape \(2, 23\), got \(23, 2\)"):
        envs.step(np.zeros((23, 2)))
    with pytest.raises(gm.InvalidInput, match=r"an action must be 23 real numbers.* complex"):
        envs.step(np.zeros((2, 23), dtype=complex))


def test_a_result_says_what_made_it(tmp_path):
    """evaluate's trials.npz and summary.json recorded neither the touch source nor the protocol, hand or controller:
    a `--touch sensors` result could not be told from a contacts one."""
    import json

    from graspmanifold.trials.evaluation import summary_json

    pose = grid_preset("quick", "box")[:1]
    som = gm.SOM(4, 4, seed=0).fit(np.random.default_rng(0).uniform(0, 1, (20, 22)), epochs=2, progress=False)
    made = {touch: gm.evaluate("box", som, pose, progress=False, touch=touch).made_by
            for touch in ("contacts", "sensors")}
    differs = {key for key in made["contacts"] if made["contacts"][key] != made["sensors"][key]}
    assert differs == {"touch"}
    record = made["sensors"]
    assert record["object"]["name"] == "box" and record["hand"]["digest"] and record["seed"] == 0
    assert record["protocol"]["name"] == "hold-test" and record["protocol"]["registered"]
    assert record["controller"]["name"] == "paper" and record["controller"]["params"]["closing_rate"] == 0.8
    assert record["experience"]["kind"] == "SOM" and record["experience"]["references"] == 16
    assert record["library_version"] == gm.__version__
    result = gm.evaluate("box", None, pose, progress=False, protocol="dexgraspbench")
    assert result.made_by["experience"]["kind"] == "none" and result.made_by["protocol"]["name"] == "dexgraspbench"
    result.save(tmp_path / "trials.npz")  # the file keeps it, and so does summary.json
    assert gm.EvaluationResult.load(tmp_path / "trials.npz").made_by == json.loads(json.dumps(result.made_by))
    assert json.loads(summary_json([result]))["results"][0]["made_by"]["protocol"]["name"] == "dexgraspbench"


def test_a_file_that_is_no_mesh_is_named_as_what_it_is(tmp_path, monkeypatch):
    """A PNG renamed .obj and a 134-byte STL declaring 2^32 - 1 triangles were refused with "No module named
    'charset_normalizer'" on a machine without that package."""
    import struct
    import sys

    monkeypatch.setitem(sys.modules, "charset_normalizer", None)  # a machine without it
    png = tmp_path / "cup.obj"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    stl = tmp_path / "cup.stl"
    stl.write_bytes(bytes(80) + struct.pack("<I", 2**32 - 1) + bytes(50))
    text = tmp_path / "cup.off"
    text.write_bytes(b"OFF\n3 1 0\n\0\0\0")
    for path, message in ((png, r"cup\.obj' is a PNG image, not a \.obj mesh"),
                          (stl, r"a binary STL of 4294967295 triangles has .* bytes, this one 134"),
                          (text, r"cup\.off' holds binary bytes; a \.off mesh is text")):
        with pytest.raises(gm.InvalidInput, match=message):
            gm.make_object("mesh", mesh=path, name="cup")


def test_a_full_disk_under_a_study_ends_in_one_line(tmp_path, monkeypatch, capsys):
    """A full disk under scripts/study_learning_curve.py ended in a 27-frame traceback (the CLI printed one line)."""
    import errno

    from graspmanifold.base import io
    from graspmanifold.studies.runner import run_study

    def full(_fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    def body(study):
        study.keep("result.json", "k", lambda: {"rate": 0.5}, lambda path: (io.json.loads(path.read_text()), {}),
                   lambda result, path, meta: io.write_text_atomic(path, io.json.dumps(result)))

    monkeypatch.setattr(io.os, "fsync", full)
    with pytest.raises(SystemExit) as ended:
        run_study(tmp_path / "study", 1, body, pool=False)
    line = str(ended.value.code)
    assert "\n" not in line and line.startswith("error: cannot write ") and "No space left on device" in line
    assert "run the same command again to resume" in line
    assert not list(tmp_path.rglob("*" + io.TEMPORARY_SUFFIX))  # nothing half-written
    with pytest.raises(OSError, match="bug"):  # another OSError is a bug and keeps its traceback
        from graspmanifold.studies.runner import run_command
        run_command(tmp_path, lambda: (_ for _ in ()).throw(OSError("bug")))


def test_a_broken_egl_on_the_loader_path_does_not_kill_the_import(tmp_path):
    """A broken libEGL on the loader path killed `import graspmanifold` inside MuJoCo's import (the library chose
    egl because it found the library)."""
    import ctypes.util
    import os
    import subprocess
    import sys

    if not ctypes.util.find_library("EGL"):
        pytest.skip("no libEGL on this machine: the library never chooses egl here")
    broken = tmp_path / "libEGL.so.1"
    broken.write_bytes(b"not a shared library" * 50)
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY")}
    env["LD_LIBRARY_PATH"] = str(tmp_path)
    done = subprocess.run([sys.executable, "-c", "import os, graspmanifold; print(os.environ.get('MUJOCO_GL'))"],
                          env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() != "egl"
    assert "the offscreen OpenGL library libEGL" in done.stderr and "cannot be used" in done.stderr


def test_the_literal_controller_trace_has_a_quick_run(tmp_path, capsys):
    """scripts/trace_literal_controller.py had no --quick like the other studies."""
    from graspmanifold.manifold.postureset import PostureSet
    from graspmanifold.studies.recall_trace import QUICK_POSES, main

    limits = gm.SHADOW_HAND.limits()
    n = 30
    postures = np.random.default_rng(0).uniform(limits[:, 0], limits[:, 1], (n, 22))
    PostureSet(postures, np.tile([0, 0, 0, 1.0, 0, 0, 0], (n, 1)), np.zeros(n, dtype=int),
               np.zeros((n, len(gm.SEGMENTS)), dtype=bool), ("start",)).save(tmp_path / "experience_pen.npz")
    with pytest.raises(SystemExit):
        main(["--quick", "--all", "--experience", str(tmp_path)])
    assert "--quick traces one cell" in capsys.readouterr().err
    main(["--quick", "--experience", str(tmp_path), "--out", str(tmp_path / "trace")])
    report = (tmp_path / "trace" / "recall_trace.md").read_text()
    assert f"({QUICK_POSES} test poses)" in report and "| the blend against the paper's controller | 3 |" in report


def test_compare_gives_the_difference_with_its_interval():
    """gm.compare gave counts and McNemar's p but no difference of rates with its interval, which a paper needs."""
    from graspmanifold.trials.stats import PairedComparison

    paired = PairedComparison(30, 24, 3, 1, 2, 0.625)
    low, high = paired.difference_interval()
    assert -1 <= low < paired.difference < high <= 1
    swapped = PairedComparison(30, 24, 1, 3, 2, 0.625).difference_interval()
    assert swapped == pytest.approx((-high, -low))  # A against B is B against A turned round
    assert str(paired).startswith(f"+6.7 pts [{100 * low:+.1f}, {100 * high:+.1f}] on 30 paired poses (+3 / -1, McNemar")
    assert PairedComparison(10, 0, 10, 0, 0, 0.002).difference_interval()[1] == 1.0  # stays inside [-1, 1]
    rng = np.random.default_rng(0)  # it covers the true difference about as often as it says
    probabilities, n, covered = [0.5, 0.15, 0.05, 0.3], 50, 0
    for _ in range(2000):
        a, b, c, d = rng.multinomial(n, probabilities)
        low, high = PairedComparison(n, a, b, c, d, 1.0).difference_interval()
        covered += low <= 0.10 <= high
    assert 0.91 <= covered / 2000 <= 0.98


def test_the_rates_figure_shows_every_method_with_its_legend_apart():
    """figures/rates.png had its legend over both panels and cut off (two methods not visible), and the run printed
    "constrained_layout not applied because axes sizes collapsed to zero"."""
    import warnings

    from graspmanifold.paper.figures import rates_figure

    methods = ("none", "som", "som_all", "database", "database_blend", "som_blend")
    summaries = [{"object": "cylinder", "method": m, "hold_rate": 0.9, "force_closure_rate": 0.8, "trials": 30}
                 for m in methods]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        figure = rates_figure(summaries, methods)
        figure.canvas.draw()
    legend = figure.legends[0]
    assert [t.get_text() for t in legend.get_texts()] == list(methods)
    box = legend.get_window_extent()
    canvas = figure.bbox
    assert canvas.x0 <= box.x0 and box.x1 <= canvas.x1 and canvas.y0 <= box.y0  # all of it on the canvas
    assert all(box.y1 <= ax.get_window_extent().y0 for ax in figure.axes)  # below the panels, over neither


def test_the_guides_status_is_a_table_one_can_scan():
    """The guide's status table had a row over 2,000 characters; its paragraphs were too dense to scan."""
    from pathlib import Path

    status = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "status.md").read_text()
    rows = [line for line in status.splitlines() if line.startswith("| ")]
    assert len(rows) > 20 and max(map(len, rows)) < 250
    assert max(map(len, status.splitlines())) < 300  # the details as wrapped bullet points, one part at a time
