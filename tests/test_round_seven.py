"""Hardening, round seven (issue 88): a dataset folder is read as itself and no object file can hang or flood the
machine. Each bad case of RELIABILITY.md's round-seven table has its test here, failing before its fix (bad cases 1
and 2, places and one's own rule in a trial's key, are in tests/test_fair_benchmark.py)."""

from __future__ import annotations

import json
import os
import signal

import pytest
import trimesh

import graspmanifold as gm
from graspmanifold.manifold.experience import check_places
from graspmanifold.manifold.representations import load_representation
from graspmanifold.sim.object_files import MAX_GEOMS, object_file_references
from graspmanifold.studies.dataset import load_object, object_files, object_names

MJCF = ('<mujoco><asset><mesh name="m" file="{file}"/></asset><worldbody><body><geom type="mesh" mesh="m"/></body>'
        '</worldbody></mujoco>')
URDF = ('<robot name="r"><link name="base_link"><collision><geometry><mesh filename="{file}"/></geometry></collision>'
        '</link></robot>')


def _box(path, size=(0.05, 0.04, 0.1)):
    trimesh.creation.box(extents=size).export(path)


@pytest.fixture
def alarm():
    """A test that would hang fails instead, after 60 s."""
    def stop(*_):
        raise TimeoutError("hung: the object file's FIFO was opened")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def test_an_object_file_that_names_a_fifo_is_refused_before_mujoco_opens_it(tmp_path, alarm):
    """Bad case 3: MuJoCo opened the FIFO before the library's check and waited for ever."""
    os.mkfifo(tmp_path / "pipe.stl")
    (tmp_path / "object.xml").write_text(MJCF.format(file="pipe.stl"))
    with pytest.raises(gm.InvalidInput, match=r"object.xml.*pipe.stl is a FIFO \(named pipe\), not a file"):
        gm.make_object("mesh", mesh=tmp_path / "object.xml")
    (tmp_path / "includes.xml").write_text('<mujoco><include file="pipe.stl"/></mujoco>')
    with pytest.raises(gm.InvalidInput, match="FIFO"):
        gm.make_object("mesh", mesh=tmp_path / "includes.xml")
    _, how = load_object(tmp_path / "object.xml", "object", 1.0, tmp_path)  # the dataset's row says why
    assert how.startswith("refused:") and "FIFO" in how


def test_a_replicated_flood_is_refused_before_anything_is_built(tmp_path):
    """Bad case 4: 300 bytes of nested <replicate> (64,000 geoms) ran past 90 s at 2 GB."""
    (tmp_path / "flood.xml").write_text(
        '<mujoco><worldbody><replicate count="40" offset="0.01 0 0"><replicate count="40" offset="0 0.01 0">'
        '<replicate count="40" offset="0 0 0.01"><geom size="0.001"/></replicate></replicate></replicate>'
        '</worldbody></mujoco>')
    with pytest.raises(gm.InvalidInput, match=rf"more than 200 bodies or {MAX_GEOMS} geoms"):  # counted in the
        gm.make_object("mesh", mesh=tmp_path / "flood.xml")  # file before MuJoCo builds anything
    (tmp_path / "entity.xml").write_text('<!DOCTYPE m [<!ENTITY a "aaaa">]><mujoco>&a;</mujoco>')
    with pytest.raises(gm.InvalidInput, match="declares an XML entity"):
        object_file_references(tmp_path / "entity.xml")


def test_a_mesh_file_is_an_objects_part_only_where_an_object_file_really_names_it(tmp_path):
    """Bad case 5: `x.stl` vanished because a URDF's text named `box.stl` (the name was searched as text)."""
    _box(tmp_path / "box.stl")
    _box(tmp_path / "x.stl")
    (tmp_path / "thing.urdf").write_text(URDF.format(file="box.stl") + "<!-- not x.stl -->")
    found = object_files(tmp_path)
    assert [p.name for p in found.objects] == ["thing.urdf", "x.stl"]
    assert found.fates == {"box.stl": "part of thing.urdf", "thing.urdf": "object", "x.stl": "object"}
    (tmp_path / "notes.txt").write_text("box.stl")
    assert object_files(tmp_path).fates["notes.txt"] == "not an object file"


