"""Exact masked nearest-neighbour search: the best match of the paper's Eq. 2 and Eq. 4.

    dist_p(w, x) = sum_k p_k (w_k - x_k)^2,   p_k >= 0, not all zero

Both experience bases (the SOM's reference vectors and the raw posture database) answer their
best-match queries with `MaskedNearest`. By default a compiled kernel (`kernels.masked_argmin`)
sums the distance directly over the masked dimensions only and validates as it goes, so a single
query costs a few microseconds; batches are split across threads.

The NumPy reference (`MaskedNearest.query_reference`) expands the distance as
p.(w*w) - 2 (p*x).w + const, so one matrix product serves a whole batch of queries with different
masks; candidates whose expanded distance lies within rounding error of the minimum are then
re-ranked with the direct formula. Both give the brute-force best match: the lowest index of a tie, distances
within `kernels.TIE` (relative) of the smallest (`argmin_tied`), so that no last bit of a distance decides it.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import ArrayLike

from ..base.errors import InvalidInput
from ..base.moved import moved_attribute
from ..base.workers import usable_cores
from ..base.compiled import compiled
from .kernels import TIE, masked_argmin, masked_argmin_rows

_CHUNK = 4096  # queries per matrix product: bounds memory at CHUNK x n distances
_PER_THREAD = 2048  # a batch gets one thread per this many queries, up to the usable cores
_RELATIVE_TOLERANCE = 1e-10  # far above the ~1e-14 relative rounding error of the expansion


def nearest_rows(references: np.ndarray, data: np.ndarray) -> np.ndarray:
    """For each reference row, the row of `data` nearest to it (Euclidean; a tie to the lowest index, `argmin_tied`):
    what a SOM node inherits from the training postures it stands for (a grasp type, where the object sat).

    Args:
        references: (k, dim) rows.
        data: (m, dim) rows, m >= 1.

    Returns:
        (k,) indices into `data`.
    """
    data = np.asarray(data, dtype=float)
    return np.array([argmin_tied(((data - row) ** 2).sum(axis=1)) for row in np.asarray(references, dtype=float)],
                    dtype=int)


def argmin_tied(values: np.ndarray, axis: int | None = None) -> int | np.ndarray:
    """The index of the smallest value, the lowest index among those within `kernels.TIE` (relative) of it: the
    best match's rule of a tie, for any array of distances.

    Args:
        values: distances (any shape).
        axis: the axis to search (None: the flattened array).

    Returns:
        The index (an int for axis None, else an array of them).
    """
    values = np.asarray(values, dtype=float)
    if axis is None:
        values, axis = values.ravel(), 0
    low = values.min(axis=axis, keepdims=True)
    index = np.argmax(values <= low + TIE * np.abs(low), axis=axis)
    return int(index) if np.ndim(index) == 0 else index


def check_queries(x: ArrayLike, mask: ArrayLike | None, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate queries and masks; return float arrays (m, dim) with unspecified entries zeroed.

    `x` is (dim,) or (m, dim); it may hold NaN where the mask is 0 (the PCP's unspecified joints).
    `mask` is None (all ones), boolean, or non-negative weights p_k, shaped (dim,) or (m, dim).
    """
    queries = np.array(x, dtype=float, ndmin=1)
    single = queries.ndim == 1
    queries = np.atleast_2d(queries)
    if queries.ndim != 2 or queries.shape[1] != dim:
        raise InvalidInput(f"x must have shape ({dim},) or (m, {dim}), got {np.shape(x)}")
    if mask is None:
        weights = np.ones_like(queries)
    else:
        weights = np.array(mask, dtype=float, ndmin=1)
        if weights.shape not in ((dim,), queries.shape) and not (single and weights.shape == (1, dim)):
            raise InvalidInput(f"mask must have shape ({dim},) or {queries.shape}, got {np.shape(mask)}")
        weights = np.broadcast_to(weights, queries.shape)
        if not np.all(np.isfinite(weights)):
            raise InvalidInput("mask has non-finite weights")
        if np.any(weights < 0):
            raise InvalidInput("mask has negative weights; expected booleans or weights p_k >= 0")
        empty = ~np.any(weights > 0, axis=1)
        if empty.any():
            raise InvalidInput(f"mask selects no dimension (all zero) for query rows {np.flatnonzero(empty)[:10].tolist()}")
    used = weights > 0
    bad = used & ~np.isfinite(queries)
    if bad.any():
        rows, cols = np.nonzero(bad)
        raise InvalidInput(f"x has non-finite values where the mask is non-zero (row {rows[0]}, column {cols[0]})")
    queries = np.where(used, queries, 0.0)
    return queries, np.ascontiguousarray(weights)


