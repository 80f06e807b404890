"""Grasp quality: the Ferrari-Canny epsilon of the L1 grasp wrench space (the paper's success measure).

Each contact's Coulomb friction cone is linearised by `num_edges` unit-normal-component edge forces
f = n + mu (cos t_k t1 + sin t_k t2); every edge gives the wrench (f, (p - c) x f / lambda). The L1
grasp wrench space is the convex hull of all of them, and epsilon is the radius of the largest ball
around the origin inside it: the magnitude of the worst-case disturbance wrench the grasp resists
per unit of total normal force. A grasp is force closure when epsilon > 0.

Degenerate wrench sets (fewer than two contacts, not spanning all six dimensions) give 0; a
numerical failure of the hull raises `QualityError` rather than reading as "not force closure".
Many cone edges make the full 6-D hull huge (an eight-contact grasp at 128 edges: two million
facets, a minute), so epsilon is found from a small hull grown where it matters: the hull of 8
edges per cone, then, round by round, the wrenches beyond its facet nearest the origin are added
until that facet supports every wrench. The hull of a subset lies inside the full one, so its
nearest distance is a lower bound, and a supporting facet at that distance makes it exact.

The cone polygon of a contact is oriented by its lever arm (p - c) projected onto the tangent plane,
so epsilon is exactly invariant to rotating and to scaling the whole grasp; when the lever arm is
parallel to the normal (a sphere grasped around its centre) the least aligned world axis orients it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..base.errors import InvalidInput, QualityError
from ..base.validation import check_int

#: epsilon with many cone edges starts from this many per cone and adds, round by round, at most
#: REFINE_WRENCHES of the other edges beyond the nearest facet (see `epsilon_l1`): few at a time keeps
#: the hull small where symmetric contacts put many edges on one facet (4 antipodal contacts on a
#: sphere: 64 edges took 18.6 s adding 32 a round, 3.1 s adding 8)
COARSE_EDGES = 8
REFINE_WRENCHES = 8
#: the finest friction cone: beyond it epsilon no longer changes (4 antipodal contacts on a sphere:
#: 0.40002 at 32 edges, 0.40016 at 64) while a symmetric grasp's hull can take minutes (128 edges)
MAX_EDGES = 64


def _array(value: object, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != len(shape) or any(s is not None and s != g for s, g in zip(shape, a.shape)):
        raise InvalidInput(f"{name} must have shape {tuple('k' if s is None else s for s in shape)}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InvalidInput(f"{name} must be finite")
    return a


def _tangent_bases(normals: np.ndarray, levers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    projected = levers - np.sum(levers * normals, axis=1, keepdims=True) * normals
    length = np.linalg.norm(projected, axis=1)
    scale = np.maximum(np.linalg.norm(levers, axis=1), 1e-12)
    fallback = length < 1e-6 * scale
    if fallback.any():
        axes = np.eye(3)[np.argmin(np.abs(normals[fallback]), axis=1)]
        projected[fallback] = axes - np.sum(axes * normals[fallback], axis=1, keepdims=True) * normals[fallback]
        length[fallback] = np.linalg.norm(projected[fallback], axis=1)
    t1 = projected / length[:, None]
    return t1, np.cross(normals, t1)


def contact_wrenches(points: np.ndarray, normals: np.ndarray, center: np.ndarray, mu: float,
                     num_edges: int = 8, torque_scale: float | None = None) -> np.ndarray:
    """The (k * num_edges, 6) edge wrenches of the linearised friction cones (see module doc)."""
    points = _array(points, (None, 3), "points")
    normals = _array(normals, (len(points), 3), "normals")
    center = _array(center, (3,), "center")
    if not np.isfinite(mu) or mu < 0:
        raise InvalidInput(f"mu must be a finite friction coefficient >= 0, got {mu!r}")
    check_int(num_edges, "num_edges", low=3, high=MAX_EDGES)
    length = np.linalg.norm(normals, axis=1)
    if np.any(length < 1e-12):
        raise InvalidInput("normals must be non-zero vectors")
    normals = normals / length[:, None]
    levers = points - center
    if torque_scale is None:
        torque_scale = float(np.max(np.linalg.norm(levers, axis=1))) if len(points) else 1.0
    elif not np.isfinite(torque_scale) or torque_scale <= 0:
        raise InvalidInput(f"torque_scale must be positive, got {torque_scale!r}")
    if torque_scale <= 0:
        torque_scale = 1.0  # every contact at the centre: torques are zero anyway
    t1, t2 = _tangent_bases(normals, levers)
    angles = 2 * np.pi * np.arange(num_edges) / num_edges
    forces = (normals[:, None, :] + mu * (np.cos(angles)[None, :, None] * t1[:, None, :]
                                          + np.sin(angles)[None, :, None] * t2[:, None, :]))
    torques = np.cross(levers[:, None, :], forces) / torque_scale
    return np.concatenate([forces, torques], axis=2).reshape(-1, 6)


def epsilon_l1(points: np.ndarray, normals: np.ndarray, center: np.ndarray, mu: float,
               num_edges: int = 8, torque_scale: float | None = None) -> float:
    """Ferrari-Canny epsilon of the L1 grasp wrench space; 0 when the grasp is not force closure.

    Fewer than two contacts or a wrench set that does not span all six dimensions give 0.

    Args:
        points: contact points (k, 3), m, in one frame with `normals` and `center`.
        normals: contact normals (k, 3), pointing into the object.
        center: the reference point for torques (3,), m: the object's centre of mass.
        mu: the friction coefficient, with no default: pass the simulation's
            (`scene.object.friction`), or epsilon is not the one the evaluation judges by.
        num_edges: edges of each linearised friction cone, 3 ... `MAX_EDGES`.
        torque_scale: lambda, m (default: the largest distance from `center` to a contact).

    Returns:
        epsilon, per unit of total normal force (0 when not force closure).
    """
    wrenches = contact_wrenches(points, normals, center, mu, num_edges, torque_scale)
    if len(points) < 2:
        return 0.0
    every, row = np.unique(np.round(wrenches, 12), axis=0, return_inverse=True)  # coinciding contacts
    if np.linalg.matrix_rank(every, tol=1e-9) < 6:                                  # give the same edges
        return 0.0
    coarse = np.zeros(num_edges, dtype=bool)  # COARSE_EDGES evenly spaced edges of every cone
    count = min(COARSE_EDGES, num_edges)
    coarse[np.floor(np.arange(count) * num_edges / count).astype(int)] = True
    chosen = np.zeros(len(every), dtype=bool)
    chosen[row.ravel()[np.tile(coarse, len(points))]] = True
    if np.linalg.matrix_rank(every[chosen], tol=1e-9) < 6:
        chosen[:] = True
    tolerance = 1e-10 * float(np.abs(every).max())
    while True:
        hull = _hull(every[chosen])
        facet = int(np.argmax(hull.equations[:, -1]))  # unit normal . x + offset <= 0 inside
        normal, distance = hull.equations[facet, :-1], -hull.equations[facet, -1]
        heights = every @ normal
        beyond = np.flatnonzero((heights > distance + tolerance) & ~chosen)
        if not len(beyond):  # the nearest facet supports every wrench: it is the whole set's nearest too
            return float(distance) if distance > 1e-12 else 0.0
        chosen[beyond[np.argsort(-heights[beyond])[:REFINE_WRENCHES]]] = True


def _hull(wrenches: np.ndarray) -> ConvexHull:
    """The convex hull of a full-rank wrench set; Qhull's precision errors on nearly coplanar edge
    sets (many cone edges) are retried with joggled input ('QJ', perturbations near 1e-11), and a
    second failure raises instead of reading as "not force closure"."""
    try:
        return ConvexHull(wrenches)
    except QhullError:
        pass
    try:
        return ConvexHull(wrenches, qhull_options="QJ")
    except QhullError as error:
        raise QualityError(f"Qhull failed on {len(wrenches)} wrenches even with joggled input: "
                           f"{str(error).splitlines()[0]}") from None


#: m: contacts farther from the object than this do not count for `q1`
Q1_CONTACT_DISTANCE = 0.005


def q1(points: np.ndarray, normals: np.ndarray, links: np.ndarray, distances: np.ndarray | None = None,
       friction: float = 0.6) -> float:
    """DexGraspBench's Q1 (Ferrari-Canny) of a grasp's contacts, in its convention: contacts within 5 mm of the
    object (the caller keeps the fingertip links' only), every link's contacts averaged into one point and
    normal, an 8-edge friction pyramid at half the friction, torques about the contacts' centroid divided by
    their mean distance from it. DexGraspBench reports 2 - q1 (2 without contacts); this returns q1.

    Args:
        points: (k, 3) m, contact points.
        normals: (k, 3) contact normals into the object (need not be unit).
        links: (k,) the link (body) each contact is on.
        distances: (k,) m, each contact's distance to the object (negative: penetrating); None: all count.
        friction: the sliding friction of the simulation (DexGraspBench: 0.6); the metric takes half.

    Returns:
        q1 (0: not force closure, or fewer than two links touch).
    """
    points, normals = np.asarray(points, dtype=float), np.asarray(normals, dtype=float)
    links = np.asarray(links)
    if points.ndim != 2 or points.shape[1:] != (3,) or normals.shape != points.shape or links.shape != (len(points),):
        raise InvalidInput(f"points and normals must be (k, 3) and links (k,), got {points.shape}, {normals.shape} "
                           f"and {links.shape}")
    near = np.ones(len(points), dtype=bool) if distances is None else np.asarray(distances) <= Q1_CONTACT_DISTANCE
    points, normals, links = points[near], normals[near], links[near]
    unit = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    merged = [(points[links == link].mean(axis=0), unit[links == link].mean(axis=0)) for link in np.unique(links)]
    if len(merged) < 2:
        return 0.0
    where, towards = (np.array(x) for x in zip(*merged))
    centroid = where.mean(axis=0)
    radius = float(np.linalg.norm(where - centroid, axis=1).mean())
    return epsilon_l1(where, towards, centroid, mu=friction / 2, num_edges=8, torque_scale=radius or None)
