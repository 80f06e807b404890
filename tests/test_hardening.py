"""The third hardening round (RELIABILITY.md, "Round three"): no stale result from an edited file, no name that
deletes or escapes its store, no file that inflates beyond its size, no runaway worker count, and the
catalogued command-line mistakes each in one line with nothing left behind."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time
import tracemalloc
import zipfile
from pathlib import Path
from dataclasses import replace

import numpy as np
import pytest
import trimesh

import graspmanifold as gm
from graspmanifold.base.checkpoints import PartStore
from graspmanifold.base.io import save_npz
from graspmanifold.base.workers import usable_cores, workers_for
from graspmanifold.cli import main as cli
from graspmanifold.sim.hand import SHADOW_HAND
from graspmanifold.sim.hand_models import hand_model
from graspmanifold.trials.benchmark import run_benchmark
from graspmanifold.trials.setup import TrialSetup

ROOT = Path(__file__).resolve().parents[1]


def _hand_file(folder: Path, servo_gain: float = 1.0, marker: float = 1.0) -> Path:
    """Our hand as a file of one's own, its servos' gains scaled by `servo_gain`; it includes `extra.xml` (a
    numeric `marker`), so that an edit of the included file alone can be told apart."""
    spec = SHADOW_HAND.spec()
    for actuator in spec.actuators:
        actuator.gainprm[0] *= servo_gain
        actuator.biasprm[1] *= servo_gain
    xml = spec.to_xml().replace("<worldbody>", '<include file="extra.xml"/>\n  <worldbody>', 1)
    (folder / "extra.xml").write_text(f'<mujoco><custom><numeric name="marker" data="{marker}"/></custom></mujoco>')
    (folder / "mine.xml").write_text(xml)
    return folder / "mine.xml"


# -- results keyed by content ------------------------------------------------------------------------------

def test_a_hand_file_edited_in_place_gives_new_results_never_the_old_files(tmp_path):
    """A hand given by path entered every result key by its path: after its servos were weakened 40x in the file,
    an evaluation into the same checkpoint folder reported the old hand's trials (and `hand_model` returned the
    old model)."""
    path = _hand_file(tmp_path)
    strong = hand_model(path)
    poses = gm.grid_preset("quick", "cylinder")[:2]
    checkpoints = tmp_path / "parts"
    before = gm.evaluate("cylinder", None, poses, hand=path, workers=1, checkpoint_dir=checkpoints, progress=False)

    _hand_file(tmp_path, servo_gain=1 / 40)
    weak = hand_model(path)
    assert weak is not strong and weak.digest != strong.digest
    assert weak.model.actuator_gainprm[0, 0] == pytest.approx(strong.model.actuator_gainprm[0, 0] / 40)
    with pytest.warns(UserWarning, match="discarded .* another configuration"):
        after = gm.evaluate("cylinder", None, poses, hand=path, workers=1, checkpoint_dir=checkpoints, progress=False)
    final = lambda result: np.array([trial.posture for trial in result.trials])  # noqa: E731
    assert not np.allclose(final(before), final(after))  # the weak hand's own trials, not the old ones

    _hand_file(tmp_path, servo_gain=1 / 40, marker=2.0)  # only the included file changes
    assert hand_model(path).digest != weak.digest
    assert TrialSetup(object="cylinder", hand=hand_model(path)).key(poses, 0) != TrialSetup(object="cylinder", hand=weak).key(poses, 0)


def test_the_studys_experience_is_kept_under_the_key_of_what_made_it(tmp_path, monkeypatch):
    """`study_experience.py --postures 3` after a 7-posture run reused the 7-posture files, and study.json said 3."""
    from graspmanifold.studies import experience_study as study_module

    study = study_module.ExperienceStudy(study_module.ExperienceStudyConfig(quick=True, out=str(tmp_path), workers=1,
                                                                            postures=1))
    study.objects = ("box",)
    union, _ = study.experience()
    assert len(union) == 1
    study.config = replace(study.config, postures=2)
    with pytest.warns(UserWarning, match="discarded .*experience_box.npz"):
        union, _ = study.experience()
    assert len(union) == 2
    ran = []
    monkeypatch.setattr(study_module, "generate_postures", lambda *a, **k: ran.append(a))
    union, _ = study.experience()  # the same configuration: taken from --out
    assert len(union) == 2 and ran == [] and study.reused == 1 and study.computed == 2


# -- names that become file names --------------------------------------------------------------------------

@pytest.mark.parametrize("label", ["*", "som[all]", "../escape", "/tmp/anywhere", "a/b", ".hidden", "x" * 101])
def test_a_benchmark_label_that_would_glob_or_escape_its_store_is_refused(tmp_path, label):
    """`label="*"` deleted every other label's stored cells, `"som[all]"` those of label `soma`, `"../escape"`
    wrote outside the store."""
    store = tmp_path / "store"
    store.mkdir()
    others = [store / "none_test_pen_palm.npz", store / "soma_test_pen_palm.npz"]
    for other in others:
        other.write_bytes(b"another label's cell")
    with pytest.raises(ValueError, match="method becomes part of a file name"):
        run_benchmark(None, objects=("pen",), every=25, store=store, method=label)
    assert all(other.read_bytes() == b"another label's cell" for other in others)
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["none_test_pen_palm.npz", "soma_test_pen_palm.npz", "store"]


def test_the_part_store_matches_names_whole_and_removes_only_its_own_names(tmp_path):
    (tmp_path / "soma_test_pen_palm.npz").write_bytes(b"not ours to delete")
    (tmp_path / "som[a]_test_pen_palm.npz").write_bytes(b"truncated part of this name")
    store = PartStore(tmp_path, "key", lambda path: (None, {}))
    with pytest.warns(UserWarning, match="discarded 1"):
        assert store.load("som[a]_test_pen_palm.npz") == {}
    assert [p.name for p in tmp_path.iterdir()] == ["soma_test_pen_palm.npz"]


# -- files that inflate beyond their size ------------------------------------------------------------------

def _bomb(path: Path, kind: str, member: str, inflated: int) -> None:
    """A valid file of `kind` whose `member` array is `inflated` bytes of zeros, deflated to about a thousandth."""
    save_npz(path, kind, {}, {})
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as archive:
        info = zipfile.ZipInfo(f"{member}.npy")
        info.compress_type = zipfile.ZIP_DEFLATED
        with archive.open(info, "w", force_zip64=True) as out:
            np.lib.format.write_array_header_1_0(out, {"descr": "<f8", "fortran_order": False,
                                                       "shape": (inflated // 8 // 22, 22)})
            chunk = bytes(2**22)
            for _ in range(inflated // len(chunk)):
                out.write(chunk)


@pytest.mark.parametrize("load, kind, member", [(gm.SOM.load, "som", "weights"),
                                                (gm.PostureSet.load, "posture_set", "postures")])
def test_a_zip_bomb_is_refused_before_it_is_inflated(tmp_path, load, kind, member):
    """A 1 MB SOM .npz whose member inflates to 2.3 GB was read whole (27 s, 2.3 GB resident) before it was
    refused; so was a posture set. Here 128 MiB from about 128 KiB, under a 32 MiB limit on what the load allocates."""
    from graspmanifold.base.io import MAX_INFLATION

    path = tmp_path / f"{kind}.npz"
    _bomb(path, kind, member, 2**27)
    assert path.stat().st_size * MAX_INFLATION < 2**27
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="would inflate to .*zip bomb"):
            load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 * 2**20, f"the refused load allocated {peak / 2**20:.0f} MiB"


# -- worker counts -----------------------------------------------------------------------------------------

def test_worker_counts_are_capped_at_the_cores_and_the_job_with_a_warning():
    """`generate --n 2 --workers 100000` started about 20 worker processes a second and printed nothing."""
    from graspmanifold.base.workers import WORKERS_PER_CORE

    with pytest.warns(UserWarning, match="workers=100000 is more than this job can use .*: running 2"):
        assert workers_for(100000, 2, 50) == 2
    with pytest.warns(UserWarning, match="running"):
        assert workers_for(100000, 10**6, 50) == WORKERS_PER_CORE * usable_cores()
    assert workers_for(2, 10**6, 50) == 2 and workers_for(None, 10, 50) == 1


# -- the command line's catalogued mistakes: one line, nothing left behind ---------------------------------

def _junk_server() -> int:
    """A port on which something answers every connection with junk (a Dask client read a 3 EiB frame from it)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)

    def answer():
        while True:
            connection, _ = server.accept()
            try:
                connection.sendall(b"\xff" * 4096)
            except OSError:
                pass
            connection.close()

    threading.Thread(target=answer, daemon=True).start()
    return server.getsockname()[1]