def check_query(x: ArrayLike, mask: ArrayLike | None, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """`check_queries` for one query (dim,): returns float (dim,) arrays."""
    if np.ndim(x) != 1:
        raise InvalidInput(f"x must have shape ({dim},), got {np.shape(x)}")
    queries, weights = check_queries(x, mask, dim)
    return queries[0], weights[0]


class MaskedNearest:
    """Exact nearest point of a fixed set under the masked squared distance."""

    def __init__(self, points: np.ndarray):
        self.points = np.ascontiguousarray(points, dtype=float)
        if self.points.ndim != 2 or len(self.points) == 0:
            raise InvalidInput(f"points must be a non-empty (n, dim) array, got shape {self.points.shape}")
        self._points_t = np.ascontiguousarray(self.points.T)  # (dim, n): the kernels run along points
        self._ones = np.ones(self.dim)
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

    def nearest(self, x: np.ndarray, mask: np.ndarray | None = None) -> int:
        """Index of the point nearest to one query x (dim,) under `mask` (see check_query)."""
        if not compiled():
            query, weights = check_query(x, mask, self.dim)
            return int(self.query_reference(query[None], weights[None])[0])
        query = np.asarray(x, dtype=float)
        weights = self._weights(mask)
        index = -1
        if query.shape == weights.shape == (self.dim,):
            index = masked_argmin(self._points_t, query, weights)
        if index < 0:  # the reference's validation names what is wrong
            check_query(x, mask, self.dim)
            raise InvalidInput(f"x or mask rejected by the best-match kernel (code {index})")
        return index

    def nearest_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """Indices (m,) of the nearest points of queries X (m, dim) under one mask (dim,) or one per
        row (m, dim) (see check_queries)."""
        if not compiled():
            return self.query_reference(*check_queries(X, masks, self.dim))
        queries = np.ascontiguousarray(X, dtype=float)
        queries = queries[None] if queries.ndim == 1 else queries
        weights = self._weights(masks)
        result = np.full(len(queries), -1, dtype=np.intp)
        if queries.ndim == 2 and queries.shape[1] == self.dim and weights.shape in ((self.dim,), queries.shape):
            weights = np.ascontiguousarray(weights.reshape(-1, self.dim))
            parts = max(1, min(usable_cores(), len(queries) // _PER_THREAD))
            bounds = np.linspace(0, len(queries), parts + 1).astype(int)
            work = [(self._points_t, queries, weights, result, int(start), int(stop))
                    for start, stop in zip(bounds[:-1], bounds[1:])]
            if parts == 1:
                masked_argmin_rows(*work[0])
            else:  # the kernel releases the GIL
                with ThreadPoolExecutor(parts) as pool:
                    list(pool.map(lambda args: masked_argmin_rows(*args), work))
        if np.any(result < 0):  # the reference's validation names what is wrong
            check_queries(X, masks, self.dim)
            raise InvalidInput(f"X or masks rejected by the best-match kernel (codes {np.unique(result[result < 0])})")
        return result

    def _weights(self, mask: np.ndarray | None) -> np.ndarray:
        """A mask as the kernels take it: boolean as it is, anything else as float; None as all ones."""
        if mask is None:
            return self._ones
        weights = np.asarray(mask)
        return weights if weights.dtype == np.bool_ else np.asarray(weights, dtype=float)

    def query_reference(self, queries: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """`nearest_batch` in NumPy for validated queries and weights (see check_queries): the
        expanded distance by matrix products, near ties re-ranked with the direct formula."""
        result = np.empty(len(queries), dtype=np.intp)
        for start in range(0, len(queries), _CHUNK):
            block = slice(start, start + _CHUNK)
            result[block] = self._query_block(queries[block], weights[block])
        return result

    def _query_block(self, queries: np.ndarray, weights: np.ndarray) -> np.ndarray:
        stacked = np.hstack([weights, -2.0 * weights * queries])
        expanded = stacked @ self._expanded  # (m, n): distance minus the query's own constant
        best = expanded.argmin(axis=1)
        rows = np.arange(len(queries))
        # |p.w^2 - 2 (p x).w| <= sum p (w_max^2 + x^2) * 2 bounds the magnitude of the rounded terms and of the
        # distances, so that this window holds every candidate of a tie (within TIE of the smallest distance)
        tolerance = 2.0 * (_RELATIVE_TOLERANCE + 2.0 * TIE) * np.einsum("ij,ij->i", self._scale_sq + queries * queries,
                                                                       weights)
        near_tie = np.count_nonzero(expanded <= (expanded[rows, best] + tolerance)[:, None], axis=1) > 1
        for row in np.flatnonzero(near_tie):  # rare: settle with the direct formula
            candidates = np.flatnonzero(expanded[row] <= expanded[row, best[row]] + tolerance[row])
            exact = np.sum(weights[row] * (self.points[candidates] - queries[row]) ** 2, axis=1)
            best[row] = candidates[argmin_tied(exact)]
        return best


class ReferenceMatcher:
    """The `experience.Experience` protocol's queries (documented there) answered by a `MaskedNearest` of the
    `references` a subclass provides with `masked_search()`: what the SOM and the posture database share."""

    @property
    def references(self) -> np.ndarray:
        """The reference postures (k, dim) that `best_match` indexes (a subclass provides them).

        Returns:
            The postures, rad.
        """
        raise NotImplementedError

    def masked_search(self) -> MaskedNearest:
        """The masked nearest search over `references` that `best_match` runs (a subclass provides it).

        Returns:
            The `MaskedNearest` over the references.
        """
        raise NotImplementedError

    def best_match(self, x: np.ndarray, mask: np.ndarray | None = None) -> int:
        """The row of `references` nearest to the query x (dim,) under the masked distance of Eq. 2 / Eq. 4."""
        return self.masked_search().nearest(x, mask)

    def best_match_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`best_match` of every query (m, dim), with one mask (dim,) or one per query (m, dim)."""
        return self.masked_search().nearest_batch(X, masks)

    def complete(self, x: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """The best-matching reference in full (dim,), rad: x completed from what the mask specifies."""
        return self.references[self.best_match(x, mask)].copy()

    def complete_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`complete` of every query: (m, dim), rad."""
        return self.references[self.best_match_batch(X, masks)]


class ManifoldMatcher(ReferenceMatcher):
    """What a fitted manifold that completes postures on itself shares of the `experience.Experience` protocol
    (`ukr.UKR`, `linear.LinearManifold`): its `references` are postures on the manifold (kept by
    `keep_references`), `best_match` the nearest of them (`ReferenceMatcher`), and `complete` one query of the
    subclass's `complete_batch`, which completes on the manifold instead of returning a reference."""

    _search: MaskedNearest | None = None

    @property
    def dim(self) -> int:
        """The postures' dimension (a subclass provides it)."""
        raise NotImplementedError

    def _require(self) -> object:
        raise NotImplementedError

    def keep_references(self, references: np.ndarray) -> None:
        """Keep the manifold's postures that `best_match` indexes, read-only (a fitting or loading subclass calls it).

        Args:
            references: (k, dim) postures on the manifold, rad.
        """
        self._search = MaskedNearest(references)
        self._search.points.flags.writeable = False

    @property
    def references(self) -> np.ndarray:
        """The manifold's postures at its training data (k, dim), rad, read-only: `best_match` gives a row of them."""
        return self.masked_search().points

    def masked_search(self) -> MaskedNearest:
        """The masked nearest search over the kept references (`ReferenceMatcher.masked_search`).

        Returns:
            The `MaskedNearest` over `references`.
        """
        self._require()
        if self._search is None:
            raise NotImplementedError("a ManifoldMatcher keeps its references (keep_references) when it is fitted")
        return self._search

    def complete(self, x: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """The manifold's posture that best fits the query's specified joints (masked completion).

        Args:
            x: the query (dim,), rad; it may hold NaN where the mask is 0.
            mask: None (every joint), boolean, or weights p_k >= 0, not all zero (the PCP mask, Eq. 2).

        Returns:
            The posture (dim,), rad.
        """
        query, weights = check_query(x, mask, self.dim)
        return self.complete_batch(query[None], weights[None])[0]


def __getattr__(name: str) -> object:
    """`Recall` and `ManifoldRecall` are `ReferenceMatcher` and `ManifoldMatcher` since 0.2, with a warning."""
    return moved_attribute(__name__, name)
