"""Issue 67: a dataset's objects as they ship (overlapping pieces, an open scan, a convex decomposition, a URDF naming
its mesh pieces) each load, get verified grasps and run a trial; a folder of them goes to verified grasps, a map and
trials in one command, and what no repair saves is a row that says why."""

import json

import numpy as np
import pytest
import trimesh

import graspmanifold as gm
from graspmanifold.cli import main
from graspmanifold.studies.dataset import object_files

SIZE = (0.05, 0.04, 0.11)  # every kind below is this box (distinct principal axes: one object frame for all)


def box(size=SIZE, z=0.0, x=0.0):
    return trimesh.creation.box(extents=size).apply_translation([x, 0.0, z])


def write_kinds(folder):
    """The box as datasets ship objects, one file each."""
    (folder / "package" / "meshes").mkdir(parents=True)
    trimesh.util.concatenate([box((0.05, 0.04, 0.07), z=-0.02), box((0.05, 0.04, 0.07), z=0.02)]).export(
        folder / "overlapping.stl")
    scan = box().subdivide()
    scan.update_faces(np.arange(len(scan.faces)) != 0)  # one triangle missing: a hole
    scan.export(folder / "scan.obj")
    halves = [box((0.0249, 0.04, 0.11), x=dx) for dx in (-0.01255, 0.01255)]  # hulls 0.1 mm apart, as V-HACD leaves
    trimesh.util.concatenate(halves).export(folder / "decomposition.obj")
    box((0.025, 0.04, 0.11)).export(folder / "package" / "meshes" / "half.stl")
    (folder / "package" / "halves.urdf").write_text(
        '<robot name="halves"><link name="base_link"><inertial><mass value="0.1"/><inertia ixx="1" iyy="1" izz="0" '
        'ixy="0" ixz="0" iyz="0"/></inertial>' + "".join(  # a placeholder inertia, as in many packages: not read
            f'<collision><origin xyz="{dx} 0 0"/><geometry><mesh filename="meshes/half.stl"/></geometry></collision>'
            for dx in (-0.0125, 0.0125)) + "</link></robot>")


@pytest.mark.filterwarnings("ignore:.*made one solid", "ignore:.*searching them now")
def test_each_kind_a_dataset_ships_loads_gets_verified_grasps_and_runs_a_trial(tmp_path):
    write_kinds(tmp_path)
    starts = gm.starting_postures(gm.make_object("mesh", mesh=box(), name="box_mesh"), "grasp_types")
    said = {"overlapping.stl": "union of 2 closed pieces", "scan.obj": "holes of 1 open piece filled",
            "decomposition.obj": "2 convex pieces kept", "package/halves.urdf": "2 convex pieces kept"}
    for file, repair in said.items():
        with pytest.warns(UserWarning, match=repair):
            obj = gm.make_object("mesh", mesh=tmp_path / file)
        assert np.allclose(2 * obj.half_extents, sorted(SIZE), atol=3e-4), file
        postures = gm.generate_postures(obj, 2, seed=0, workers=1, progress=False, starts=starts)
        assert len(postures) == 2, file  # verified: each held the object when replayed
        result = gm.evaluate(obj, postures, gm.grid_preset("quick", obj)[:1], seed=0, workers=1, progress=False)
        assert len(result.trials) == 1 and result.trials[0].posture is not None, file


def test_a_package_folder_lists_its_object_files_not_the_meshes_they_name(tmp_path):
    write_kinds(tmp_path)
    names = [p.relative_to(tmp_path).as_posix() for p in object_files(tmp_path).objects]
    assert names == ["decomposition.obj", "overlapping.stl", "package/halves.urdf", "scan.obj"]
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="holds no object file"):
        object_files(tmp_path / "empty")
    with pytest.raises(ValueError, match="is not a folder"):
        object_files(tmp_path / "missing")


@pytest.mark.filterwarnings("ignore:.*searching them now")
def test_a_dataset_folder_to_verified_grasps_a_map_and_controllers_in_one_command(tmp_path, capsys):
    folder, out = tmp_path / "objects", tmp_path / "run"
    folder.mkdir()
    box().export(folder / "box.obj")  # the solid of the test above (to the last bit: .obj keeps it): its starts kept
    trimesh.Trimesh(vertices=[[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], faces=[[0, 1, 2]]).export(folder / "sheet.stl")
    command = ["dataset", str(folder), "--postures", "2", "--poses", "1", "--workers", "1", "--out", str(out)]
    assert main(command) == 0
    table = capsys.readouterr().out
    report = json.loads((out / "dataset.json").read_text())
    rows = {row["object"]: row for row in report["objects"]}
    assert "refused" in rows["sheet"]["loaded"] and "not watertight" in rows["sheet"]["loaded"]
    assert rows["box"]["loaded"] == "as shipped" and rows["box"]["postures"] == 2 and len(rows["box"]["digest"]) == 16
    assert report["trials"]["hand"] == "shadow-primitives" and report["trials"]["protocol"] == "hold-test" and report["versions"]["code"]
    assert {m: n for m, (_, n) in rows["box"]["results"].items()} == {"none": 1, "database": 1, "som": 1}
    assert (out / "maps" / "box_som.npz").exists()
    assert "Loaded 1 of 2; 1 got 2 verified postures." in table and "| sheet | refused:" in table
    assert "Every object's trials together" in table and [row[:2] for row in report["pooled"]] == [["database", 1],
                                                                                                    ["som", 1]]
    assert main(command) == 0  # a rerun takes what is done
    assert json.loads((out / "dataset.json").read_text())["objects"] == report["objects"]
    assert main([*command, "--manifold", "linear"]) == 0  # another manifold by name: only its trials run
    rows = {row["object"]: row for row in json.loads((out / "dataset.json").read_text())["objects"]}
    assert set(rows["box"]["results"]) == {"none", "database", "linear"} and (out / "maps" / "box_linear.npz").exists()
    assert "| linear |" in capsys.readouterr().out
    both = (out / "dataset.md").read_text()  # round seven: the second manifold's run kept the first's report
    assert "## som" in both and "## linear" in both and "| box | as shipped |" in both.split("## linear")[0]
    assert set(json.loads((out / "dataset.json").read_text())["manifolds"]) == {"som", "linear"}
