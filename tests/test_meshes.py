"""Mesh objects through trimesh: checks, the object frame, queries against the exact primitives,
MuJoCo collision geometry, the object family, and the whole pipeline on meshes."""

import functools
import subprocess
import sys
import warnings

import numpy as np
import pytest
import trimesh

import graspmanifold as gm
from graspmanifold.sim.family import FAMILY, HELD_OUT, SHAPES, family_mesh

RNG = np.random.default_rng(0)


def cylinder_mesh(sections: int = 64) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=0.03, height=0.16, sections=sections)


# -- bad input -------------------------------------------------------------------------------------

def test_meshes_as_datasets_ship_them_are_made_one_solid_and_what_none_saves_is_refused():
    """Issue 67: an open scan, overlapping pieces, a convex decomposition load; a sheet and pieces apart do not."""
    open_mesh = cylinder_mesh()
    open_mesh.update_faces(np.arange(len(open_mesh.faces)) != 0)  # one triangle missing: a hole
    with pytest.warns(UserWarning, match="'holed' made one solid: the holes of 1 open piece filled"):
        holed = gm.make_object("mesh", mesh=open_mesh, name="holed")
    assert holed.mesh.is_watertight and np.isclose(holed.mesh.volume, cylinder_mesh().volume, rtol=1e-9)
    box, rod = trimesh.creation.box(extents=(0.05, 0.05, 0.05)), trimesh.creation.cylinder(radius=0.02, height=0.1)
    with pytest.warns(UserWarning, match="the union of 2 closed pieces"):
        joined = gm.make_object("mesh", mesh=trimesh.util.concatenate([box, rod]), name="box_and_rod")
    assert int(joined.mesh.body_count) == 1 and box.volume < joined.mesh.volume < box.volume + rod.volume
    halves = [trimesh.creation.box(extents=(0.03, 0.04, 0.1)).apply_translation([dx, 0.0, 0.0]) for dx in (-0.015,
                                                                                                          0.015)]
    with pytest.warns(UserWarning, match="its 2 convex pieces kept as its collision parts"):
        decomposition = gm.make_object("mesh", mesh=trimesh.util.concatenate(halves), name="halves")
    whole = gm.make_object("mesh", mesh=trimesh.creation.box(extents=(0.06, 0.04, 0.1)), name="whole")
    assert len(decomposition.parts) == 2 and len(whole.parts) == 1  # the pieces given are its collision parts
    assert np.isclose(decomposition.mesh.volume, whole.mesh.volume, rtol=1e-9)
    assert decomposition.mesh_digest != whole.mesh_digest  # collided otherwise: never confused
    assert [sorted(np.ptp(p.vertices, axis=0).round(6).tolist()) for p in decomposition.parts] == [[0.03, 0.04, 0.1]] * 2
    assert np.allclose(trimesh.util.concatenate(decomposition.parts).bounds, decomposition.mesh.bounds, atol=1e-12)
    sheet = trimesh.Trimesh(vertices=[[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], faces=[[0, 1, 2]])
    with pytest.raises(ValueError, match="not watertight"):
        gm.make_object("mesh", mesh=sheet)
    apart = trimesh.util.concatenate([box, rod.copy().apply_translation([0.2, 0.0, 0.0])])
    with pytest.raises(ValueError, match="2 separate solids that do not touch"):
        gm.make_object("mesh", mesh=apart)


def test_pieces_that_touch_at_an_edge_or_lie_a_hair_apart_are_one_object_and_stay_closed():
    """Issue 67: a decomposition's hulls touch at edges or leave gaps of micrometres (pybullet's teddy: four solids
    0.0011 mm apart); they are one object of several closed solids, not welded into an open surface; a millimetre
    and more apart they are refused with the gap."""
    rod = trimesh.creation.box(extents=(0.02, 0.02, 0.06))
    with pytest.warns(UserWarning, match="2 solids at most 0 mm apart kept as one object"):
        edge = gm.make_object("mesh", mesh=trimesh.util.concatenate([rod, rod.copy().apply_translation([0.02, 0.02, 0])]))
    assert edge.mesh.is_watertight and int(edge.mesh.body_count) == 2 and len(edge.parts) == 2
    with pytest.warns(UserWarning, match="at most 0.0005 mm apart"):
        gm.make_object("mesh", mesh=trimesh.util.concatenate([rod, rod.copy().apply_translation([0.0200005, 0, 0])]))
    with pytest.raises(ValueError, match="2 mm apart, more than the 1 mm"):
        gm.make_object("mesh", mesh=trimesh.util.concatenate([rod, rod.copy().apply_translation([0.022, 0, 0])]))


def test_one_mesh_under_two_names_shares_its_searched_starts():
    from graspmanifold.synthesis.start_cache import starts_cache_path

    named = [gm.make_object("mesh", mesh=cylinder_mesh(), name=name) for name in ("can", "tin")]
    assert starts_cache_path(named[0], "grasp_types") == starts_cache_path(named[1], "grasp_types")
    assert starts_cache_path(named[0], "grasp_types") != starts_cache_path(named[0], "five_fingertip")
    other = gm.make_object("mesh", mesh=cylinder_mesh(48), name="can")
    assert starts_cache_path(other, "grasp_types") != starts_cache_path(named[0], "grasp_types")


def test_a_zero_volume_mesh_is_refused():
    flat = trimesh.Trimesh(vertices=[[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], faces=[[0, 1, 2], [0, 2, 1]])
    with pytest.raises(ValueError, match="volume|watertight"):
        gm.make_object("mesh", mesh=flat)


def test_a_mesh_two_metres_across_is_refused_with_the_unit_hint():
    with pytest.raises(ValueError, match=r"2\.00 m across.*scale=0\.001"):
        gm.make_object("mesh", mesh=trimesh.creation.box(extents=(2.0, 0.5, 0.5)))


def test_missing_and_unreadable_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="mesh file: no such file"):
        gm.make_object("mesh", mesh=tmp_path / "nothing.stl")
    garbage = tmp_path / "garbage.stl"
    garbage.write_bytes(b"\x00\x01 this is not a mesh")
    with pytest.raises(ValueError, match="garbage.stl"):
        gm.make_object("mesh", mesh=garbage)
    sheet = tmp_path / "sheet.obj"  # read, but no repair makes it a solid: the file and the reason
    trimesh.Trimesh(vertices=[[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0]], faces=[[0, 1, 2]]).export(sheet)
    with pytest.raises(ValueError, match=r"sheet\.obj'?: mesh is not watertight"):
        gm.make_object("mesh", mesh=sheet)
    with pytest.raises(ValueError, match="mesh must be"):
        gm.make_object("mesh", mesh=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="needs mesh="):
        gm.make_object("mesh")
    with pytest.raises(ValueError, match="mesh= and scale="):
        gm.make_object("sphere", radius=0.03, mesh=cylinder_mesh())


def test_misleading_mesh_messages_say_what_is_wrong(tmp_path):
    """A NaN vertex was reported as 'not watertight', a 0.04 mm mesh as '0.0 mm thick' and a directory named
    x.stl as 'does not exist'."""
    box = trimesh.creation.box(extents=(0.05, 0.05, 0.05))
    vertices = box.vertices.copy()
    vertices[3, 1] = np.nan
    broken = tmp_path / "broken.obj"
    broken.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in vertices)
                      + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in box.faces))
    with pytest.raises(ValueError, match="1 vertices with non-finite coordinates .* index 3"):
        gm.make_object("mesh", mesh=broken)
    with pytest.raises(ValueError, match="only 0.04 mm thick"):
        gm.make_object("mesh", mesh=trimesh.creation.box(extents=(0.05, 0.05, 0.00004)))
    (tmp_path / "folder.stl").mkdir()
    with pytest.raises(ValueError, match="is a directory, not a file"):
        gm.make_object("mesh", mesh=tmp_path / "folder.stl")


