"""What a notebook user touches first: attributes, array-likeness, reprs, figures and the command line."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.cli import DEFAULT_WORKERS, build_parser
from graspmanifold.cli import main as cli


@pytest.fixture(scope="module")
def postures():
    return gm.generate_postures("cylinder", 12, seed=0, params=gm.GeneratorParams(verify=False, job_size=6))


def test_submodules_are_reachable_from_the_package():
    assert callable(gm.plots.plot_lattice) and callable(gm.stats.wilson_interval) and callable(gm.study.compare)
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
    with pytest.raises(SystemExit):
        cli(["evaluate", "--experience", "oracle", "--out", "x"])
    assert "invalid choice: 'oracle'" in capsys.readouterr().err