def test_two_objects_never_get_one_name(tmp_path):
    """Bad case 6: `a/b/c.obj` and `a_b/c.obj` were both `a_b_c`; the second's files overwrote the first's."""
    for folder in ("a/b", "a_b"):
        (tmp_path / folder).mkdir(parents=True)
        _box(tmp_path / folder / "c.obj")
    found = object_files(tmp_path).objects
    names = object_names(found, tmp_path)
    assert len(set(names)) == 2 and all(name.startswith("a_b_c") for name in names)
    assert names == object_names(found, tmp_path)  # the same names every run


def test_a_dataset_folder_is_read_as_itself(tmp_path):
    """Bad case 7: files outside the folder were read through ../, absolute paths, includes and links."""
    folder = tmp_path / "dataset"
    folder.mkdir()
    _box(tmp_path / "outside.stl")
    (folder / "parent.urdf").write_text(URDF.format(file="../outside.stl"))
    (folder / "absolute.xml").write_text(MJCF.format(file=tmp_path / "outside.stl"))
    (tmp_path / "outside.xml").write_text(MJCF.format(file="outside.stl"))
    (folder / "includes.xml").write_text(f'<mujoco><include file="{tmp_path / "outside.xml"}"/></mujoco>')
    (folder / "link.stl").symlink_to(tmp_path / "outside.stl")
    found = object_files(folder)
    for path in found.objects:
        obj, how = load_object(path, path.stem, 1.0, folder)
        assert obj is None and "outside the folder" in how, (path.name, how)
    obj, how = load_object(folder / "parent.urdf", "parent", 1.0, None)  # --outside: the user said so
    assert obj is not None, how


@pytest.mark.parametrize("call, message", [
    (lambda: __import__("graspmanifold.sim.flange", fromlist=["FlangeLimits"]).FlangeLimits(speed=10 ** 400),
     r"FlangeLimits\.speed must be a finite number"),
    (lambda: gm.make_object("mesh", mesh="a\x00b.stl"), "NUL byte"),
    (lambda: __import__("graspmanifold.sim.meshes", fromlist=["make_solid"]).make_solid(None),
     "make_solid takes a trimesh.Trimesh, got NoneType"),
])
def test_validation_gaps_are_refused_by_name(call, message):
    """Poor cases: an OverflowError without the field, a raw 'embedded null byte', an AttributeError."""
    with pytest.raises(gm.InvalidInput, match=message):
        call()


def test_an_explicit_still_palm_is_not_overridden_by_the_lift():
    """Poor case: `TactileGraspEnv(protocol="lift", palm=False)` put the palm on a flange without a word."""
    from graspmanifold.envs.tactile_grasp import episode_setup

    with pytest.raises(gm.InvalidInput, match="palm=False, but the 'lift' protocol moves the palm"):
        episode_setup("box", protocol="lift", palm=False)
    assert episode_setup("box", protocol="lift").palm is not None  # left out: the lift brings its flange


def test_result_files_are_standard_json_and_read_back_unbounded_numbers(tmp_path):
    """Poor case: summary.json and dataset.json held `Infinity`, which JSON.parse refuses and jq turns into 1.8e308."""
    from types import SimpleNamespace

    import numpy as np

    from graspmanifold.base.io import json_text, read_json
    from graspmanifold.trials.evaluation import summary_json

    def strict(text):
        return json.loads(text, parse_constant=lambda name: pytest.fail(f"non-standard JSON: {name}"))

    result = SimpleNamespace(summary={"max_match_distance": float("inf"), "epsilon": [np.float64("nan"), 0.5]},
                             made_by={"seed": 0})
    strict(summary_json([result]))
    path = tmp_path / "study.json"
    path.write_text(json_text({"bound": -np.inf, "rows": [{"p": float("nan")}], "name": "Infinity stone"}))
    data = read_json(path, "study.json")
    assert data["bound"] == -np.inf and np.isnan(data["rows"][0]["p"]) and data["name"] == "Infinity stone"
    path.write_text("{not json")
    with pytest.raises(gm.InvalidInput, match="study.json .* is not JSON"):
        read_json(path, "study.json")


