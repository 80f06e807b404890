"""Scenes: composition, hand placement, closing on an object, tactile readings."""

import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import graspmanifold as gm


def random_quat(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


@pytest.mark.parametrize("free", [False, True])
def test_set_hand_pose_places_the_palm_in_the_object_frame(free, rng):
    scene = gm.Scene("box", free_object=free)
    for _ in range(10):
        limits = gm.finger_limits()
        scene.set_posture(rng.uniform(limits[:, 0], limits[:, 1]), wrist=rng.uniform(-0.3, 0.1, 2))
        pos, quat = rng.uniform(-0.2, 0.2, 3), random_quat(rng)
        scene.set_hand_pose(pos, quat)
        got_pos, got_quat = scene.hand_pose()
        np.testing.assert_allclose(got_pos, pos, atol=1e-9)
        assert abs(abs(np.dot(got_quat, quat)) - 1.0) < 1e-9


def test_scene_composes_hand_and_named_object():
    scene = gm.Scene("cylinder")
    assert scene.model.body("object").id > 0
    assert scene.model.geom("object").type == mujoco.mjtGeom.mjGEOM_CYLINDER
    np.testing.assert_allclose(scene.model.geom("object").size[:2], [0.03, 0.08])
    custom = gm.Scene(gm.make_object("sphere", radius=0.05, mass=0.2, friction=0.5))
    assert custom.model.body("object").mass[0] == pytest.approx(0.2)
    assert custom.model.geom("object").friction[0] == pytest.approx(0.5)
    assert gm.Scene("sphere", free_object=True).model.nq == 24 + 7


def test_unknown_object_and_bad_postures_raise():
    with pytest.raises(ValueError, match="unknown object"):
        gm.Scene("teapot")
    scene = gm.Scene("sphere")
    with pytest.raises(ValueError, match="shape"):
        scene.set_posture(np.zeros(24))
    with pytest.raises(ValueError, match="non-finite"):
        scene.set_target(np.full(22, np.nan))
    with pytest.raises(ValueError, match="quaternion"):
        scene.set_hand_pose([0, 0, 0], [0, 0, 0, 0])


def test_set_posture_holds_still():
    scene = gm.Scene("sphere")
    scene.set_hand_pose([0.5, 0, 0], [1, 0, 0, 0])
    flex = np.array([0.0 if j[-1] in "45" else 0.3 for j in gm.FINGER_JOINTS])  # no abduction: fingers stay apart
    target = gm.clip_posture(gm.open_posture() + flex)
    scene.set_posture(target)
    scene.run(0.5)
    assert np.max(np.abs(scene.posture() - target)) < 0.05


def closed_on(name, seconds=2.0):
    scene = gm.Scene(name)
    scene.set_hand_pose(*gm.facing_pose(name, clearance=0.01))
    scene.set_posture(gm.open_posture())
    scene.set_target(gm.closed_posture())
    worst = 0.0
    for _ in range(int(seconds / 0.1)):
        scene.run(0.1)
        assert np.all(np.isfinite(scene.data.qpos)) and np.all(np.isfinite(scene.data.qvel))
        reading = scene.tactile()
        assert np.all(np.isfinite(reading.forces))
        worst = max(worst, reading.max_penetration)
    return scene, scene.tactile(), worst


@pytest.mark.parametrize("name", ["cylinder", "box", "sphere"])
def test_closing_on_an_object_is_stable(name):
    scene, reading, worst = closed_on(name)
    assert len(reading.segments) >= 4, reading.segments
    assert worst <= 0.002
    assert np.all(reading.forces >= 0) and reading.forces.sum() > 0
    assert np.max(np.abs(scene.data.qvel)) < 0.5  # settled: no jitter


def test_tactile_reading_geometry():
    scene, reading, _ = closed_on("sphere", seconds=1.0)
    k = len(reading.forces)
    assert reading.points.shape == (k, 3) and reading.normals.shape == (k, 3) and len(reading.contact_segments) == k
    np.testing.assert_allclose(np.linalg.norm(reading.normals, axis=1), 1.0, atol=1e-9)
    # on a sphere at the origin every normal pointing into the object points at the centre
    inward = -reading.points / np.linalg.norm(reading.points, axis=1, keepdims=True)
    assert np.all(np.sum(inward * reading.normals, axis=1) > 0.95)
    assert sum(reading.force_on(s) for s in reading.segments) == pytest.approx(reading.forces.sum())
    assert reading.touches(reading.segments[0])
    with pytest.raises(ValueError, match="unknown segment"):
        reading.force_on("elbow")


def test_self_contacts_are_not_tactile_events():
    scene = gm.Scene("sphere")
    scene.set_hand_pose([0.5, 0, 0], [1, 0, 0, 0])  # the object is out of reach
    fist = gm.closed_posture()
    fist[gm.FINGER_JOINTS.index("THJ4")] = 1.22
    scene.set_posture(gm.open_posture())
    scene.set_target(fist)
    scene.run(1.0)
    assert scene.data.ncon > 0  # fingers and thumb touch each other ...
    assert scene.tactile().segments == ()  # ... but that is no touch of the object


def test_gravity_switch_drops_a_free_object():
    scene = gm.Scene("sphere", free_object=True)
    scene.set_hand_pose([0.5, 0, 0], [1, 0, 0, 0])
    scene.run(0.2)
    assert np.linalg.norm(scene.object_pose()[0]) < 1e-9
    scene.set_gravity([9.81, 0, 0])
    scene.run(0.2)
    assert scene.object_pose()[0][0] > 0.1
    with pytest.raises(ValueError, match="gravity"):
        scene.set_gravity([0, 0])


def test_installed_package_works_from_another_directory(tmp_path):
    code = "import graspmanifold as g; g.load_hand(); g.Scene('cylinder'); print(g.sim.hand.asset_path('shadow_hand.xml'))"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, check=True)
    asset = Path(out.stdout.strip())
    assert asset.is_file()
    package_dir = Path(gm.__file__).parent
    if "site-packages" in str(package_dir):  # a wheel install must carry its assets inside the package
        assert package_dir in asset.parents