@pytest.fixture
def mistakes(tmp_path):
    """A folder of the files the mistakes name."""
    os.symlink("loop.xml", tmp_path / "loop.xml")
    os.symlink("loop", tmp_path / "loop")
    os.mkfifo(tmp_path / "fifo.stl")
    (tmp_path / "picture.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    (tmp_path / "mesh.stlx").write_bytes(b"solid x\nendsolid x\n")
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><body name='a'><joint/></body></worldbody></mujoco>")
    one = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    trimesh.util.concatenate([one, one.copy().apply_translation((0.06, 0, 0))]).export(tmp_path / "two.stl")
    spec = SHADOW_HAND.spec()
    spec.delete(spec.actuator("A_THJ1"))
    (tmp_path / "no_thj1.xml").write_text(spec.to_xml())
    return tmp_path


CLI_MISTAKES = [
    (["demo", "--hand", "{tmp}/loop.xml"], "hand: cannot read .*loop.xml: Symlink loop"),
    (["generate", "--hand", "{tmp}/bad.xml", "--n", "2", "--out", "{tmp}/out.npz"], "--hand: .*root body"),
    (["generate", "--hand", "{tmp}/no_thj1.xml", "--n", "2", "--out", "{tmp}/out.npz"], "no actuator for THJ1"),
    (["reproduce", "--hand", "{tmp}/bad.xml", "--out", "{tmp}/run"], "root body"),
    (["reproduce", "--workers", "0", "--out", "{tmp}/run"], "--workers must be a positive whole number"),
    (["reproduce", "--objects", "teapot", "--out", "{tmp}/run"], "unknown object 'teapot'"),
    (["evaluate", "--object", "teapot", "--out", "{tmp}/eval"], "--object: unknown object"),
    (["evaluate", "--experience", "none", "--executor", "bogus://x", "--out", "{tmp}/eval"],
     "--executor: executor address must be"),
    (["evaluate", "--experience", "none", "--executor", "dask://tcp://localhost:port", "--out", "{tmp}/eval"],
     "--executor: executor address must be"),
    (["evaluate", "--experience", "none", "--executor", "dask://tcp://127.0.0.1:{junk}", "--out", "{tmp}/eval"],
     "--executor: cannot connect to a Dask scheduler"),
    (["evaluate", "--experience", "none", "--out", "{tmp}/loop"], "symbolic link that leads nowhere"),
    (["evaluate", "--experience", "som", "--som", "/dev/zero", "--out", "{tmp}/eval"], "/dev/zero is a device"),
    (["evaluate", "--experience", "som", "--som", "{tmp}/fifo.stl", "--out", "{tmp}/eval"], "is a FIFO"),
    (["evaluate", "--experience", "ukr", "--map", "{tmp}/picture.png", "--out", "{tmp}/eval"],
     "not a readable .npz file of graspmanifold's"),
    (["evaluate", "--experience", "database", "--postures", "{tmp}/absent.npz", "--out", "{tmp}/eval"],
     "no such file: .*absent.npz"),
    (["demo", "--object", "{tmp}/picture.png"], ".png is not a mesh format"),
    (["demo", "--object", "{tmp}/mesh.stlx"], ".stlx is not a mesh format"),
    (["demo", "--object", "/dev/zero"], "/dev/zero is a device"),
    (["demo", "--object", "{tmp}/fifo.stl"], "is a FIFO"),
    (["demo", "--object", "{tmp}/two.stl"], "2 separate solids"),
    (["demo", "--seconds", "1e9"], "--seconds must be a positive duration of at most 60"),
    (["demo", "--seconds", "nan"], "--seconds must be a positive duration"),
    (["generate", "--n", "100000000000000000000000", "--out", "{tmp}/out.npz"], "--n must be a whole number in 1"),
    (["generate", "--n", "2", "--workers", "-3", "--out", "{tmp}/out.npz"], "--workers must be a positive"),
]


@pytest.mark.parametrize("args, message", CLI_MISTAKES, ids=[" ".join(a)[:60] for a, _ in CLI_MISTAKES])
def test_each_catalogued_mistake_ends_in_one_line_and_leaves_nothing_behind(mistakes, args, message):
    """Each was a traceback, a misleading message, or left a lock file, an empty --out or run.json behind."""
    before = sorted(p.name for p in mistakes.iterdir())
    port = _junk_server() if any("{junk}" in a for a in args) else 0
    with pytest.raises(SystemExit) as refused:
        cli([a.format(tmp=mistakes, junk=port) for a in args])
    text = str(refused.value.code)
    assert text.startswith("error: ") and "\n" not in text and "Traceback" not in text, text
    assert __import__("re").search(message, text), text
    assert sorted(p.name for p in mistakes.iterdir()) == before  # no lock, folder, run.json or stages/ left


def test_a_full_disk_while_the_lock_is_written_ends_in_one_line(tmp_path, monkeypatch):
    from graspmanifold.base import io

    real_open = open

    def full(path, *args, **kwargs):
        if str(path).endswith(".lock"):
            raise OSError(28, "No space left on device")
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr("builtins.open", full)
    with pytest.raises(SystemExit, match=r"^error: cannot write .*\.out\.npz\.lock: No space left on device"):
        cli(["generate", "--n", "2", "--no-verify", "--workers", "1", "--out", str(tmp_path / "out.npz")])
    monkeypatch.undo()
    assert list(tmp_path.iterdir()) == [] and io.LOCK_FILE


def _command(*args: str, env: dict | None = None, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "GRASPMANIFOLD_PROGRESS": "0", **(env or {})}, **kwargs)


