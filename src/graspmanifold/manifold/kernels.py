"""Compiled hot paths (numba): the masked best match and the online SOM epoch.

They run in every control cycle of every grasp trial and in every step of SOM training, where
NumPy pays its call overhead on vectors of a few hundred entries. Each kernel has a NumPy
reference next to its caller (`nearest.MaskedNearest.query_reference`, `som.online_epoch_reference`)
and the tests compare the two; `base.compiled` switches between them.

The kernels compute the masked distance directly over the masked dimensions only,
sum_k p_k (w_k - x_k)^2 in increasing k, vectorised across points (points are stored transposed,
(dim, n)), and take the lowest index of a tie (distances within `TIE` of the smallest). They release the GIL, so
batches are split across threads (not numba's own parallel layer, which is not safe in forked worker processes).
"""

from __future__ import annotations

import math

import numpy as np

from ..base.compiled import compiled_kernel

#: error codes of `masked_argmin` (non-negative values are indices)
BAD_WEIGHT, EMPTY_MASK, BAD_QUERY = -1, -2, -3


@compiled_kernel
def _checked_dimensions(query: np.ndarray, weights: np.ndarray) -> int:
    """Number of dimensions with weight > 0, or an error code: a negative or non-finite weight,
    no weight > 0, a non-finite query value where the weight is > 0."""
    used = 0
    for k in range(query.shape[0]):
        p = np.float64(weights[k])
        if not (0.0 <= p < math.inf):
            return BAD_WEIGHT
        if p > 0.0:
            if not math.isfinite(query[k]):
                return BAD_QUERY
            used += 1
    return used if used > 0 else EMPTY_MASK


@compiled_kernel
def _masked_distances(points_t: np.ndarray, query: np.ndarray, weights: np.ndarray, out: np.ndarray) -> None:
    """out[j] = sum over k with weights[k] > 0 of weights[k] (points_t[k, j] - query[k])^2."""
    out[:] = 0.0
    n = points_t.shape[1]
    for k in range(points_t.shape[0]):
        p = np.float64(weights[k])
        if p > 0.0:
            xk = query[k]
            row = points_t[k]
            for j in range(n):
                d = row[j] - xk
                out[j] += p * (d * d)


#: values within this fraction of the smallest tie with it, and the lowest index of a tie wins: a rule that the last
#: bits of the distances (which move with the processor, the BLAS and the compiler's vector width) do not decide
TIE = 1e-9


@compiled_kernel
def _argmin(values: np.ndarray) -> int:
    """Index of the smallest value: the lowest index among the values within `TIE` (relative) of it."""
    low = values[0]
    for j in range(1, values.shape[0]):
        if values[j] < low:
            low = values[j]
    bound = low + TIE * abs(low)
    for j in range(values.shape[0]):
        if values[j] <= bound:
            return j
    return 0


@compiled_kernel
def masked_argmin(points_t: np.ndarray, query: np.ndarray, weights: np.ndarray) -> int:
    """Index of the point (a column of points_t, (dim, n)) nearest to `query` under the masked
    distance with `weights` (dim,), bool or float; validates as it goes and returns an error code
    (BAD_WEIGHT, EMPTY_MASK, BAD_QUERY) instead of raising."""
    status = _checked_dimensions(query, weights)
    if status < 0:
        return status
    distances = np.empty(points_t.shape[1])
    _masked_distances(points_t, query, weights, distances)
    return _argmin(distances)


@compiled_kernel
def masked_argmin_rows(points_t: np.ndarray, queries: np.ndarray, weights: np.ndarray, out: np.ndarray,
                       start: int, stop: int) -> None:
    """out[i] = masked_argmin of queries[i] with weights[i] (or weights[0] for every row when it has
    one row) for start <= i < stop."""
    distances = np.empty(points_t.shape[1])
    shared = weights.shape[0] == 1
    for i in range(start, stop):
        row_weights = weights[0] if shared else weights[i]
        status = _checked_dimensions(queries[i], row_weights)
        if status < 0:
            out[i] = status
            continue
        _masked_distances(points_t, queries[i], row_weights, distances)
        out[i] = _argmin(distances)


@compiled_kernel
def online_epoch(weights_t: np.ndarray, data: np.ndarray, order: np.ndarray, rate: float, sigma: float,
                 rows: int, cols: int, negligible: float) -> None:
    """One online SOM epoch in place: for each sample data[i], i in `order`, find the winner b
    (plain Euclidean distance) and move every node a by h (x - w_a), h = rate exp(-|a - b|^2 /
    (2 sigma^2)), h dropped below `negligible` * rate. The update touches only the lattice window
    where the Gaussian can reach that bound. weights_t: (dim, rows * cols), node a = r * cols + c."""
    dim, n = weights_t.shape
    reach = int(min(sigma * math.sqrt(-2.0 * math.log(negligible)), rows + cols))  # beyond: exp(..) < negligible
    ones = np.ones(dim)
    distances = np.empty(n)
    gauss_r = np.empty(rows)
    gauss_c = np.empty(cols)
    step = np.empty(cols)
    for i in order:
        x = data[i]
        _masked_distances(weights_t, x, ones, distances)
        winner = _argmin(distances)
        win_r = winner // cols
        win_c = winner - win_r * cols
        r0, r1 = max(0, win_r - reach), min(rows, win_r + reach + 1)
        c0, c1 = max(0, win_c - reach), min(cols, win_c + reach + 1)
        width = c1 - c0
        for r in range(r0, r1):
            t = (r - win_r) / sigma
            gauss_r[r] = math.exp(-0.5 * t * t)
        for c in range(c0, c1):
            t = (c - win_c) / sigma
            gauss_c[c] = math.exp(-0.5 * t * t)
        for r in range(r0, r1):
            for c in range(width):  # zero-based loops over contiguous slices: they vectorise
                h = rate * (gauss_r[r] * gauss_c[c0 + c])
                step[c] = h if h >= negligible * rate else 0.0
            start = r * cols + c0
            for k in range(dim):
                xk = x[k]
                segment = weights_t[k, start:start + width]
                for c in range(width):
                    segment[c] += step[c] * (xk - segment[c])
