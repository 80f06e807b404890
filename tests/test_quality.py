"""The Ferrari-Canny epsilon of the L1 grasp wrench space."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graspmanifold.judging.quality import contact_wrenches, epsilon_l1

TETRAHEDRON = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3)


def sphere_grasp(directions, radius=0.03):
    points = radius * np.asarray(directions, dtype=float)
    return points, -points / radius  # normals point into the sphere


def box_grasp():
    """Five contacts on a 4 x 4 x 16 cm box, as a hand would place them (not symmetric)."""
    points = np.array([[0.02, 0.005, 0.03], [0.02, -0.01, -0.02], [-0.02, 0.0, 0.01], [-0.02, 0.008, -0.035],
                       [0.0, 0.02, 0.0]])
    normals = np.array([[-1, 0, 0], [-1, 0, 0], [1, 0, 0], [1, 0, 0], [0, -1, 0]], dtype=float)
    return points, normals


def test_tetrahedral_contacts_on_a_sphere_are_force_closure():
    points, normals = sphere_grasp(TETRAHEDRON)
    assert epsilon_l1(points, normals, np.zeros(3), mu=0.5) > 0.05
    assert epsilon_l1(points, normals, np.zeros(3), mu=0.0) == 0.0  # frictionless points cannot resist torque


def test_two_antipodal_contacts_give_zero():
    points, normals = sphere_grasp([[1, 0, 0], [-1, 0, 0]])
    assert epsilon_l1(points, normals, np.zeros(3), mu=1.0) == 0.0


def test_contacts_all_on_one_side_give_zero():
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(6, 3))
    directions[:, 2] = np.abs(directions[:, 2]) + 0.2  # upper hemisphere only
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points, normals = sphere_grasp(directions)
    assert epsilon_l1(points, normals, np.zeros(3), mu=0.3) == 0.0


def test_fewer_than_two_contacts_give_zero_and_malformed_input_raises():
    assert epsilon_l1(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(3), mu=0.6) == 0.0
    assert epsilon_l1([[0.03, 0, 0]], [[-1, 0, 0]], np.zeros(3), mu=0.6) == 0.0
    with pytest.raises(ValueError, match="normals must have shape"):
        epsilon_l1(np.zeros((3, 3)), np.zeros((2, 3)), np.zeros(3), mu=0.6)
    with pytest.raises(ValueError, match="points must be finite"):
        epsilon_l1([[np.nan, 0, 0], [1, 0, 0]], [[1, 0, 0], [-1, 0, 0]], np.zeros(3), mu=0.6)
    with pytest.raises(ValueError, match="non-zero"):
        epsilon_l1([[1, 0, 0], [-1, 0, 0]], [[0, 0, 0], [1, 0, 0]], np.zeros(3), mu=0.6)
    with pytest.raises(ValueError, match="mu"):
        epsilon_l1([[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]], np.zeros(3), mu=-1)
    with pytest.raises(ValueError, match="num_edges"):
        epsilon_l1([[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]], np.zeros(3), mu=0.6, num_edges=2)


@pytest.mark.parametrize("grasp", ["box", "offset_sphere"])
def test_epsilon_is_invariant_to_rotation_and_scale(grasp):
    if grasp == "box":
        points, normals = box_grasp()
        center = np.array([0.001, 0.002, 0.0])
    else:
        points, normals = sphere_grasp(TETRAHEDRON)
        center = np.array([0.004, -0.002, 0.003])  # lever arms not parallel to the normals
    reference = epsilon_l1(points, normals, center, mu=0.6)
    assert reference > 0
    for seed in range(5):
        rotation = Rotation.random(random_state=seed).as_matrix()
        shift = np.random.default_rng(seed).normal(size=3)
        moved = epsilon_l1((points - center) @ rotation.T + shift, normals @ rotation.T, shift, mu=0.6)
        assert moved == pytest.approx(reference, rel=1e-9)
    for scale in (0.1, 3.0, 50.0):
        assert epsilon_l1(points * scale, normals, center * scale, mu=0.6) == pytest.approx(reference, rel=1e-9)


def test_adding_a_contact_never_lowers_epsilon():
    rng = np.random.default_rng(3)
    for _ in range(20):
        directions = rng.normal(size=(4, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        points, normals = sphere_grasp(directions)
        center = rng.normal(scale=0.003, size=3)
        before = epsilon_l1(points, normals, center, mu=0.5, torque_scale=0.04)
        extra_dir = rng.normal(size=3)
        extra_dir /= np.linalg.norm(extra_dir)
        extra_p, extra_n = sphere_grasp([extra_dir])
        after = epsilon_l1(np.vstack([points, extra_p]), np.vstack([normals, extra_n]), center, mu=0.5,
                           torque_scale=0.04)
        assert after >= before - 1e-12
        # with the default torque scale too, when the new contact is no farther from the centre
        lam = np.max(np.linalg.norm(points - center, axis=1))
        if np.linalg.norm(extra_p[0] - center) <= lam:
            assert epsilon_l1(np.vstack([points, extra_p]), np.vstack([normals, extra_n]), center, mu=0.5) >= \
                epsilon_l1(points, normals, center, mu=0.5) - 1e-12


def test_edge_wrenches_have_unit_normal_component():
    points, normals = box_grasp()
    wrenches = contact_wrenches(points, normals, np.zeros(3), mu=0.4, num_edges=6)
    assert wrenches.shape == (30, 6)
    forces = wrenches[:, :3].reshape(5, 6, 3)
    np.testing.assert_allclose(np.einsum("kej,kj->ke", forces, normals), 1.0)
    tangential = forces - np.einsum("kej,kj->ke", forces, normals)[..., None] * normals[:, None, :]
    np.testing.assert_allclose(np.linalg.norm(tangential, axis=2), 0.4)


def test_epsilon_has_no_friction_default_that_could_disagree_with_the_simulation():
    """The README's snippet once called epsilon_l1 without mu and got the default 1.0, five times the
    simulation's 0.6 (0.189 against 0.036 on one grasp): the friction is now a required argument."""
    with pytest.raises(TypeError, match="mu"):
        epsilon_l1([[0.03, 0, 0], [-0.03, 0, 0]], [[-1, 0, 0], [1, 0, 0]], np.zeros(3))