def test_a_study_folder_that_cannot_be_written_is_named_as_such(tmp_path):
    """Poor case: `--out` a file (or read-only) was refused up front, but the message ended "... free the space"."""
    from graspmanifold.studies.runner import run_study

    out = tmp_path / "a-file"
    out.write_text("")
    with pytest.raises(SystemExit, match="it is a file, not a directory") as refused:
        run_study(out, 1, lambda run: pytest.fail("the study ran"), pool=False)
    assert "free the space" not in str(refused.value)


def _flanged_scene():
    from graspmanifold.sim.flange import FlangeLimits

    return gm.Scene("box", flange=FlangeLimits())


def _starts(poses, streams):
    import numpy as np

    from graspmanifold.trials.episode import trial_starts
    from graspmanifold.trials.setup import TrialSetup

    return trial_starts(TrialSetup(object="box"), poses, [np.random.default_rng(k) for k in range(streams)],
                        gm.open_posture())


@pytest.mark.parametrize("call, message", [
    (lambda: _flanged_scene().steer_flange([1j] * 6, 0.01), "target must be 6 finite real numbers"),
    (lambda: _flanged_scene().steer_flange(["up"] * 6, 0.01), "target must be 6 finite real numbers"),
    (lambda: _flanged_scene().steer_flange([0.0] * 6, "fast"), r"period must be a finite number > 0 s"),
    (lambda: _starts([[0.0, 0.0, 0.02, float("nan")]], 1), "poses row 0 has non-finite values"),
    (lambda: _starts([[0.0] * 3, [0.0] * 3, [0.02] * 3, [0.0] * 3], 4), r"poses must have shape \(n, 4\)"),
    (lambda: _starts([[0.0, 0.0, 0.02, 0.0]] * 3, 2), "one random stream per pose: 3 poses, got 2 streams"),
    (lambda: check_places([[1e300, 0.0, 0.0]], 1), r"places must be finite positions in m.*within \+-1"),
    (lambda: check_places([[0.01j, 0.0, 0.0]], 1), "places must be .* not real numbers"),
])
def test_more_validation_gaps_are_refused_by_name(call, message):
    """Poor cases: complex or text flange targets, trial starts from a NaN pose, transposed poses, or fewer random
    streams than poses (zip truncated them)."""
    with pytest.raises(gm.InvalidInput, match=message):
        call()


def test_a_float32_period_steers_the_flange():
    """Poor case: a float32 period was refused as 'not > 0'."""
    import numpy as np

    scene = _flanged_scene()
    scene.steer_flange([0.01, 0, 0, 0, 0, 0], np.float32(0.01))
    assert scene.data.ctrl[scene.flange_actuators][0] > 0


def test_a_truncated_binary_stl_whose_header_says_solid_is_named_as_such(tmp_path):
    """Poor case: a binary STL whose 80-byte header begins with 'solid' went to the text decoder (a machine without
    charset_normalizer answered that it needs it)."""
    data = bytearray(trimesh.exchange.stl.export_stl(trimesh.creation.box(extents=(0.05, 0.04, 0.1))))
    data[:80] = b"solid exported by a CAD tool".ljust(80)
    (tmp_path / "whole.stl").write_bytes(bytes(data))
    assert gm.make_object("mesh", mesh=tmp_path / "whole.stl").name == "whole"
    (tmp_path / "cut.stl").write_bytes(bytes(data[:-20]))
    with pytest.raises(gm.InvalidInput, match="a binary STL of 12 triangles has 684 bytes, this one 664"):
        gm.make_object("mesh", mesh=tmp_path / "cut.stl")


def _rewritten(path, **changes):
    """The npz file at `path` with some members changed (as a corrupted or hand-edited file would be)."""
    import numpy as np

    with np.load(path) as stored:
        members = {name: stored[name] for name in stored.files}
    members.update(changes)
    with open(path, "wb") as handle:
        np.savez(handle, **members)
    return path


