"""Experience that knows where the object sat (issue 66): a database keeps each grasp's place of the object in the
palm's frame, a SOM node its nearest training posture's; both through save and load; never matched."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold import InvalidInput
from graspmanifold.manifold.experience import check_experience, object_places


@pytest.fixture(scope="module")
def grasps():
    return gm.generate_postures("cylinder", 8, seed=0, workers=1)


def test_the_object_sits_in_front_of_the_palm_where_each_grasp_held_it(grasps):
    places = object_places(grasps)
    assert places.shape == (8, 3)
    assert np.all(places[:, 1] < 0) and np.all(np.linalg.norm(places, axis=1) < 0.2)  # the palm's -y: its front
    for place, pose in zip(places, grasps.hand_poses):  # the palm's pose applied to the place is the object's origin
        assert np.allclose(gm.base.poses.rotate(place, pose[3:]) + pose[:3], 0.0, atol=1e-12)


def test_a_database_keeps_each_postures_place_through_save_and_load(grasps, tmp_path):
    database = check_experience(grasps)
    assert np.array_equal(database.places, object_places(grasps)) and "with places" in repr(database)
    loaded = gm.PostureDatabase.load(database.save(tmp_path / "database.npz"))
    assert np.array_equal(loaded.places, database.places) and np.array_equal(loaded.postures, database.postures)
    plain = gm.PostureDatabase.load(gm.PostureDatabase(grasps.postures).save(tmp_path / "plain.npz"))
    assert plain.places is None
    query = grasps.postures[3].copy()
    mask = np.zeros(22, dtype=bool)
    mask[:4] = True
    assert database.best_match(query, mask) == plain.best_match(query, mask)  # places are never matched
    with pytest.raises(InvalidInput, match="places"):
        gm.PostureDatabase(grasps.postures, np.zeros((7, 3)))
    with pytest.raises(InvalidInput, match="places"):
        gm.PostureDatabase(grasps.postures, np.full((8, 3), np.nan))


def test_a_map_node_carries_its_nearest_training_postures_place_until_it_is_trained_again(grasps, tmp_path):
    places = object_places(grasps)
    som = gm.SOM(3, 3, 22, seed=0).fit(grasps.postures, epochs=5)
    assert som.places is None
    som.carry_places(grasps.postures, places)
    for node, place in zip(som.references, som.places):
        nearest = np.argmin(((grasps.postures - node) ** 2).sum(axis=1))
        assert np.array_equal(place, places[nearest])
    loaded = gm.SOM.load(som.save(tmp_path / "som.npz"))
    assert np.array_equal(loaded.places, som.places)
    som.resume(grasps.postures, epochs=1)  # new weights: the old places no longer belong to them
    assert som.places is None
    with pytest.raises(InvalidInput, match="places"):
        gm.SOM(3, 3, 22, seed=0).fit(grasps.postures, epochs=2).carry_places(grasps.postures, places[:5])
