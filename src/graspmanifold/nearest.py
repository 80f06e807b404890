"""Exact masked nearest-neighbour search: the best match of the paper's Eq. 2 and Eq. 4.

    dist_p(w, x) = sum_k p_k (w_k - x_k)^2,   p_k >= 0, not all zero

Both experience bases (the SOM's reference vectors and the raw posture database) answer their
best-match queries with `MaskedNearest`. The distance is expanded as p.(w*w) - 2 (p*x).w + const,
so one matrix product serves a whole batch of queries with different masks; candidates whose
expanded distance lies within rounding error of the minimum are then re-ranked with the direct
formula, so the answer is exactly the brute-force argmin (lowest index on ties).
"""

from __future__ import annotations

import math

import numpy as np

_CHUNK = 4096  # queries per matrix product: bounds memory at CHUNK x n distances
_RELATIVE_TOLERANCE = 1e-10  # far above the ~1e-14 relative rounding error of the expansion


def check_queries(x: object, mask: object, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate queries and masks; return float arrays (m, dim) with unspecified entries zeroed.

    `x` is (dim,) or (m, dim); it may hold NaN where the mask is 0 (the PCP's unspecified joints).
    `mask` is None (all ones), boolean, or non-negative weights p_k, shaped (dim,) or (m, dim).
    """
    queries = np.array(x, dtype=float, ndmin=1)
    single = queries.ndim == 1
    queries = np.atleast_2d(queries)
    if queries.ndim != 2 or queries.shape[1] != dim:
        raise ValueError(f"x must have shape ({dim},) or (m, {dim}), got {np.shape(x)}")
    if mask is None:
        weights = np.ones_like(queries)
    else:
        weights = np.array(mask, dtype=float, ndmin=1)
        if weights.shape not in ((dim,), queries.shape) and not (single and weights.shape == (1, dim)):
            raise ValueError(f"mask must have shape ({dim},) or {queries.shape}, got {np.shape(mask)}")
        weights = np.broadcast_to(weights, queries.shape)
        if not np.all(np.isfinite(weights)):
            raise ValueError("mask has non-finite weights")
        if np.any(weights < 0):
            raise ValueError("mask has negative weights; expected booleans or weights p_k >= 0")
        empty = ~np.any(weights > 0, axis=1)
        if empty.any():
            raise ValueError(f"mask selects no dimension (all zero) for query rows {np.flatnonzero(empty)[:10].tolist()}")
    used = weights > 0
    bad = used & ~np.isfinite(queries)
    if bad.any():
        rows, cols = np.nonzero(bad)
        raise ValueError(f"x has non-finite values where the mask is non-zero (row {rows[0]}, column {cols[0]})")
    queries = np.where(used, queries, 0.0)
    return queries, np.ascontiguousarray(weights)


def check_query(x: object, mask: object, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """`check_queries` for one query: returns float (dim,) arrays; a lean path for control loops."""
    query = np.asarray(x, dtype=float)
    if query.shape != (dim,):
        raise ValueError(f"x must have shape ({dim},), got {np.shape(x)}")
    if mask is None:
        weights = np.ones(dim)
    else:
        weights = np.asarray(mask, dtype=float)
        if weights.shape != (dim,):
            raise ValueError(f"mask must have shape ({dim},), got {np.shape(mask)}")
        total = float(weights.sum())
        if not math.isfinite(total):
            raise ValueError("mask has non-finite weights")
        if weights.min() < 0:
            raise ValueError("mask has negative weights; expected booleans or weights p_k >= 0")
        if total == 0.0:
            raise ValueError("mask selects no dimension (all zero)")
    query = np.where(weights > 0, query, 0.0)
    if not np.isfinite(query).all():
        raise ValueError(f"x has non-finite values where the mask is non-zero (column {int(np.argmin(np.isfinite(query)))})")
    return query, weights


class MaskedNearest:
    """Exact nearest point of a fixed set under the masked squared distance."""

    def __init__(self, points: np.ndarray):
        self.points = np.ascontiguousarray(points, dtype=float)
        if self.points.ndim != 2 or len(self.points) == 0:
            raise ValueError(f"points must be a non-empty (n, dim) array, got shape {self.points.shape}")
        squares = self.points * self.points
        self._expanded = np.ascontiguousarray(np.hstack([squares, self.points]).T)  # (2 dim, n)
        self._scale_sq = squares.max(axis=0)

    @property
    def dim(self) -> int:
        return self.points.shape[1]

    def distances(self, x: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """Direct masked squared distances (n,) from one query to every point."""
        query, weights = check_query(x, mask, self.dim)
        return np.sum(weights * (self.points - query) ** 2, axis=1)

    def query(self, queries: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Indices (m,) of the nearest points for validated queries and weights (see check_queries)."""
        result = np.empty(len(queries), dtype=np.intp)
        for start in range(0, len(queries), _CHUNK):
            block = slice(start, start + _CHUNK)
            result[block] = self._query_block(queries[block], weights[block])
        return result

    def query_one(self, query: np.ndarray, weights: np.ndarray) -> int:
        """Index of the nearest point for one validated query (see check_query)."""
        expanded = np.concatenate((weights, -2.0 * weights * query)) @ self._expanded
        best = int(expanded.argmin())
        # |p.w^2 - 2 (p x).w| <= sum p (w_max^2 + x^2) * 2 bounds the magnitude of the rounded terms
        tolerance = 2.0 * _RELATIVE_TOLERANCE * float((self._scale_sq + query * query) @ weights)
        threshold = expanded[best] + tolerance
        if np.count_nonzero(expanded <= threshold) > 1:  # rare: settle with the direct formula
            candidates = np.flatnonzero(expanded <= threshold)
            exact = np.sum(weights * (self.points[candidates] - query) ** 2, axis=1)
            best = int(candidates[np.argmin(exact)])
        return best

    def _query_block(self, queries: np.ndarray, weights: np.ndarray) -> np.ndarray:
        stacked = np.hstack([weights, -2.0 * weights * queries])
        expanded = stacked @ self._expanded  # (m, n): distance minus the query's own constant
        best = expanded.argmin(axis=1)
        rows = np.arange(len(queries))
        tolerance = 2.0 * _RELATIVE_TOLERANCE * np.einsum("ij,ij->i", self._scale_sq + queries * queries, weights)
        near_tie = np.count_nonzero(expanded <= (expanded[rows, best] + tolerance)[:, None], axis=1) > 1
        for row in np.flatnonzero(near_tie):  # rare: settle with the direct formula
            candidates = np.flatnonzero(expanded[row] <= expanded[row, best[row]] + tolerance[row])
            exact = np.sum(weights[row] * (self.points[candidates] - queries[row]) ** 2, axis=1)
            best[row] = candidates[np.argmin(exact)]
        return best