def test_a_file_in_millimetres_loads_with_its_scale(tmp_path):
    path = tmp_path / "can.stl"
    trimesh.creation.cylinder(radius=30.0, height=160.0, sections=48).export(path)
    with pytest.raises(ValueError, match="scale"):
        gm.make_object("mesh", mesh=path)
    obj = gm.make_object("mesh", mesh=path, scale=0.001)
    assert obj.name == "can"
    np.testing.assert_allclose(obj.half_extents, [0.03, 0.03, 0.08], atol=5e-4)


# -- the object frame and the queries -----------------------------------------------------------------

def test_a_mesh_is_centred_at_its_centre_of_mass_on_its_principal_axes_long_axis_z():
    turned = cylinder_mesh()
    turned.apply_transform(trimesh.transformations.rotation_matrix(0.7, [1.0, 0.3, 0.0]))
    turned.apply_translation([0.3, -0.2, 0.1])
    obj = gm.make_object("mesh", mesh=turned)
    np.testing.assert_allclose(obj.mesh.center_mass, 0.0, atol=1e-9)
    np.testing.assert_allclose(obj.half_extents, [0.03, 0.03, 0.08], atol=5e-4)
    frustum = gm.get_object("frustum_m")  # its centre of mass lies towards the wide end
    assert frustum.mesh.bounds[1, 2] > -frustum.mesh.bounds[0, 2]


