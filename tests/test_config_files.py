"""Experiment files: a reproduction's configuration read from TOML into the validated dataclasses, and back."""

from pathlib import Path

import pytest

from graspmanifold.base.config_files import read_config, to_toml
from graspmanifold.control.controller import BLEND
from graspmanifold.paper.reproduce import PRESETS

ROOT = Path(__file__).resolve().parents[1]


def test_an_experiment_file_changes_the_preset_it_names(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text('postures = { box = 120, cylinder = 80 }\nmap_size = [10, 12]\nprotocol = "dexgraspbench"\n'
                    '[generator]\nmode = "recording"\n[controller]\nrecall = "base"\nmax_match_distance = 0.2\n')
    config = read_config(path, PRESETS["quick"])
    assert config.postures == {"box": 120, "cylinder": 80} and config.map_size == (10, 12)
    assert config.generator.mode == "recording" and config.controller == BLEND and config.protocol == "dexgraspbench"
    assert config.grid == PRESETS["quick"].grid  # what the file does not set stays the preset's


@pytest.mark.parametrize("name", ["quick", "paper", "verified"])
def test_a_written_configuration_reads_back_the_same(tmp_path, name):
    path = tmp_path / "config.toml"
    path.write_text(to_toml(PRESETS[name]))
    other = "paper" if name == "quick" else "quick"
    assert read_config(path, PRESETS[other]) == PRESETS[name]


@pytest.mark.parametrize("text, message", [
    ("maps = 3\n", "unknown key maps in the configuration; ReproduceConfig has postures"),
    ("[generator]\nwalk = 1\n", r"unknown key walk in \[generator\]"),
    ("map_size = [1, 1]\n", "map_size must be at least 2 x 4"),
    ("protocol = \"mine\"\n", "protocol must be one of"),
    ("grid = \n", "not TOML"),
])
def test_a_bad_experiment_file_is_named_with_what_is_wrong(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as caught:
        read_config(path, PRESETS["quick"])
    assert "bad.toml" in str(caught.value)
    with pytest.raises(ValueError, match="cannot be read"):
        read_config(tmp_path / "missing.toml", PRESETS["quick"])


def test_the_study_reads_its_configuration_from_a_file_and_renders_the_published_report(tmp_path):
    """The experience study was configured by flags alone; its report is rendered again from study.json, as
    published, with the folder and the report named in a TOML file."""
    import shutil

    from graspmanifold.studies.experience_study import ExperienceStudyConfig, main

    out, doc = tmp_path / "study", tmp_path / "report.md"
    out.mkdir()
    shutil.copy(ROOT / "docs" / "studies" / "experience_study.json", out / "study.json")
    config = tmp_path / "study.toml"
    config.write_text(f'out = "{out}"\ndoc = "{doc}"\n')
    main(["--config", str(config), "--render"])
    assert doc.read_text() == (ROOT / "docs" / "studies" / "experience_study.md").read_text()
    config.write_text("postures = 12\nobjects = ['box']\n")
    with pytest.raises(SystemExit, match="unknown key objects in the configuration; ExperienceStudyConfig has quick"):
        main(["--config", str(config), "--render"])
    with pytest.raises(ValueError, match="postures"):
        ExperienceStudyConfig(postures=-3)
