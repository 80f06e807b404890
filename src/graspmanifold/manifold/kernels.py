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


#: a UKR kernel weight exp(-e) with e beyond this is dropped (below 4e-18 of the nearest latent point's)
UKR_CUT = 40.0
#: a masked completion stops when a step lowers its error by less than this fraction
STEP_GAIN = 1e-4


@compiled_kernel
def ukr_point(model: tuple, z: np.ndarray, near: int, scratch: tuple) -> tuple[int, int]:
    """The UKR manifold at the latent point z (q,): f = sum_i K_i y_i / sum_i K_i, K_i = exp(-|z - x_i|^2 / 2)
    (`UKR_CUT` applied), into f (dim,), its Jacobian df/dz = sum_i K_i (y_i - f)(x_i - centre)^T / sum_i K_i into
    jacobian (dim, q) and the kernel-weighted latent centre into centre (q,).

    The model is (latent (n, q), postures (n, dim), keys (n,)): the training points sorted by their first latent
    coordinate, `keys`; training point `near` bounds the nearest one's squared distance b, so every point the kernel
    keeps (and the nearest) lies within sqrt(b + 2 UKR_CUT) of z along the first coordinate: only that window is read
    (the same points and weights as reading all). The scratch is (kernel (n,), kept (n,), f, jacobian, centre): the
    first `count` entries of kept name the training points kept, kernel their weights. Returns count and the nearest
    point's index."""
    latent, postures, keys = model
    kernel, kept, f, jacobian, centre = scratch
    n, q = latent.shape
    dim = postures.shape[1]
    bound = 0.0
    for a in range(q):
        t = latent[near, a] - z[a]
        bound += t * t
    reach = math.sqrt(bound + 2.0 * UKR_CUT)
    low = np.searchsorted(keys, z[0] - reach)
    high = np.searchsorted(keys, z[0] + reach, side="right")
    nearest, nearest_index = math.inf, near
    for i in range(low, high):
        s = 0.0
        for a in range(q):
            t = latent[i, a] - z[a]
            s += t * t
        kernel[i - low] = s
        if s < nearest:
            nearest, nearest_index = s, i
    count = 0
    total = 0.0
    for i in range(low, high):
        e = 0.5 * (kernel[i - low] - nearest)
        if e < UKR_CUT:
            kept[count] = i
            kernel[count] = math.exp(-e)  # count <= i - low: the distances still to read lie beyond
            total += kernel[count]
            count += 1
    f[:] = 0.0
    centre[:] = 0.0
    for c in range(count):
        w = kernel[c] / total
        kernel[c] = w
        i = kept[c]
        for k in range(dim):
            f[k] += w * postures[i, k]
        for a in range(q):
            centre[a] += w * latent[i, a]
    jacobian[:] = 0.0
    for c in range(count):
        w = kernel[c]
        i = kept[c]
        for k in range(dim):
            dk = w * (postures[i, k] - f[k])
            for a in range(q):
                jacobian[k, a] += dk * (latent[i, a] - centre[a])
    return count, nearest_index


@compiled_kernel
def _masked_error(f: np.ndarray, query: np.ndarray, weights: np.ndarray) -> float:
    """sum_k weights_k (f_k - query_k)^2 over the dimensions with weight > 0 (the others never read)."""
    error = 0.0
    for k in range(f.shape[0]):
        if weights[k] > 0.0:
            d = f[k] - query[k]
            error += weights[k] * d * d
    return error


@compiled_kernel
def _solve_damped(normal: np.ndarray, gradient: np.ndarray, damping: float, step: np.ndarray) -> bool:
    """step = -(normal + damping * trace(normal) / q * I)^-1 gradient by Cholesky (q <= 3); False where the
    normal matrix is zero (no direction to go)."""
    q = gradient.shape[0]
    scale = 0.0
    for a in range(q):
        scale += normal[a, a]
    if not scale > 0.0:
        return False
    m = normal.copy()
    for a in range(q):
        m[a, a] += damping * scale / q
    lower = np.zeros((q, q))
    for a in range(q):
        for b in range(a + 1):
            s = m[a, b]
            for c in range(b):
                s -= lower[a, c] * lower[b, c]
            if a == b:
                if not s > 0.0:
                    return False
                lower[a, a] = math.sqrt(s)
            else:
                lower[a, b] = s / lower[b, b]
    y = np.empty(q)
    for a in range(q):
        s = -gradient[a]
        for c in range(a):
            s -= lower[a, c] * y[c]
        y[a] = s / lower[a, a]
    for a in range(q - 1, -1, -1):
        s = y[a]
        for c in range(a + 1, q):
            s -= lower[c, a] * step[c]
        step[a] = s / lower[a, a]
    return True