def test_mesh_queries_agree_with_the_exact_primitive():
    mesh, exact = gm.make_object("mesh", mesh=cylinder_mesh(128)), gm.get_object("cylinder")
    points = RNG.normal(0.0, 0.05, (300, 3))
    chord = 0.03 * (1 - np.cos(np.pi / 128))  # the polygon's largest gap to the circle
    np.testing.assert_allclose(mesh.signed_distance(points), exact.signed_distance(points), atol=chord + 1e-9)
    outside = exact.signed_distance(points) > 0.002
    np.testing.assert_allclose(mesh.closest_point(points[outside]), exact.closest_point(points[outside]), atol=2e-3)
    agree = np.sum(mesh.surface_normal(points[outside]) * exact.surface_normal(points[outside]), axis=1)
    assert np.median(agree) > 0.999
    assert mesh.signed_distance(np.zeros(3)) < 0 < mesh.signed_distance([0.1, 0.0, 0.0])


def dataset_kinds() -> dict[str, trimesh.Trimesh]:
    """The kinds of mesh datasets ship (issue 67): an open scan (a hole), overlapping closed pieces, a convex
    decomposition (pieces that touch), and a non-convex solid with large and small triangles side by side."""
    open_scan = cylinder_mesh()
    open_scan.update_faces(np.arange(len(open_scan.faces)) != 0)
    box, rod = trimesh.creation.box(extents=(0.05, 0.05, 0.05)), trimesh.creation.cylinder(radius=0.02, height=0.1)
    halves = [trimesh.creation.box(extents=(0.03, 0.04, 0.1)).apply_translation([dx, 0.0, 0.0]) for dx in (-0.015,
                                                                                                          0.015)]
    return {"open_scan": open_scan, "overlapping": trimesh.util.concatenate([box, rod]),
            "decomposition": trimesh.util.concatenate(halves)}


