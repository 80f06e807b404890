"""What a notebook user touches first: attributes, array-likeness, reprs, figures and the command line."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.cli import DEFAULT_WORKERS, build_parser, main as cli


@pytest.fixture(scope="module")
def postures():
    return gm.generate_postures("cylinder", 12, seed=0, params=gm.GeneratorParams(verify=False, job_size=6))


def test_submodules_are_reachable_from_the_package():
    assert callable(gm.plots.plot_lattice) and callable(gm.stats.wilson_interval) and callable(gm.stats.compare)
    with pytest.raises(AttributeError, match="no attribute 'teapot'"):
        gm.teapot  # noqa: B018


def test_a_posture_set_goes_wherever_postures_do(postures):
    assert np.asarray(postures).shape == (12, 22) and len(postures) == 12
    assert postures[3].shape == (22,) and np.array_equal(postures[3], postures.postures[3])
    part = postures[2:5]
    assert isinstance(part, gm.PostureSet) and len(part) == 3
    assert gm.SOM(3, 3, 22, seed=0).fit(postures, epochs=2).is_fitted
    controller = gm.GraspController(postures)
    assert isinstance(controller.experience, gm.PostureDatabase) and len(controller.experience.postures) == 12
    result = gm.evaluate("cylinder", postures, np.array([[0.0, 0.0, 0.01, 0.0]]))
    assert result.method == "database"


def test_reprs_are_short_and_say_what_matters(postures):
    result = gm.evaluate("cylinder", None, np.array([[0.0, 0.0, 0.01, 0.0]]))
    objects = [postures, result, result.trials[0], gm.Scene("box"), gm.GraspController(), gm.SOM(3, 3, 22),
               gm.PostureDatabase(postures.postures)]
    for obj in objects:
        text = repr(obj)
        assert len(text) < 200 and "object at 0x" not in text, text
    assert "12 postures of cylinder" in repr(postures) and "hold" in repr(result)
    assert result._repr_markdown_().startswith("| object | method |")


def test_plots_without_axes_make_a_pyplot_figure(postures):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    before = set(plt.get_fignums())
    ax = gm.plots.plot_lattice(gm.SOM(3, 3, 22, seed=0).fit(postures, epochs=2))
    assert ax.figure.number in set(plt.get_fignums()) - before
    plt.close(ax.figure)


def test_the_command_line_is_consistent(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli(["--version"])
    assert exit_.value.code == 0 and gm.__version__ in capsys.readouterr().out
    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    for name in ("reproduce", "generate", "evaluate"):
        args = commands[name].parse_args(["--out", "x.npz"])
        assert args.workers == DEFAULT_WORKERS
        assert getattr(args, "preset", "quick") == "quick"
    assert "(default: quick)" in commands["generate"].format_help().replace("\n", " ").replace("  ", " ")
    with pytest.raises(SystemExit, match="--experience must be none, one of .* or a trained file .* got 'oracle'"):
        cli(["evaluate", "--experience", "oracle", "--out", "x"])


def test_a_scene_draws_itself_from_named_cameras():
    from graspmanifold.sim.scene import CAMERAS

    scene = gm.Scene("cylinder")
    scene.set_hand_pose(*gm.facing_pose("cylinder"))
    pictures = {name: scene.render(name, 96, 64) for name in CAMERAS}
    for name, picture in pictures.items():
        assert picture.shape == (64, 96, 3) and picture.dtype == np.uint8 and picture.std() > 10, name
    assert np.abs(pictures["hand"].astype(int) - pictures["top"]).mean() > 5  # other viewpoints, other pictures
    assert scene._repr_png_().startswith(b"\x89PNG")
    with pytest.raises(ValueError, match="unknown camera"):
        scene.render("ceiling")
    with pytest.raises(ValueError, match="width"):
        scene.render("hand", width=0)


def test_a_recorded_trial_is_the_evaluated_trial_and_animates(tmp_path):
    pose = (0.0, 0.0, 0.01, 0.0)
    recording = gm.record_trial("box", None, pose, seed=5, every=10)
    evaluated = gm.evaluate("box", None, np.array([pose]), seed=5).trials[0]
    assert recording.trial.hold == evaluated.hold
    assert np.array_equal(recording.trial.posture, evaluated.posture)
    assert len(recording.states) > 10 and recording.period == pytest.approx(0.2)
    path = recording.save_gif(tmp_path / "grasp.gif", width=64, height=48)
    from PIL import Image

    with Image.open(path) as gif:
        assert gif.n_frames > 5 and gif.size == (64, 48)
    with pytest.raises(ValueError, match="every"):
        gm.record_trial("box", every=0)


def test_progress_is_on_by_default_with_one_switch_and_a_rate_that_reads_right(capsys):
    """Long jobs were silent from Python unless asked (progress=False), and a slow bar read "2.06s/ trials"."""
    import time

    from graspmanifold.base.progress import progress_bar

    assert "plots" in dir(gm) and "show_progress" in gm.__all__
    previous = gm.show_progress(True)
    try:
        with progress_bar(2, "evaluate box / som", "trials", enabled=None) as bar:
            time.sleep(2.2)  # a bar appears once a job has run 2 s
            bar.update(2)
        shown = capsys.readouterr().err
        assert "evaluate box / som" in shown and " trials/s" in shown and "s/ trials" not in shown
        gm.show_progress(False)
        with progress_bar(2, "silent", "trials", enabled=None) as bar:
            time.sleep(2.2)
            bar.update(2)
        assert "silent" not in capsys.readouterr().err
    finally:
        gm.show_progress(previous)


def test_pictures_after_the_first_reuse_one_drawing_process_which_comes_back_if_killed():
    """Every picture used to start a child process (about 7 s each, a notebook's _repr_png_ too). The child
    path (MuJoCo imported before the library, or no in-process context) keeps one child for later pictures."""
    import os
    import signal

    from graspmanifold.sim import render

    scene = gm.Scene("cylinder")
    state = scene.state()[None]
    first = render.render_states(scene, state, "hand", 64, 48, backends=render.BACKENDS)[0]
    (child,) = [render._drawing[b] for b in render.BACKENDS if b in render._drawing]
    again = render.render_states(scene, state, "hand", 64, 48, backends=render.BACKENDS)[0]
    assert np.array_equal(again, first) and child.process.poll() is None
    assert [render._drawing[b] for b in render.BACKENDS if b in render._drawing] == [child]
    os.kill(child.process.pid, signal.SIGKILL)
    assert np.array_equal(render.render_states(scene, state, "hand", 64, 48, backends=render.BACKENDS)[0], first)
    (fresh,) = [render._drawing[b] for b in render.BACKENDS if b in render._drawing]
    assert fresh is not child and fresh.process.poll() is None
    assert scene.render("hand", 64, 48).shape == (48, 64, 3)  # the default route: in this process, or the child
    assert "<mujoco" in scene.to_xml() and "cylinder" in scene.to_xml()


def test_a_headless_import_chooses_the_offscreen_backend_for_pictures_in_this_process(tmp_path):
    """MUJOCO_GL set before MuJoCo's import, where it is unset and there is no display; left alone otherwise."""
    import ctypes.util
    import os
    import subprocess
    import sys

    code = "import os, graspmanifold; print(os.environ.get('MUJOCO_GL'))"
    base = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY",
                                                             "PYOPENGL_PLATFORM")}
    expected = "egl" if ctypes.util.find_library("EGL") else "osmesa" if ctypes.util.find_library("OSMesa") else "None"
    for env, chosen in ((base, expected), ({**base, "MUJOCO_GL": "osmesa"}, "osmesa"),
                        ({**base, "DISPLAY": ":0"}, "None")):
        done = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 0 and done.stdout.strip() == chosen, (env.get("MUJOCO_GL"), done.stderr[-500:])



def test_long_jobs_use_the_commands_default_workers_and_small_ones_stay_in_this_process(monkeypatch):
    """From Python every job ran on one worker while the command used two."""
    from graspmanifold.base import workers
    from graspmanifold.cli import DEFAULT_WORKERS

    assert DEFAULT_WORKERS == workers.default_workers()  # the command's default is the library's
    monkeypatch.setattr(workers, "usable_cores", lambda: 8)
    assert workers.default_workers() == 2
    assert workers.workers_for(None, 500, 16) == 2 and workers.workers_for(None, 10, 16) == 1
    assert workers.workers_for(3, 10, 16) == 3  # what the caller asks for, it gets
    monkeypatch.setattr(workers, "usable_cores", lambda: 1)
    assert workers.workers_for(None, 500, 16) == 1


def test_the_viewer_says_it_needs_a_display(monkeypatch):
    import sys

    from graspmanifold.sim.render import RenderingUnavailable

    if not sys.platform.startswith("linux"):
        pytest.skip("the display check is Linux's")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RenderingUnavailable, match="needs a display"):
        gm.Scene("cylinder").viewer()