def _postures():
    return gm.PostureSet.load("tests/data/v0_1/postures.npz").postures[:40]


@pytest.mark.parametrize("make, member, value, message", [
    (lambda: gm.LinearManifold(3).fit(_postures()), "mean", lambda a: a * 0 + float("nan"), "mean row 0 has non-finite"),
    (lambda: gm.LinearManifold(3).fit(_postures()), "mean", lambda a: a * 0 + 1e14, "mean row 0 holds joint angles beyond"),
    (lambda: gm.UKR(2, starts=("pca",), scales=2, iterations=2).fit(_postures()), "latent", lambda a: a * 1e200,
     r"latent row 0 is not a finite point within \+-1e\+06"),
    (lambda: gm.PostureDatabase(_postures()), "postures", lambda a: a + 50.0, "postures row 0 holds joint angles beyond"),
])
def test_experience_files_with_numbers_no_hand_has_are_refused_with_the_file_named(tmp_path, make, member, value,
                                                                                      message):
    """Poor case: a linear manifold with a NaN or 1e14-rad mean loaded (its trials blamed on the physics), UKR latent
    points x1e200 took 16 s with overflow warnings, postures of 50 rad completed to 50 rad."""
    import numpy as np

    path = make().save(tmp_path / "experience.npz")
    with np.load(path) as stored:
        changed = value(stored[member])
    _rewritten(path, **{member: changed})
    with pytest.raises(gm.InvalidInput, match=message) as refused:
        load_representation(path)
    assert str(path) in str(refused.value)


def test_an_experience_outside_the_hands_joint_ranges_is_refused_before_trials():
    """Poor case: a map trained on one hand's postures ran on another hand without a word (here: references no
    joint of our hand reaches: a warning, since a synthetic experience may mean it)."""
    from graspmanifold.trials.setup import TrialSetup

    postures = _postures().copy()
    postures[3, 5] = 2.5  # rad: beyond every finger joint's range of our hand
    with pytest.warns(UserWarning, match=r"reference posture 3 has joint 5 at 2\.500 rad, outside the 'shadow-primitives'"):
        TrialSetup(object="box", experience=gm.PostureDatabase(postures))
    assert TrialSetup(object="box", experience=gm.PostureDatabase(_postures())).experience is not None


def test_the_previous_versions_hand_keyword_of_generate_postures_still_works_with_a_warning(tmp_path):
    """Poor case: `generate_postures(..., hand=...)` of the previous version raised TypeError instead of answering
    with a DeprecationWarning, as the other moved names do."""
    params = gm.GeneratorParams(verify=False)
    with pytest.warns(DeprecationWarning, match=r"generate_postures\(hand=...\) is now .*GeneratorParams\(hand=...\)"):
        old = gm.generate_postures("sphere", 3, seed=1, workers=1, params=params, progress=False,
                                   hand="shadow-primitives")
    new = gm.generate_postures("sphere", 3, seed=1, workers=1, params=params, progress=False)
    assert old.hand == new.hand == "shadow-primitives"
    assert (old.postures == new.postures).all()


def test_a_flanged_scene_is_built_without_mujocos_empty_prefix_warning():
    """Poor case: MuJoCo's 'empty prefix' warning printed 50 times a run (once per flanged scene)."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _flanged_scene()
    assert not [w for w in caught if "empty prefix" in str(w.message)]


def test_one_object_that_fails_is_its_own_row_and_an_absurd_mesh_scale_is_refused(tmp_path, monkeypatch):
    """Poor case: a mesh `scale="1e300"` ended the whole dataset command in a SciPy traceback, every rerun the same:
    the scale is refused by name, and whatever else one object raises is that object's row."""
    import graspmanifold.studies.dataset as dataset

    _box(tmp_path / "box.stl")
    (tmp_path / "huge.urdf").write_text(URDF.format(file="box.stl").replace('"/>', '" scale="1e300 1e300 1e300"/>', 1))
    obj, loaded = load_object(tmp_path / "huge.urdf", "huge", 1.0, tmp_path)
    assert obj is None and loaded.startswith("refused: ") and "scales a mesh by [1e+300" in loaded

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug met by one object")

    monkeypatch.setattr(dataset, "make_object", broken)
    assert load_object(tmp_path / "box.stl", "box", 1.0, tmp_path) == (None, "failed: ZeroDivisionError: a bug met "
                                                                             "by one object")