def winding_number(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """The generalised winding number of a closed mesh at points (1 inside, 0 outside): the triangles' solid angles
    (Van Oosterom and Strackee) summed, robust to micrometres from the surface, where a ray test is not."""
    t = np.array(mesh.triangles)[None] - points[:, None, None]
    a, b, c = t[:, :, 0], t[:, :, 1], t[:, :, 2]
    la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
    dot = lambda u, v: np.einsum("nfi,nfi->nf", u, v)  # noqa: E731
    angle = np.arctan2(dot(a, np.cross(b, c)), la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb)
    return angle.sum(axis=1) / (2 * np.pi)


@functools.cache
def query_cases() -> list[tuple]:
    """The test objects (four of the family, the three dataset kinds), query points around each (far, 1 mm and 1 um
    from the surface, its vertices), the nearest distance over every point-triangle pair and the winding number."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the dataset kinds' repairs, said elsewhere
        objects = [gm.get_object(name) for name in ("ring_m", "cylinder_mesh", "bottle_m", "mug_m")]
        objects += [gm.make_object("mesh", mesh=mesh, name=name) for name, mesh in dataset_kinds().items()]
    cases = []
    for obj in objects:
        triangles = np.array(obj.mesh.triangles)
        size = float(np.ptp(obj.mesh.bounds, axis=0).max())
        surface = obj.mesh.sample(60, seed=1)
        points = np.vstack([RNG.normal(0.0, 0.6 * size, (60, 3)), surface + RNG.normal(0.0, 1e-3, (60, 3)),
                            surface[:20] + RNG.normal(0.0, 1e-6, (20, 3)), obj.mesh.vertices[:10]])
        every_pair = trimesh.triangles.closest_point(np.tile(triangles, (len(points), 1, 1)),
                                                     np.repeat(points, len(triangles), axis=0))
        nearest = np.linalg.norm(every_pair.reshape(len(points), -1, 3) - points[:, None], axis=2).min(axis=1)
        cases.append((obj, points, nearest, winding_number(obj.mesh, points)))
    return cases


def test_fast_mesh_queries_agree_with_every_point_triangle_pair_on_every_test_object(engine):
    """Issue 67: the query structures (`mesh_queries`: the compiled grid near the object and the k-d trees beyond it,
    or the k-d trees alone) give the exact closest distance (1e-12 m: the same as testing every point-triangle pair), a closest point on the surface, and the sign of a point's containment (the winding
    number) wherever a point is more than 1e-9 m from the surface; near, far, inside and outside points."""
    for obj, points, nearest, winding in query_cases():
        closest = obj.closest_point(points)
        np.testing.assert_allclose(np.linalg.norm(closest - points, axis=1), nearest, atol=1e-12, err_msg=obj.name)
        signed = obj.signed_distance(points)
        np.testing.assert_allclose(np.abs(signed), nearest, atol=1e-12, err_msg=obj.name)
        clear = nearest > 1e-9
        assert np.array_equal(signed[clear] < 0, winding[clear] > 0.5), obj.name
        np.testing.assert_allclose(obj.signed_distance(closest), 0.0, atol=1e-12, err_msg=obj.name)
        normals = obj.surface_normal(points[clear & (signed > 1e-4)])
        outward = closest[clear & (signed > 1e-4)] - points[clear & (signed > 1e-4)]
        assert np.all(np.sum(normals * outward, axis=1) <= 1e-12), obj.name  # the face faces the point


def test_every_object_has_one_query_interface():
    points = RNG.normal(0.0, 0.04, (20, 3))
    for obj in (gm.get_object("box"), gm.get_object("sphere"), gm.get_object("capsule_m")):
        closest = obj.closest_point(points)
        assert closest.shape == (20, 3)
        np.testing.assert_allclose(obj.signed_distance(closest), 0.0, atol=1e-3)
        normals = obj.surface_normal(points)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    with pytest.raises(ValueError, match="points"):
        gm.get_object("capsule_m").closest_point([np.nan, 0.0, 0.0])


# -- MuJoCo -------------------------------------------------------------------------------------------

def test_a_mesh_scene_collides_like_the_primitive():
    """The same grid pose, the same open hand: the mesh cylinder's clearance and mass properties match
    the primitive's, and closing the hand touches with the same segments."""
    mesh, exact = gm.get_object("cylinder_mesh"), gm.get_object("cylinder")
    pose = np.array([0.0, 0.0, 0.01, 0.0])
    clearance = [gm.grid.open_hand_clearance(o, pose[None])[0] for o in (mesh, exact)]
    assert abs(clearance[0] - clearance[1]) < 2e-4
    scenes = [gm.Scene(o) for o in (mesh, exact)]
    np.testing.assert_allclose(scenes[0].model.body_inertia[scenes[0].object_body],
                               scenes[1].model.body_inertia[scenes[1].object_body], rtol=0.01)
    touched = []
    for scene in scenes:
        scene.set_hand_pose(*gm.facing_pose(scene.object, clearance=0.01))
        scene.set_target(gm.closed_posture())
        scene.run(1.5)
        touched.append(set(scene.tactile().segments))
    assert touched[0] == touched[1] and len(touched[0]) >= 5