def test_a_bad_environment_is_named_and_does_not_stop_what_it_does_not_touch(tmp_path):
    """`MUJOCO_GL=bogus` killed even `demo`, which draws nothing (MuJoCo's import raised); unknown values of
    GRASPMANIFOLD_COMPILED and GRASPMANIFOLD_PROGRESS were taken without a word."""
    demo = _command("-m", "graspmanifold.cli", "demo", "--seconds", "0.2", env={"MUJOCO_GL": "bogus"})
    out, err = demo.communicate(timeout=120)
    assert demo.returncode == 0 and "segments touch the object" in out, err
    assert "MUJOCO_GL='bogus' is not a value MuJoCo takes" in err and "Traceback" not in err
    switches = _command("-c", "from graspmanifold.base.progress import progress_bar\n"
                        "from graspmanifold.base.compiled import compiled\n"
                        "progress_bar(1, 'x', 'y').__enter__(); print(compiled())",
                        env={"GRASPMANIFOLD_COMPILED": "sometimes", "GRASPMANIFOLD_PROGRESS": "maybe"})
    out, err = switches.communicate(timeout=120)
    assert switches.returncode == 0 and out.strip() == "True", err
    assert "GRASPMANIFOLD_COMPILED='sometimes' is neither on" in err and "GRASPMANIFOLD_PROGRESS='maybe'" in err


