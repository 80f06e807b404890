"""Fast exact queries on a closed triangle mesh: closest surface point, signed distance and surface normal.

The posture generator's springs ask for the closest surface point of five fingertips every physics step, and a
scan or a dataset's mesh has thousands of triangles. `MeshQueries` answers from structures built once per object
(in milliseconds, kept with the object): a k-d tree of points on the surface (the vertices and the triangles'
centroids) gives every query point an upper bound of its distance; only triangles whose bounding box lies within that bound can hold the
closest point, and a second k-d tree over the boxes' centres finds them; the closest point on each is computed
exactly (the projection onto its plane, else the nearest of its edges, vectorised) and the nearest taken. So the answers are the exact ones (tested
against every point-triangle pair: equal distances to 1e-12 m), not a grid's interpolation. The sign of the
distance comes from the angle-weighted pseudo-normal of the nearest feature (face, edge or vertex; Baerentzen and
Aanaes 2005), which is exact for a closed, consistently wound mesh, as every grasp object is (`meshes.make_solid`).

Triangles far larger than the typical one (a CAD model's long facets) would widen every ball search; they are kept
apart and tested by their boxes directly.
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

#: triangles whose bounding box is more than this many times the median's (half diagonal) are tested by their
#: boxes directly, not found through the k-d tree of box centres
LARGE_TRIANGLE = 4.0
#: barycentric weights below this put the closest point on an edge or a vertex (for the sign's pseudo-normal)
FEATURE_TOLERANCE = 1e-9


class MeshQueries:
    """Exact closest-point, signed-distance and normal queries on one closed mesh.

    Args:
        mesh: a watertight, consistently wound triangle mesh (m).
    """

    def __init__(self, mesh: trimesh.Trimesh):
        triangles = np.array(mesh.triangles, dtype=float)
        self._triangles = _Triangles(triangles)
        self._face_normals = np.array(mesh.face_normals, dtype=float)
        lower, upper = triangles.min(axis=1), triangles.max(axis=1)
        self._lower, self._upper = lower, upper
        half_diagonal = 0.5 * np.linalg.norm(upper - lower, axis=1)
        large = half_diagonal > LARGE_TRIANGLE * np.median(half_diagonal)
        self._small = np.flatnonzero(~large)
        self._large = np.flatnonzero(large)
        self._box_tree = cKDTree(0.5 * (lower + upper)[self._small])
        self._slack = float(half_diagonal[self._small].max())
        faces = np.asarray(mesh.faces)
        self._sample_tree = cKDTree(np.vstack([mesh.vertices, triangles.mean(axis=1)]))
        self._edge_normals, self._vertex_normals = _pseudo_normals(mesh)
        self._face_edges = np.asarray(mesh.faces_unique_edges)
        self._faces = faces

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The closest surface points, their triangles and the features they lie on.

        Args:
            points: (n, 3), m, finite.

        Returns:
            Closest points (n, 3), m; their triangles (n,); their features (n,): 0 the face's interior, 1-3 its
            corners, 4-6 its edges (first-second, second-third, third-first corner).
        """
        p = np.asarray(points, dtype=float)
        n = len(p)
        bound = self._sample_tree.query(p)[0] * (1.0 + 1e-12) + 1e-15  # a surface point's distance: an upper bound
        found = self._box_tree.query_ball_point(p, bound + self._slack, return_sorted=False)
        counts = np.fromiter((len(f) for f in found), dtype=np.intp, count=n)
        rows = np.repeat(np.arange(n), counts)
        cols = self._small[np.fromiter((i for f in found for i in f), dtype=np.intp, count=int(counts.sum()))]
        if len(self._large):
            rows = np.concatenate([rows, np.repeat(np.arange(n), len(self._large))])
            cols = np.concatenate([cols, np.tile(self._large, n)])
        gap = p[rows] - np.clip(p[rows], self._lower[cols], self._upper[cols])
        near = np.einsum("ij,ij->i", gap, gap) <= bound[rows] ** 2
        rows, cols = rows[near], cols[near]
        on, feature = self._triangles.closest(cols, p[rows])
        squared = np.einsum("ij,ij->i", on - p[rows], on - p[rows])
        order = np.lexsort((cols, squared, rows))  # per point the nearest, ties to the lowest triangle
        best = order[np.searchsorted(rows[order], np.arange(n))]
        return on[best], cols[best], feature[best]

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distances (n,), m, negative inside, of points (n, 3), m."""
        p = np.asarray(points, dtype=float)
        on, triangle, feature = self.closest(p)
        offset = p - on
        distance = np.linalg.norm(offset, axis=1)
        return np.where(np.einsum("ij,ij->i", offset, self._pseudo_normal(triangle, feature)) < 0.0,
                        -distance, distance)

    def normal(self, points: np.ndarray) -> np.ndarray:
        """Outward unit normals (n, 3) of the faces that hold the closest points of points (n, 3), m."""
        return self._face_normals[self.closest(points)[1]]

    def _pseudo_normal(self, triangle: np.ndarray, feature: np.ndarray) -> np.ndarray:
        """The angle-weighted pseudo-normal (n, 3) of each feature (`closest`'s codes) of each triangle."""
        normal = self._face_normals[triangle].copy()
        corner = (feature >= 1) & (feature <= 3)
        normal[corner] = self._vertex_normals[self._faces[triangle[corner], feature[corner] - 1]]
        edge = feature >= 4
        normal[edge] = self._edge_normals[self._face_edges[triangle[edge], feature[edge] - 4]]
        return normal


def _pseudo_normals(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Each unique edge's pseudo-normal (the sum of its faces' normals) and each vertex's (the sum of its faces'
    normals weighed by the faces' angles there), in the orders of `mesh.edges_unique` and `mesh.vertices`."""
    normals = np.asarray(mesh.face_normals)
    edges = np.zeros((len(mesh.edges_unique), 3))
    np.add.at(edges, np.asarray(mesh.faces_unique_edges).ravel(), np.repeat(normals, 3, axis=0))
    vertices = np.zeros((len(mesh.vertices), 3))
    angles = np.nan_to_num(np.asarray(mesh.face_angles))
    np.add.at(vertices, np.asarray(mesh.faces).ravel(), (angles[:, :, None] * normals[:, None, :]).reshape(-1, 3))
    return edges, vertices


class _Triangles:
    """Triangles (n, 3, 3) with what `closest` needs of each precomputed: a corner and two sides, the sides' Gram
    matrix inverted, and the three edges (first-second, second-third, third-first) with their squared lengths."""

    def __init__(self, corners: np.ndarray):
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        self.a, self.ab, self.ac = a, b - a, c - a
        d00, d01, d11 = (np.einsum("ij,ij->i", u, v) for u, v in ((self.ab, self.ab), (self.ab, self.ac),
                                                                   (self.ac, self.ac)))
        determinant = d00 * d11 - d01 * d01
        usable = determinant > 1e-30 * np.maximum(d00 * d11, 1e-300)  # a degenerate one is only its edges
        inverse = np.where(usable, 1.0 / np.where(usable, determinant, 1.0), 0.0)
        self.gram = np.stack([d11 * inverse, -d01 * inverse, d00 * inverse], axis=1) * usable[:, None]
        self.usable = usable
        self.starts = corners  # (n, 3 edges, 3)
        self.edges = np.stack([b - a, c - b, a - c], axis=1)
        self.lengths = np.maximum(np.einsum("ijk,ijk->ij", self.edges, self.edges), 1e-300)

    def closest(self, index: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The closest point of triangle `index[i]` to `points[i]` (n, 3) and the feature it lies on (codes of
        `MeshQueries.closest`): the projection onto the plane where it falls inside the triangle (all barycentric
        weights above `FEATURE_TOLERANCE`), else the nearest of the three edges' closest points."""
        offset = points - self.a[index]
        e0, e1 = np.einsum("ij,ij->i", offset, self.ab[index]), np.einsum("ij,ij->i", offset, self.ac[index])
        gram = self.gram[index]
        v, w = gram[:, 0] * e0 + gram[:, 1] * e1, gram[:, 1] * e0 + gram[:, 2] * e1
        inside = self.usable[index] & (v > FEATURE_TOLERANCE) & (w > FEATURE_TOLERANCE) & (v + w < 1.0 - FEATURE_TOLERANCE)
        closest = self.a[index] + v[:, None] * self.ab[index] + w[:, None] * self.ac[index]
        feature = np.zeros(len(index), dtype=np.intp)
        rim = np.flatnonzero(~inside)
        if len(rim):
            starts, edges = self.starts[index[rim]], self.edges[index[rim]]
            along = np.einsum("ijk,ijk->ij", points[rim, None] - starts, edges) / self.lengths[index[rim]]
            along = np.clip(along, 0.0, 1.0)
            on_edges = starts + along[:, :, None] * edges  # (rim, 3, 3)
            gaps = on_edges - points[rim, None]
            edge = np.argmin(np.einsum("ijk,ijk->ij", gaps, gaps), axis=1)
            rows = np.arange(len(rim))
            closest[rim] = on_edges[rows, edge]
            t = along[rows, edge]
            # an edge's ends are corners: edge e runs from corner e to corner (e + 1) % 3
            feature[rim] = np.where(t <= 0.0, 1 + edge, np.where(t >= 1.0, 1 + (edge + 1) % 3, 4 + edge))
        return closest, feature