def test_a_non_convex_mesh_is_split_into_the_same_convex_parts_every_time():
    ring = gm.get_object("ring_m")
    assert not ring.mesh.is_convex and len(ring.parts) > 1
    again = gm.make_object("mesh", mesh=family_mesh("ring_m"), name="again")
    assert [p.vertices.tolist() for p in again.parts] == [p.vertices.tolist() for p in ring.parts]
    scene = gm.Scene(ring)
    assert len(scene.object_geoms) == len(ring.parts)
    hull_volume = sum(p.volume for p in ring.parts)
    assert 0.8 * ring.mesh.volume < hull_volume < 1.5 * ring.mesh.volume  # the parts follow the ring


def test_a_mesh_listed_in_another_order_is_the_same_object():
    """Vertices and faces in another order (as another trimesh release lists them) give the same digest, frame
    and convex parts, so shipped starting postures still match."""
    mesh = family_mesh("ring_m")
    rng = np.random.default_rng(0)
    order = rng.permutation(len(mesh.vertices))
    faces = np.argsort(order)[mesh.faces][rng.permutation(len(mesh.faces))]
    shuffled = trimesh.Trimesh(mesh.vertices[order], np.roll(faces, 1, axis=1), process=False)
    ring, again = gm.get_object("ring_m"), gm.make_object("mesh", mesh=shuffled, name="ring_m")
    assert again.mesh_digest == ring.mesh_digest and again.params() == ring.params()
    np.testing.assert_array_equal(again.mesh.vertices, ring.mesh.vertices)
    assert [p.vertices.tolist() for p in again.parts] == [p.vertices.tolist() for p in ring.parts]


def test_the_family_holds_every_shape_in_three_sizes_and_the_paper_objects_as_meshes():
    assert len(FAMILY) == 3 * len(SHAPES) + 3
    for name in FAMILY:
        obj = gm.get_object(name)
        assert obj.shape == "mesh" and obj.mesh.is_watertight and obj.name == name
    small, large = gm.get_object("bottle_s"), gm.get_object("bottle_l")
    np.testing.assert_allclose(large.half_extents / small.half_extents, 1.5, rtol=1e-6)
    with pytest.raises(ValueError, match="family name"):
        gm.get_object("teapot_m")
    assert set(HELD_OUT) <= set(FAMILY)  # the shapes kept aside from tuning are members
    mug = gm.get_object("mug_m")  # a cup and its handle, one solid: its ring handle leaves a hole through it
    assert mug.mesh.euler_number == 0 and 0.079 < mug.narrowest_width < 0.081


# -- the generator's defaults ---------------------------------------------------------------------------------

#: every family member not held out (the held-out ones are checked once, in docs/studies/generator_defaults_held_out.md)
TEST_FAMILY = [name for name in FAMILY if name not in HELD_OUT]