def test_ctrl_c_of_the_study_script_ends_in_one_line_and_its_output_is_locked(tmp_path):
    """Ctrl-C of the study script ended in a traceback, and two studies could write one --out."""
    from graspmanifold.base.io import LOCK_FILE, output_lock

    out = tmp_path / "study"
    with output_lock(out / LOCK_FILE, out):
        second = _command(str(ROOT / "scripts" / "study_experience.py"), "--quick", "--out", str(out), cwd=tmp_path)
        _, err = second.communicate(timeout=120)
    assert second.returncode == 1 and err.strip().startswith("error: ") and "being written by another" in err, err
    study = _command(str(ROOT / "scripts" / "study_experience.py"), "--quick", "--workers", "1", "--out", str(out),
                     cwd=tmp_path, start_new_session=True,
                     # a shell starts a background job with SIGINT ignored, and Python then never installs its
                     # handler: the study under test gets Ctrl-C's default, as in a terminal
                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while not (out / LOCK_FILE).exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(3)  # inside the work
    os.killpg(study.pid, signal.SIGINT)  # as a terminal's Ctrl-C: to the whole process group
    try:
        _, err = study.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        study.kill()
        _, err = study.communicate()
        raise AssertionError(f"the study did not end within 120 s of Ctrl-C; its stderr: {err[-2000:]}") from None
    assert study.returncode == 130 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1].startswith("interrupted: finished work is kept in")


# -- input the library took without a word -----------------------------------------------------------------

def test_input_that_was_taken_without_a_word_is_refused_or_named(tmp_path):
    one = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    with pytest.raises(ValueError, match="2 separate solids that do not touch"):  # overlapping ones are joined
        gm.make_object("mesh", mesh=trimesh.util.concatenate([one, one.copy().apply_translation((0.06, 0, 0))]))
    one.export(tmp_path / "box.stl")
    assert gm.make_object("mesh", mesh=tmp_path / "box.stl").name == "box_mesh"  # not the paper's box
    for data in (np.ones((8, 22), bool), np.ones((8, 22), complex)):
        with pytest.raises(ValueError, match="X must hold real numbers"):
            gm.SOM(2, 4, 22).fit(data, epochs=1, progress=False)
    from graspmanifold.sim.render import render_postures

    with pytest.raises(ValueError, match="postures row 0 has non-finite values"):
        render_postures(np.full((1, 22), np.nan))  # was "no offscreen OpenGL context"
    with pytest.raises(ValueError, match="size \\(pixels\\) must be a whole number in 16"):
        render_postures(np.zeros((1, 22)), size=0)
    huge = trimesh.creation.icosphere(subdivisions=7, radius=0.03)  # 327,680 triangles (655k vertices: 49 s)
    with pytest.raises(ValueError, match="327680 triangles, more than 200000: simplify it first"):
        gm.make_object("mesh", mesh=huge)


def test_view_without_a_display_says_so_in_one_line(monkeypatch):
    """`view` on a machine without a display printed GLFW's two lines and MuJoCo's log."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(SystemExit, match="^error: view opens a window and needs a display"):
        cli(["view"])