@compiled_kernel
def ukr_complete_rows(model: tuple, queries: np.ndarray, weights: np.ndarray, starts: np.ndarray, iterations: int,
                      out: tuple, rows: tuple) -> None:
    """Masked completion on the UKR manifold for rows start <= r < stop: from the latent point of training point
    starts[r], Levenberg-Marquardt steps on sum_k p_k (f_k(z) - x_k)^2 (p = weights[r], or weights[0] for every row
    when it has one row), a step kept only where it lowers the error; stops after `iterations` steps, when a step
    gains less than `STEP_GAIN` of the error, or when the damping passes 1e8. Writes z (q,) and f(z) (dim,) into
    out = (out_latent (m, q), out_postures (m, dim)) for rows = (start, stop). The model is (latent, postures, keys),
    the training points sorted by their first latent coordinate (`ukr_point`); starts index them so."""
    latent, postures, _ = model
    out_latent, out_postures = out
    start, stop = rows
    n, q = latent.shape
    dim = postures.shape[1]
    kernel = np.empty(n)
    kept = np.empty(n, dtype=np.int64)
    f, f_new = np.empty(dim), np.empty(dim)
    jacobian, jacobian_new = np.empty((dim, q)), np.empty((dim, q))
    centre = np.empty(q)
    normal, gradient, step, z_new = np.empty((q, q)), np.empty(q), np.empty(q), np.empty(q)
    shared = weights.shape[0] == 1
    for r in range(start, stop):
        p = weights[0] if shared else weights[r]
        x = queries[r]
        z = latent[starts[r]].copy()
        _, near = ukr_point(model, z, starts[r], (kernel, kept, f, jacobian, centre))
        error = _masked_error(f, x, p)
        damping = 1e-3
        for _ in range(iterations):
            normal[:] = 0.0
            gradient[:] = 0.0
            for k in range(dim):
                if p[k] > 0.0:
                    residual = p[k] * (f[k] - x[k])
                    for a in range(q):
                        gradient[a] += jacobian[k, a] * residual
                        for b in range(q):
                            normal[a, b] += p[k] * jacobian[k, a] * jacobian[k, b]
            if not _solve_damped(normal, gradient, damping, step):
                break
            for a in range(q):
                z_new[a] = z[a] + step[a]
            _, near_new = ukr_point(model, z_new, near, (kernel, kept, f_new, jacobian_new, centre))
            error_new = _masked_error(f_new, x, p)
            if error_new < error:
                gain = error - error_new
                z[:] = z_new
                near = near_new
                f[:] = f_new
                jacobian[:] = jacobian_new
                error = error_new
                damping = max(damping * 0.3, 1e-9)
                if gain <= STEP_GAIN * (error + gain):
                    break
            else:
                damping *= 10.0
                if damping > 1e8:
                    break
        out_latent[r] = z
        out_postures[r] = f


@compiled_kernel
def ukr_loo(latent: np.ndarray, postures: np.ndarray, gradient: np.ndarray, with_gradient: bool) -> float:
    """The UKR leave-one-out error (1/n) sum_i |y_i - f_{-i}(x_i)|^2 and, `with_gradient`, its gradient (n, q) into
    `gradient`: each point's own kernel term left out, weights beyond `UKR_CUT` of the row's nearest dropped, so a
    row costs n q for its distances and (its kept pairs) x dim for the rest (`ukr.loo_error_reference` is the same
    in NumPy, over the full n x n matrices)."""
    n, q = latent.shape
    dim = postures.shape[1]
    squared = np.empty(n)
    weights = np.empty(n)
    kept = np.empty(n, dtype=np.int64)
    recon = np.empty(dim)
    residual = np.empty(dim)
    error = 0.0
    if with_gradient:
        gradient[:] = 0.0
    for i in range(n):
        nearest = math.inf
        for j in range(n):
            s = 0.0
            for a in range(q):
                t = latent[i, a] - latent[j, a]
                s += t * t
            squared[j] = s
            if j != i and s < nearest:
                nearest = s
        count = 0
        total = 0.0
        for j in range(n):
            e = 0.5 * (squared[j] - nearest)
            if j != i and e < UKR_CUT:
                kept[count] = j
                weights[count] = math.exp(-e)
                total += weights[count]
                count += 1
        recon[:] = 0.0
        for c in range(count):
            weights[c] /= total
            j = kept[c]
            for k in range(dim):
                recon[k] += weights[c] * postures[j, k]
        own = 0.0  # r_i . f_i
        for k in range(dim):
            residual[k] = recon[k] - postures[i, k]
            error += residual[k] * residual[k]
            own += residual[k] * recon[k]
        if not with_gradient:
            continue
        for c in range(count):  # M_ij = b_ij (2/n) (r_i . y_j - r_i . f_i); d/dx_i and d/dx_j of K_ij
            j = kept[c]
            dot = 0.0
            for k in range(dim):
                dot += residual[k] * postures[j, k]
            m = weights[c] * (2.0 / n) * (dot - own)
            for a in range(q):
                t = m * (latent[i, a] - latent[j, a])
                gradient[i, a] -= t
                gradient[j, a] += t
    return error / n