def test_a_family_members_shipped_starts_are_found_whatever_the_last_bits_of_its_mesh():
    """A family mesh is computed where it is used; the last bits of its vertices (and its digest) change with the
    libraries' arithmetic, and its shipped starting postures are still its own; another solid of that name has
    none."""
    from dataclasses import replace

    from graspmanifold.synthesis.starts import shipped_starting_postures

    bottle = gm.get_object("bottle_l")
    shipped = [s.name for s in shipped_starting_postures(bottle, "grasp_types")]
    last_bits = replace(bottle, mesh_digest="0" * 16, half_sizes=tuple(h * (1 + 1e-14) for h in bottle.half_sizes))
    assert [s.name for s in shipped_starting_postures(last_bits, "grasp_types")] == shipped and len(shipped) >= 3
    larger = replace(bottle, mesh_digest="0" * 16, half_sizes=tuple(h * 1.01 for h in bottle.half_sizes))
    assert shipped_starting_postures(larger, "grasp_types") is None


@pytest.mark.parametrize("name", TEST_FAMILY)
def test_the_defaults_give_verified_postures_of_several_designs_and_grasp_types(name):
    """`generate_postures(obj, n)` with its defaults: n verified postures from at least three starting designs
    of at least two grasp types."""
    postures = gm.generate_postures(name, 6, seed=0, workers=1, progress=False)
    meta = postures.metadata
    used = [design for design, kept in meta["kept_by_start"].items() if kept]
    assert len(postures) == 6 and meta["verified"] and np.all(postures.hold_displacement <= 0.02)
    assert len(used) >= 3 and len({meta["grasp_types"][design] for design in used}) >= 2, meta["kept_by_start"]


# -- the pipeline ---------------------------------------------------------------------------------

@pytest.mark.parametrize("shape", sorted(set(SHAPES) - {"egg", "wedge"}))
def test_every_family_shape_generates_postures_trains_a_map_and_evaluates(shape):
    """Public API end to end on the small size: 24 postures (unverified candidates, to keep the test
    short), a 6 x 6 map, every other pose of the quick grid with that map, on one worker (the suite runs two files
    at once); physics healthy on every trial. The egg and the wedge, convex solids like the ellipsoid and the rounded
    box, take the same path and are left out to keep the suite short (they passed it when added)."""
    name = f"{shape}_s"
    postures = gm.generate_postures(name, 24, seed=0, workers=1, params=gm.GeneratorParams(verify=False))
    assert len(postures) == 24 and postures.metadata["object"]["mesh_digest"]
    som = gm.SOM(6, 6, 22, seed=0, epochs=10).fit(postures)
    result = gm.evaluate(name, som, gm.grid_preset("quick", name)[::2], seed=0, workers=1)
    assert len(result.trials) >= 10 and result.summary["invalid_trials"] == 0
    assert result.summary["hold_rate"] > 0.0  # the controller grasps the shape at least somewhere


def test_the_cli_generates_and_evaluates_on_a_mesh_file(tmp_path):
    path = tmp_path / "handle.stl"
    family_mesh("capsule_s").export(path)
    run = lambda *args: subprocess.run([sys.executable, "-m", "graspmanifold.cli", *args], capture_output=True,  # noqa: E731
                                       text=True, cwd=tmp_path, timeout=600)
    generated = run("generate", "--object", str(path), "--n", "40", "--no-verify", "--out", "handle.npz", "--workers", "1")
    assert generated.returncode == 0, generated.stderr
    evaluated = run("evaluate", "--object", str(path), "--experience", "database", "--postures", "handle.npz",
                    "--grid", "quick", "--out", "eval", "--workers", "1")
    assert evaluated.returncode == 0, evaluated.stderr
    assert "| handle |" in (tmp_path / "eval" / "table.md").read_text()
    refused = run("demo", "--object", str(tmp_path / "missing.stl"))
    assert refused.returncode != 0 and "no such file" in refused.stderr


