"""Objects: the paper's sizes, the factory, and exact closest points."""

import numpy as np
import pytest

import graspmanifold as gm


def test_paper_objects_have_the_papers_sizes():
    np.testing.assert_allclose(gm.PAPER_OBJECTS["box"].half_extents, [0.02, 0.02, 0.08])
    np.testing.assert_allclose(gm.PAPER_OBJECTS["cylinder"].half_extents, [0.03, 0.03, 0.08])
    np.testing.assert_allclose(gm.PAPER_OBJECTS["sphere"].half_extents, [0.03, 0.03, 0.03])
    assert gm.get_object("box") is gm.PAPER_OBJECTS["box"]


def test_factory_makes_other_sizes_with_mass_and_friction():
    cyl = gm.make_object("cylinder", radius=0.04, length=0.2, mass=0.3, friction=0.7)
    assert cyl.half_sizes == (0.04, 0.1) and cyl.mass == 0.3 and cyl.friction == 0.7
    assert gm.make_object("box", size=(0.1, 0.05, 0.02)).half_sizes == (0.05, 0.025, 0.01)
    assert gm.make_object("sphere", radius=0.05).half_extents.tolist() == [0.05] * 3


def test_a_variant_of_a_paper_object_by_keyword_says_what_differs():
    """make_object("cylinder", friction=0.3) used to fail ("a cylinder needs ['radius', 'length']"), and the way
    that worked (dataclasses.replace) kept the name "cylinder", so nothing downstream showed the change."""
    slippery = gm.make_object("cylinder", friction=0.3)
    assert slippery.name == "cylinder_friction0.3" and "friction=0.3" in repr(slippery)
    assert slippery.half_sizes == gm.get_object("cylinder").half_sizes and slippery != gm.get_object("cylinder")
    assert gm.get_object("box").with_(mass=0.2, friction=0.5).name == "box_mass0.2_friction0.5"
    assert gm.get_object("box").with_(friction=gm.get_object("box").friction) is gm.get_object("box")
    assert gm.Scene(slippery).object.friction == 0.3


@pytest.mark.parametrize("call, message", [
    (lambda: gm.make_object("cone", radius=0.1), "unknown object shape"),
    (lambda: gm.make_object("sphere"), "needs"),
    (lambda: gm.make_object("sphere", radius=-1), "radius"),
    (lambda: gm.make_object("sphere", radius=float("nan")), "radius"),
    (lambda: gm.make_object("box", size=(0.1, 0.1)), "three extents"),
    (lambda: gm.make_object("sphere", radius=0.1, size=(1, 1, 1)), "not"),
    (lambda: gm.make_object("sphere", radius=0.1, mass=0), "mass"),
    (lambda: gm.get_object("teapot"), "unknown object"),
    # absurd sizes and friction, accepted before (meshes were already held to 5 mm - 30 cm)
    (lambda: gm.make_object("sphere", radius=0.0005), "every extent must be 5 mm to 30 cm"),
    (lambda: gm.make_object("box", size=(1e6, 0.05, 0.05)), "every extent must be 5 mm to 30 cm"),
    (lambda: gm.make_object("cylinder", radius=0.03, length=0.16, friction=1e6), "friction must be at most"),
    (lambda: gm.make_object("cylinder", friction=-0.3), "friction"),
])
def test_bad_object_arguments_raise(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def _surface_samples(obj, rng, n=40000):
    """Many points on the surface, found by projecting random points (checked independently below)."""
    pts = rng.uniform(-1.0, 1.0, (n, 3)) * obj.half_extents * 1.5
    return obj.closest_point(pts)


@pytest.mark.parametrize("obj", [gm.PAPER_OBJECTS["box"], gm.PAPER_OBJECTS["cylinder"], gm.PAPER_OBJECTS["sphere"],
                                 gm.make_object("box", size=(0.1, 0.03, 0.05)),
                                 gm.make_object("cylinder", radius=0.05, length=0.04)])
def test_closest_points_are_exact(obj, rng):
    query = rng.uniform(-1.0, 1.0, (300, 3)) * obj.half_extents * 2.0
    closest = obj.closest_point(query)
    distance = obj.signed_distance(query)
    # on the surface, at the stated distance
    np.testing.assert_allclose(obj.signed_distance(closest), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(query - closest, axis=1), np.abs(distance), atol=1e-12)
    # no sampled surface point is nearer (brute force)
    surface = _surface_samples(obj, rng)
    brute = np.min(np.linalg.norm(query[:, None, :] - surface[None, :, :], axis=2), axis=1)
    assert np.all(np.abs(distance) <= brute + 1e-12)
    # the sign: inside is negative
    inside = np.all(np.abs(query) < obj.half_extents * 0.5, axis=1) & (np.linalg.norm(query, axis=1) < 0.5 * obj.half_extents.min())
    assert np.all(distance[inside] < 0)


def test_closest_point_matches_mujoco_distance(rng):
    import mujoco
    for name in ("box", "cylinder", "sphere"):
        scene = gm.Scene(name)
        scene.set_hand_pose([0.4, 0, 0], [1, 0, 0, 0])
        obj = scene.object
        tip = scene.model.geom("ffdistal").id
        for _ in range(5):
            scene.set_posture(gm.open_posture())
            probe = rng.normal(size=3)
            probe *= (np.linalg.norm(obj.half_extents) + 0.02) / np.linalg.norm(probe)
            pos, quat = scene.hand_pose()
            scene.set_hand_pose(pos + probe - scene.data.geom_xpos[tip], quat)
            fromto = np.zeros(6)
            dist = mujoco.mj_geomDistance(scene.model, scene.data, tip, scene.object_geoms[0], 1.0, fromto)
            assert 0.0 < dist < 1.0
            # fromto[:3] is the capsule's nearest point: its distance to our surface is MuJoCo's distance
            assert abs(obj.signed_distance(fromto[:3]) - dist) < 5e-4, name


def test_single_point_queries_and_bad_points():
    obj = gm.PAPER_OBJECTS["sphere"]
    np.testing.assert_allclose(obj.closest_point([0.1, 0, 0]), [0.03, 0, 0])
    assert obj.signed_distance([0, 0, 0]) == pytest.approx(-0.03)
    with pytest.raises(ValueError, match="points"):
        obj.closest_point([[0, 0, np.nan]])
    with pytest.raises(ValueError, match="points"):
        obj.closest_point([[0, 0]])
