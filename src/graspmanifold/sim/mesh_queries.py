"""Fast exact queries on a closed triangle mesh: closest surface point, signed distance and surface normal.

The posture generator's springs ask for the closest surface point of five fingertips every physics step, and a
scan or a dataset's mesh has thousands of triangles. `MeshQueries` answers from structures built once per object
and process (`mesh_queries`), in two ways with one rule, the exact closest point of each candidate triangle (its
plane's projection where that falls inside it, else the nearest of its edges' closest points):

- near the object (its box grown by `GRID_MARGIN`, where the fingertips are) a compiled query (numba): a grid of
  cells, each with the triangles that can hold the closest point of any point in it (those whose box lies within
  a bound of the cell centre's distance plus the cell's diagonal), found when a query first falls in the cell, a
  few microseconds a point;
- anywhere (the points outside the grid, or in a cell of more than `GRID_MOST` candidates), a k-d tree of points
  on the surface (vertices and centroids) bounds each point's distance, and a k-d tree of the triangles' box
  centres finds the triangles within the bound (triangles far larger than the typical one are tested by their
  boxes directly).

Both are exact (tested against every point-triangle pair: equal distances to 1e-12 m), not a grid's interpolation.
The sign of the distance comes from the angle-weighted pseudo-normal of the nearest feature (face, edge or vertex;
Baerentzen and Aanaes 2005), which is exact for a closed, consistently wound mesh, as every grasp object is
(`meshes.make_solid`; tested against the winding number).
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from ..base.compiled import compiled, compiled_kernel

#: triangles whose bounding box is more than this many times the median's (half diagonal) are tested by their
#: boxes directly, not found through the k-d tree of box centres
LARGE_TRIANGLE = 4.0
#: barycentric weights below this put the closest point on an edge or a vertex (for the sign's pseudo-normal)
FEATURE_TOLERANCE = 1e-9
#: the compiled query's grid: the object's box grown by this margin (m) on every side, in cells of its largest
#: extent over `GRID_CELLS`
GRID_MARGIN = 0.03
GRID_CELLS = 24
#: a cell that would hold more candidate triangles than this (deep inside the object, where no fingertip goes) is
#: left to the k-d tree query
GRID_MOST = 2048
#: `_grid_closest`'s mark of a point in a cell whose candidates are not found yet
UNFILLED = -2


#: the queries built in this process, by mesh digest (a worker process builds an object's once, not once per task)
_BUILT: dict[str, MeshQueries] = {}
#: the most kept (an object's are megabytes)
BUILT_KEPT = 8


def mesh_queries(mesh: trimesh.Trimesh, digest: str) -> MeshQueries:
    """The queries of a mesh, built once per process and digest (the most recent `BUILT_KEPT` kept).

    Args:
        mesh: a watertight, consistently wound triangle mesh (m).
        digest: what tells this mesh from others (`meshes.mesh_digest`).

    Returns:
        Its `MeshQueries`.
    """
    if digest not in _BUILT:
        while len(_BUILT) >= BUILT_KEPT:
            _BUILT.pop(next(iter(_BUILT)))
        _BUILT[digest] = MeshQueries(mesh)
    return _BUILT[digest]


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
        self._corners = np.ascontiguousarray(triangles)
        self._cell = float(np.max(mesh.extents)) / GRID_CELLS
        self._origin = np.asarray(mesh.bounds[0], dtype=float) - GRID_MARGIN
        self._shape = np.ceil((np.asarray(mesh.extents) + 2 * GRID_MARGIN) / self._cell).astype(np.int64)
        cells = int(np.prod(self._shape))
        #: each cell's candidates, `_found[_starts[c]:_starts[c] + _counts[c]]`, filled on a cell's first query
        #: (a start of -1: not yet; a count of 0: left to the k-d trees)
        self._starts, self._counts = np.full(cells, -1, np.int64), np.zeros(cells, np.int64)
        self._found = np.zeros(0, np.int32)

    def _fill(self, cells: np.ndarray) -> None:
        """Find the candidate triangles of these cells (`_grid_candidates`)."""
        ijk = np.stack(np.unravel_index(cells, tuple(self._shape)), axis=1)
        centres = self._origin + (ijk + 0.5) * self._cell
        bound = self._sample_tree.query(centres)[0]  # a surface point's distance: at least the centre's own
        reach = bound + math.sqrt(3.0) * self._cell  # and twice the cell's half diagonal
        starts, found = _grid_candidates(centres, reach * (1.0 + 1e-9) + 1e-12, self._lower, self._upper, GRID_MOST)
        self._starts[cells], self._counts[cells] = len(self._found) + starts[:-1], np.diff(starts)
        self._found = np.concatenate([self._found, found])

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The closest surface points, their triangles and the features they lie on: from the compiled grid query
        for points near the object, from the k-d tree query (`_closest_reference`) for the others (for all, with the
        compiled code switched off: `base.compiled`).

        Args:
            points: (n, 3), m, finite.

        Returns:
            Closest points (n, 3), m; their triangles (n,); their features (n,): 0 the face's interior, 1-3 its
            corners, 4-6 its edges (first-second, second-third, third-first corner).
        """
        p = np.ascontiguousarray(points, dtype=float)
        if not compiled():
            return self._closest_reference(p)
        on, triangle, feature = np.empty_like(p), np.empty(len(p), np.int64), np.empty(len(p), np.int64)
        grid = (self._origin, self._cell, self._shape)
        _grid_closest(p, *grid, self._starts, self._counts, self._found, self._corners, FEATURE_TOLERANCE,
                      on, triangle, feature)
        new = np.flatnonzero(triangle == UNFILLED)
        if len(new):  # cells met for the first time: find their candidates, then ask again
            ijk = np.floor((p[new] - self._origin) / self._cell).astype(np.int64)
            self._fill(np.unique(np.ravel_multi_index(tuple(ijk.T), tuple(self._shape))))
            again = [np.empty((len(new), 3)), np.empty(len(new), np.int64), np.empty(len(new), np.int64)]
            _grid_closest(np.ascontiguousarray(p[new]), *grid, self._starts, self._counts, self._found,
                          self._corners, FEATURE_TOLERANCE, *again)
            on[new], triangle[new], feature[new] = again
        outside = np.flatnonzero(triangle < 0)
        if len(outside):
            on[outside], triangle[outside], feature[outside] = self._closest_reference(p[outside])
        return on, triangle, feature

    def _closest_reference(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`closest` by the k-d trees, for any point (those outside the grid or in a cell left to the trees)."""
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
        inside = (self.usable[index] & (v > FEATURE_TOLERANCE) & (w > FEATURE_TOLERANCE)
                  & (v + w < 1.0 - FEATURE_TOLERANCE))
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


@compiled_kernel
def _grid_candidates(centres: np.ndarray, reach: np.ndarray, lower: np.ndarray, upper: np.ndarray, most: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, the triangles whose box lies within `reach` of its centre, ascending (none for a cell of more than
    `most`): the offsets (cells + 1,) and the triangles' indices."""
    cells, faces = len(centres), len(lower)
    counts = np.zeros(cells, np.int64)
    for twice in range(2):
        starts = np.zeros(cells + 1, np.int64)
        starts[1:] = np.cumsum(counts)
        found = np.empty(starts[-1], np.int32)
        for c in range(cells):
            if twice and counts[c] == 0:
                continue
            limit, count = reach[c] * reach[c], 0
            for t in range(faces):
                gap = 0.0
                for k in range(3):
                    x = centres[c, k]
                    if x < lower[t, k]:
                        gap += (lower[t, k] - x) ** 2
                    elif x > upper[t, k]:
                        gap += (x - upper[t, k]) ** 2
                if gap <= limit:
                    if twice:
                        found[starts[c] + count] = t
                    count += 1
            if not twice:
                counts[c] = count if count <= most else 0
    return starts, found


@compiled_kernel
def _grid_closest(points: np.ndarray, origin: np.ndarray, cell: float, shape: np.ndarray, starts: np.ndarray,
                  counts: np.ndarray, candidates: np.ndarray, corners: np.ndarray, tolerance: float, on: np.ndarray,
                  triangle: np.ndarray, feature: np.ndarray) -> None:
    """`MeshQueries.closest` of each point in the grid, into `on`, `triangle`, `feature`; -1 in `triangle` for a point
    outside it or in a cell left to the k-d tree (no candidates), `UNFILLED` for one in a cell not filled yet. The
    rule is `_Triangles.closest`'s: the projection onto the plane where its barycentric weights are all above
    `tolerance`, else the nearest of the edges' closest points; of the candidates the nearest, ties to the lowest
    triangle."""
    for i in range(len(points)):
        index = 0
        inside = True
        for k in range(3):
            at = int(math.floor((points[i, k] - origin[k]) / cell))
            if at < 0 or at >= shape[k]:
                inside = False
            index = index * shape[k] + at
        triangle[i] = -1
        if not inside:
            continue
        if starts[index] < 0:
            triangle[i] = UNFILLED
            continue
        best = np.inf
        for m in range(starts[index], starts[index] + counts[index]):
            t = candidates[m]
            x, y, z, code = _on_triangle(points[i], corners[t], tolerance)
            d = (x - points[i, 0]) ** 2 + (y - points[i, 1]) ** 2 + (z - points[i, 2]) ** 2
            if d < best:
                best = d
                on[i, 0], on[i, 1], on[i, 2] = x, y, z
                triangle[i], feature[i] = t, code


@compiled_kernel
def _on_triangle(p: np.ndarray, corner: np.ndarray, tolerance: float) -> tuple[float, float, float, int]:
    """The closest point of one triangle (3, 3) to p (3,) and its feature code, by `_Triangles.closest`'s rule
    (scalar arithmetic: no arrays made)."""
    ax, ay, az = corner[0, 0], corner[0, 1], corner[0, 2]
    bx, by, bz = corner[1, 0] - ax, corner[1, 1] - ay, corner[1, 2] - az
    cx, cy, cz = corner[2, 0] - ax, corner[2, 1] - ay, corner[2, 2] - az
    px, py, pz = p[0] - ax, p[1] - ay, p[2] - az
    d00, d01, d11 = bx * bx + by * by + bz * bz, bx * cx + by * cy + bz * cz, cx * cx + cy * cy + cz * cz
    determinant = d00 * d11 - d01 * d01
    if determinant > 1e-30 * max(d00 * d11, 1e-300):
        e0, e1 = px * bx + py * by + pz * bz, px * cx + py * cy + pz * cz
        v = (d11 * e0 - d01 * e1) / determinant
        w = (d00 * e1 - d01 * e0) / determinant
        if v > tolerance and w > tolerance and v + w < 1.0 - tolerance:
            return ax + v * bx + w * cx, ay + v * by + w * cy, az + v * bz + w * cz, 0
    best, code = np.inf, 0
    x = y = z = 0.0
    for e in range(3):
        sx, sy, sz = corner[e, 0], corner[e, 1], corner[e, 2]
        f = (e + 1) % 3
        ex, ey, ez = corner[f, 0] - sx, corner[f, 1] - sy, corner[f, 2] - sz
        length = max(ex * ex + ey * ey + ez * ez, 1e-300)
        along = min(max(((p[0] - sx) * ex + (p[1] - sy) * ey + (p[2] - sz) * ez) / length, 0.0), 1.0)
        qx, qy, qz = sx + along * ex, sy + along * ey, sz + along * ez
        d = (qx - p[0]) ** 2 + (qy - p[1]) ** 2 + (qz - p[2]) ** 2
        if d < best:
            best, x, y, z = d, qx, qy, qz
            code = 1 + e if along <= 0.0 else (1 + f if along >= 1.0 else 4 + e)
    return x, y, z, code