def test_a_reproduction_runs_from_a_config_that_names_family_objects(tmp_path):
    from graspmanifold.paper.report import RunData, figure_from_run
    from graspmanifold.paper.reproduce import ReproduceConfig, reproduce

    config = ReproduceConfig(postures={"capsule_s": 40}, grid=((0.0, 0.0, 0.01, 0.0), (0.0, 0.01, 0.02, 0.2)),
                             map_size=(4, 4), epochs=5, image_size=32, generator=gm.GeneratorParams(verify=False))
    summary = reproduce(tmp_path / "run", config, workers=1, log=lambda line: None)
    methods = ("none", "database", "som", "som_all", "database_blend", "som_blend")
    assert [(r["object"], r["method"]) for r in summary["evaluation"]] == [("capsule_s", m) for m in methods]
    assert {"fig4_capsule_s", "fig6_capsule_s_evaluation", "fig8_capsule_s_resumed"} <= set(summary["figures"]["figures"])
    run = RunData.load(tmp_path / "run")
    assert set(run.results) == {("capsule_s", m) for m in methods}
    figure_from_run(tmp_path / "run", "fig6_capsule_s_evaluation", tmp_path / "again")
    assert (tmp_path / "again" / "fig6_capsule_s_evaluation.png").stat().st_size > 0
    with pytest.raises(ValueError, match="unknown object"):
        ReproduceConfig(postures={"teapot": 40})


def test_open_loop_grasps_of_a_mesh_set_ask_for_the_mesh_it_does_not_hold():
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.manifold.postureset import PostureSet

    can = gm.make_object("mesh", mesh=cylinder_mesh(), name="can")
    pose = np.array([[0.0, 0.1, 0.0, 1.0, 0.0, 0.0, 0.0]])
    made = PostureSet(gm.open_posture()[None], pose, np.zeros(1, int), np.zeros((1, len(gm.SEGMENTS)), bool),
                      ("s",), {"object": can.params(), "generator": {"stages": "contacts"}})
    with pytest.raises(ValueError, match=r"'can' is a mesh its file does not hold.*obj="):
        open_loop_grasps(made)
    assert len(open_loop_grasps(made, obj=can)) == 1


def test_an_object_file_of_a_robot_data_package_loads_by_its_file(tmp_path):
    """A URDF whose link is two mesh pieces (a convex decomposition) and an MJCF body of a mesh and a cylinder load as
    one object each, their pieces where the file puts them; a file MuJoCo cannot compile is refused by name."""
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=(0.03, 0.04, 0.1)).export(tmp_path / "meshes" / "half.stl")
    (tmp_path / "halves.urdf").write_text(
        '<robot name="halves"><link name="base_link">' + "".join(
            f'<collision><origin xyz="{dx} 0 0" rpy="0 0 0"/><geometry><mesh filename="meshes/half.stl"/></geometry>'
            "</collision>" for dx in (-0.015, 0.015)) + "</link></robot>")
    (tmp_path / "can.xml").write_text(
        '<mujoco><asset><mesh name="half" file="meshes/half.stl"/></asset><worldbody><body name="can"><freejoint/>'
        '<geom type="mesh" mesh="half" pos="0 0 0.05"/><geom type="cylinder" size="0.02 0.03" pos="0 0 -0.02"/>'
        "</body></worldbody></mujoco>")
    with pytest.warns(UserWarning, match="its 2 convex pieces kept"):
        halves = gm.make_object("mesh", mesh=tmp_path / "halves.urdf")
    assert halves.name == "halves" and len(halves.parts) == 2
    assert np.isclose(halves.mesh.volume, 0.06 * 0.04 * 0.1, rtol=1e-6)
    with pytest.warns(UserWarning, match="the union of 2 closed pieces"):
        can = gm.make_object("mesh", mesh=tmp_path / "can.xml")
    assert 0.03 * 0.04 * 0.1 < can.mesh.volume < 0.03 * 0.04 * 0.1 + np.pi * 0.02 ** 2 * 0.06
    (tmp_path / "broken.urdf").write_text("<robot><link name='a'><collision><geometry><mesh filename='none.stl'/>"
                                          "</geometry></collision></link></robot>")
    with pytest.raises(ValueError, match="broken.urdf.*mesh file: no such file: .*none.stl"):
        gm.make_object("mesh", mesh=tmp_path / "broken.urdf")