def test_a_thousand_pieces_are_refused_at_once(tmp_path):
    """Poor case: 1,000 pieces 1 mm apart took 60 s and 3.8 GB before a MemoryError."""
    cubes = [trimesh.creation.box(extents=(0.004,) * 3).apply_translation([0.005 * (i % 10), 0.005 * (i // 10 % 10),
                                                                            0.005 * (i // 100)]) for i in range(1000)]
    trimesh.util.concatenate(cubes).export(tmp_path / "pieces.stl")
    with pytest.raises(gm.InvalidInput, match="1000 separate pieces, more than 256"):  # before any pair's gap
        gm.make_object("mesh", mesh=tmp_path / "pieces.stl")


def test_a_package_url_and_an_articulated_file_are_said(tmp_path):
    """Poor cases: a `package://` mesh URL mangled with no word that it is not resolved; an articulated URDF silently
    made one rigid solid."""
    _box(tmp_path / "box.stl")
    (tmp_path / "ros.urdf").write_text(URDF.format(file="package://things/meshes/box.stl"))
    with pytest.raises(gm.InvalidInput, match=r"names a ROS package \(package://\), which MuJoCo cannot find"):
        gm.make_object("mesh", mesh=tmp_path / "ros.urdf")
    (tmp_path / "hinged.urdf").write_text(
        '<robot name="r"><link name="a"><collision><geometry><box size="0.05 0.04 0.08"/></geometry></collision></link>'
        '<link name="b"><collision><origin xyz="0 0 0.06"/><geometry><box size="0.05 0.04 0.05"/></geometry>'
        '</collision></link><joint name="hinge" type="revolute"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    with pytest.warns(UserWarning, match=r"has 1 joint \(hinge\), fixed at the reference pose"):
        gm.make_object("mesh", mesh=tmp_path / "hinged.urdf")
    _, loaded = load_object(tmp_path / "hinged.urdf", "hinged", 1.0, tmp_path)
    assert "1 joint (hinge), fixed at the reference pose" in loaded


def test_a_sealed_hollow_box_is_one_solid_not_two_apart(tmp_path):
    """Poor case: a sealed thin-walled box was described as '2 separate solids 5 mm apart'."""
    outer, inner = trimesh.creation.box(extents=(0.06, 0.05, 0.1)), trimesh.creation.box(extents=(0.05, 0.04, 0.09))
    inner.invert()
    trimesh.util.concatenate([outer, inner]).export(tmp_path / "hollow.stl")
    with pytest.warns(UserWarning, match="the sealed cavity of 1 inner shell filled"):
        hollow = gm.make_object("mesh", mesh=tmp_path / "hollow.stl")
    assert sorted(2 * h for h in hollow.half_sizes) == pytest.approx([0.05, 0.06, 0.1], abs=1e-6)


def test_a_table_cell_cannot_break_its_table():
    """Poor case: file names holding '|' or a newline broke dataset.md's rows."""
    from graspmanifold.base.io import markdown_table

    lines = markdown_table(["file", "what it is"], [["a|b.stl", "refused: two\nlines"]])
    assert lines[2] == "| a\\|b.stl | refused: two lines |"


@pytest.mark.parametrize("limits, message", [
    (dict(travel=0.01), r"raises the palm 0\.2 m, but the arm travels FlangeLimits\.travel=0\.01 m"),
    (dict(force=0.01), r"the arm pushes FlangeLimits\.force=0\.01 N, less than twice its weight"),
])
def test_a_lift_the_arm_cannot_perform_is_refused_before_any_trial(limits, message):
    """Poor case: the lift reported 'held' with an arm that could rise 1 cm of the 0.2 m lift, or pull 0.01 N."""
    from graspmanifold.sim.flange import FlangeLimits
    from graspmanifold.trials.setup import TrialSetup

    with pytest.raises(gm.InvalidInput, match=message):
        TrialSetup(object="box", protocol="lift", palm=FlangeLimits(**limits))
    assert TrialSetup(object="box", protocol="lift", palm=FlangeLimits()).palm == FlangeLimits()


def test_the_dataset_commands_trials_name_their_preset_grid():
    """Poor case: the dataset command's summaries labelled a preset's grid 'custom' (its poses went in as an array)."""
    from graspmanifold.studies.dataset import trial_grid
    from graspmanifold.trials.grid import grid_preset

    box = gm.get_object("box")
    grid, poses = trial_grid("quick", None, box)
    assert grid == "quick" and (poses == grid_preset("quick", box)).all()
    grid, poses = trial_grid("quick", 3, box)
    assert len(poses) == 3 and (grid == poses).all()  # a subset is the custom grid it is


def test_record_trials_default_pose_fits_a_new_larger_object(tmp_path):
    """Poor case: `record_trial(obj)`'s default pose (1 cm from the palm) was unreachable for a larger new object, so
    the recipe's call failed."""
    import numpy as np

    from graspmanifold.trials.grid import reachable

    _box(tmp_path / "big.stl", size=(0.08, 0.07, 0.12))
    big = gm.make_object("mesh", mesh=tmp_path / "big.stl")
    assert not reachable(big, np.array([[0.0, 0.0, 0.01, 0.0]]))[0]
    recording = gm.record_trial(big, every=50)
    assert reachable(big, np.asarray(recording.trial.grid_pose)[None])[0] and len(recording.states) >= 2


def test_a_refused_objects_row_says_why_not_where(tmp_path):
    """Poor case: a refusal's reason was cut after the file's full path in dataset.md, so the table showed the path
    and not the reason."""
    deep = tmp_path / ("a-long-folder-name-" * 6) / "flat.stl"
    deep.parent.mkdir()
    trimesh.Trimesh([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], [[0, 1, 2]]).export(deep)
    _, loaded = load_object(deep, "flat", 1.0, tmp_path)
    assert loaded.startswith("refused: ") and str(deep.parent) not in loaded and "watertight" in loaded


def test_the_palm_steering_has_named_values_and_a_flag(tmp_path, monkeypatch):
    """Poor case: `palm=FlangeLimits()` alone moved nothing, the docs gave no palm-steering values (found only in
    the source) and the CLI had no flag for it."""
    from graspmanifold.cli import main
    from graspmanifold.control.controller import PALM_EXPERIENCE, PALM_STEERINGS, PALM_TOUCH

    import graspmanifold.trials.evaluation as evaluation

    assert PALM_TOUCH.active and PALM_EXPERIENCE.recalled_place and not PALM_STEERINGS["still"].active
    asked = {}

    def spy(*args, **kwargs):  # what the command asks of evaluate; its trials are the API's, tested elsewhere
        asked.update(kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(evaluation, "evaluate", spy)
    main(["evaluate", "--object", "box", "--experience", "none", "--palm-steering", "touch", "--out",
          str(tmp_path / "run")])
    assert asked["params"].palm == PALM_TOUCH and asked["palm"] is not None and "controller" not in asked


def test_a_map_trained_on_another_hands_postures_is_refused_by_the_command(tmp_path, capsys):
    """Poor case: a map trained on one hand's postures ran on another hand without a word (maps a run trains now
    record their hand, and `--map` is refused for another, as `--postures` already was)."""
    from graspmanifold.cli import main
    from graspmanifold.base.io import npz_metadata

    path = gm.SOM(3, 3, 22, seed=0).fit(_postures(), epochs=2).save(tmp_path / "map.npz",
                                                                       extra={"hand": "gymnasium-robotics"})
    assert npz_metadata(path)["hand"] == "gymnasium-robotics"
    with pytest.raises(SystemExit, match="was trained on the 'gymnasium-robotics' hand's postures, not --hand"):
        main(["evaluate", "--object", "box", "--map", str(path), "--out", str(tmp_path / "run")])
