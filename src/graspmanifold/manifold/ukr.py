"""Unsupervised Kernel Regression: a continuous grasp manifold (the paper's future work, Section 6).

    ukr = UKR(latent_dim=2).fit(postures)                       # spectral starts, then the leave-one-out fit
    posture = ukr.complete(pcp, mask)                           # masked completion (the PCP of Eq. 1-4)
    grid = ukr.manifold(latent_points)                          # postures anywhere on the manifold

The manifold maps a latent point z (q = 1, 2 or 3 dimensions) to a posture by the Nadaraya-Watson estimator over
the training postures y_i and their latent points x_i (Meinicke, Klanke, Memisevic and Ritter, 2005):

    f(z) = sum_i K(z - x_i) y_i / sum_j K(z - x_j),   K(u) = exp(-|u|^2 / 2)

The kernel's bandwidth is fixed at 1; the latent points' scale is what the fit chooses. Training minimises the
leave-one-out reconstruction error (1/n) sum_i |y_i - f_{-i}(x_i)|^2, where f_{-i} leaves posture i's own kernel
term out (without that, every point would reconstruct itself): the starts are the spectral embeddings of
`embeddings` (PCA and Isomap), each tried at `scales` sizes spread geometrically (each axis first brought to unit
variance), the start with the lowest leave-one-out error refined by L-BFGS on all latent points with the error's
exact gradient (compiled, `kernels.ukr_loo`: n^2 q for the latent distances, the rest only over the pairs the
kernel keeps; the NumPy reference `loo_error_reference` works on the full n x n matrices).

Masked completion: the latent point minimising sum_k p_k (f_k(z) - x_k)^2 over the specified joints (p_k > 0) only,
from the latent point of the training posture whose manifold posture best matches the query (the masked best
match of Eq. 2 over `references`), by Levenberg-Marquardt steps (`kernels.ukr_complete_rows`; the NumPy reference
`complete_reference` beside it); the posture read off there. A step is kept only where it lowers the error, so a
completion fits the specified joints at least as well as its best match does; it stops after `completion_steps`
steps or when a step gains less than `kernels.STEP_GAIN` of the error. Kernel weights below 4e-18 of the nearest
latent point's are dropped (`kernels.UKR_CUT`), so the compiled kernel reads only the training points within reach
along the first latent coordinate (kept sorted by it). About 0.1-0.3 ms a completion, a batch of 10,000 in
0.2-0.8 s on one core for 625-4,000 training postures (BENCHMARKS.md).

A UKR is an `experience.Experience`: `references` are the manifold's postures at the training latent points,
`best_match` the nearest of them under the masked distance, `complete` the completed posture, so every controller
and study takes it as it takes a SOM.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Literal, overload

import numpy as np
from scipy.optimize import minimize

from ..base.compiled import compiled
from ..base.errors import InvalidInput, NotFittedError
from ..base.io import NpzRecord, fingerprint
from ..base.progress import progress_bar
from ..base.validation import check_choice, check_data, check_int
from ..base.workers import usable_cores
from .embeddings import isomap, pca_embedding, squared_distances
from .experience import check_file_postures
from .kernels import STEP_GAIN, UKR_CUT, ukr_complete_rows, ukr_loo
from .nearest import ManifoldMatcher, check_queries

#: the embeddings a fit may start from (`embeddings.pca_embedding`, `embeddings.isomap`)
STARTS: tuple[str, ...] = ("pca", "isomap")
#: the most postures a UKR is fitted on: Isomap's start holds n x n geodesics (8,000 postures took 2.7 GB and 45 s;
#: 15,000 need about 9.5 GB, 30,000 about 38 GB); fit on a subset, or resume with fewer
MAX_POSTURES = 15_000
#: the farthest a latent point of a file may lie (the kernel's bandwidth is 1: a fit's points lie within tens)
MAX_LATENT = 1e6
_BLOCK = 2048  # latent points per kernel matrix block of `manifold`: bounds its memory
_PER_THREAD = 256  # a completion batch gets one thread per this many queries, up to the usable cores


def _check_size(n: int) -> None:
    """Refuse a fit of more than `MAX_POSTURES` postures before any work (a fit of 30,000 was killed for memory)."""
    if n > MAX_POSTURES:
        raise InvalidInput(f"a UKR is fitted on at most {MAX_POSTURES} postures (its fit holds n x n matrices: "
                           f"{n} postures would need about {42 * n * n / 1e9:.0f} GB); fit it on a subset")


def _kernel_rows(squared: np.ndarray) -> np.ndarray:
    """Row-normalised Gaussian kernel weights from squared latent distances (m, n), each row's nearest 1, weights
    below exp(-UKR_CUT) of it 0."""
    exponent = 0.5 * (squared - squared.min(axis=1, keepdims=True))
    weights = np.where(exponent < UKR_CUT, np.exp(-np.minimum(exponent, UKR_CUT)), 0.0)
    return weights / weights.sum(axis=1, keepdims=True)


@overload
def loo_error(latent: np.ndarray, postures: np.ndarray, gradient: Literal[False] = False) -> float: ...


@overload
def loo_error(latent: np.ndarray, postures: np.ndarray, gradient: Literal[True]) -> tuple[float, np.ndarray]: ...


@overload
def loo_error(latent: np.ndarray, postures: np.ndarray, gradient: bool) -> float | tuple[float, np.ndarray]: ...


def loo_error(latent: np.ndarray, postures: np.ndarray, gradient: bool = False
              ) -> float | tuple[float, np.ndarray]:
    """The leave-one-out reconstruction error of latent points, and its gradient (compiled: `kernels.ukr_loo`).

    Args:
        latent: (n, q) latent points.
        postures: (n, dim) the postures they stand for, rad.
        gradient: also return d error / d latent.

    Returns:
        (1/n) sum_i |y_i - f_{-i}(x_i)|^2, rad^2; with `gradient`, also (n, q).
    """
    if not compiled():
        return loo_error_reference(latent, postures, gradient)
    out = np.zeros(np.shape(latent))
    error = ukr_loo(np.ascontiguousarray(latent, dtype=float), np.ascontiguousarray(postures, dtype=float), out,
                    gradient)
    return (error, out) if gradient else error


@overload
def loo_error_reference(latent: np.ndarray, postures: np.ndarray, gradient: Literal[False] = False) -> float: ...


@overload
def loo_error_reference(latent: np.ndarray, postures: np.ndarray, gradient: Literal[True]
                        ) -> tuple[float, np.ndarray]: ...


@overload
def loo_error_reference(latent: np.ndarray, postures: np.ndarray, gradient: bool
                        ) -> float | tuple[float, np.ndarray]: ...


def loo_error_reference(latent: np.ndarray, postures: np.ndarray, gradient: bool = False
                        ) -> float | tuple[float, np.ndarray]:
    """`loo_error` in NumPy over the full n x n kernel matrix (memory ~5 n^2 doubles).

    Args:
        latent: (n, q) latent points.
        postures: (n, dim) the postures they stand for, rad.
        gradient: also return d error / d latent.

    Returns:
        As `loo_error`.
    """
    n = len(latent)
    squared = squared_distances(latent, latent)
    np.fill_diagonal(squared, np.inf)  # the point's own term left out
    weights = _kernel_rows(squared)
    recon = weights @ postures
    residual = recon - postures
    error = float((residual * residual).sum() / n)
    if not gradient:
        return error
    # d error / d b_ij = (2/n) r_i.y_j; through the normalisation and the kernel (see the module doc):
    # d error / d x_i = -sum_j S_ij (x_i - x_j), S = M + M^T, M_ij = b_ij (g_ij - sum_k b_ik g_ik)
    coupling = (2.0 / n) * (residual @ postures.T)
    coupling -= (2.0 / n) * (residual * recon).sum(axis=1)[:, None]
    coupling *= weights
    coupling += coupling.T
    return error, -(coupling.sum(axis=1)[:, None] * latent - coupling @ latent)


def complete_reference(latent: np.ndarray, postures: np.ndarray, queries: np.ndarray, weights: np.ndarray,
                       starts: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """`kernels.ukr_complete_rows` in NumPy (the tests compare them): the same Levenberg-Marquardt steps.

    Args:
        latent: (n, q) the training latent points.
        postures: (n, dim) the training postures, rad.
        queries: (m, dim) checked queries (`nearest.check_queries`), rad.
        weights: (m, dim) their masks.
        starts: (m,) the training point each starts from.
        iterations: the most steps.

    Returns:
        The latent points (m, q) and the postures there (m, dim), rad.
    """
    q = latent.shape[1]

    def point(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        kernel = _kernel_rows(((latent - z) ** 2).sum(axis=1)[None])[0]
        f = kernel @ postures
        centre = kernel @ latent
        return f, ((postures - f) * kernel[:, None]).T @ (latent - centre)

    out_latent, out_postures = np.empty((len(queries), q)), np.empty_like(queries)
    for r, (x, p, first) in enumerate(zip(queries, weights, starts)):
        used = p > 0
        z = latent[first].copy()
        f, jacobian = point(z)
        error = float((p[used] * (f[used] - x[used]) ** 2).sum())
        damping = 1e-3
        for _ in range(iterations):
            normal = (jacobian[used] * p[used, None]).T @ jacobian[used]
            gradient = jacobian[used].T @ (p[used] * (f[used] - x[used]))
            scale = np.trace(normal)
            if not scale > 0:
                break
            try:
                step = -np.linalg.solve(normal + damping * scale / q * np.eye(q), gradient)
            except np.linalg.LinAlgError:
                break
            f_new, jacobian_new = point(z + step)
            error_new = float((p[used] * (f_new[used] - x[used]) ** 2).sum())
            if error_new < error:
                gain = error - error_new
                z, f, jacobian, error = z + step, f_new, jacobian_new, error_new
                damping = max(damping * 0.3, 1e-9)
                if gain <= STEP_GAIN * (error + gain):
                    break
            else:
                damping *= 10.0
                if damping > 1e8:
                    break
        out_latent[r], out_postures[r] = z, f
    return out_latent, out_postures


class UKR(ManifoldMatcher, NpzRecord):
    """A continuous grasp manifold fitted by Unsupervised Kernel Regression (see the module doc).

    Attributes (fitted): `latent` (n, q) the training postures' latent points, `postures` (n, dim) the training
    postures (rad), `references` (n, dim) the manifold's postures at the latent points, `history` one entry per fit
    or resume (its start, scale and leave-one-out errors).
    """

    def __init__(self, latent_dim: int = 2, *, starts: tuple[str, ...] = STARTS, scales: int = 12,
                 iterations: int = 200, neighbours: int = 8, completion_steps: int = 10):
        """An unfitted manifold.

        Args:
            latent_dim: the latent space's dimensions, 1, 2 or 3.
            starts: the spectral embeddings to start from (`STARTS`).
            scales: the sizes each start is tried at (its leave-one-out error picks one).
            iterations: the most L-BFGS iterations of the fit.
            neighbours: Isomap's neighbours.
            completion_steps: the most Levenberg-Marquardt steps of a masked completion.
        """
        self.latent_dim = check_int(latent_dim, "latent_dim", high=3)
        if isinstance(starts, str) or not starts:
            raise InvalidInput(f"starts must be a non-empty tuple of names from {STARTS}, got {starts!r}")
        self.starts = tuple(str(check_choice(s, STARTS, "starts")) for s in starts)
        self.scales = check_int(scales, "scales", high=1000)
        self.iterations = check_int(iterations, "iterations", low=0, high=100_000)
        self.neighbours = check_int(neighbours, "neighbours")
        self.completion_steps = check_int(completion_steps, "completion_steps", low=0, high=10_000)
        self.latent: np.ndarray | None = None
        self.postures: np.ndarray | None = None
        self.history: list[dict] = []
        self._sorted: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # by the first latent coordinate
        self._rank: np.ndarray | None = None

    # -- fitting ---------------------------------------------------------------------------------
    @property
    def is_fitted(self) -> bool:
        """Whether it has latent points."""
        return self.latent is not None

    @property
    def dim(self) -> int:
        """The posture's dimensions (22 for the hand's postures)."""
        return self._require()[1].shape[1]

    def fit(self, postures: np.ndarray, *, progress: bool | None = None) -> UKR:
        """Fit afresh: the best spectral start, refined (see the module doc).

        Args:
            postures: (n, dim) training postures, rad, n > latent_dim + 1.
            progress: show a bar over the refinement's iterations (None: as `progress.show_progress` says).

        Returns:
            Itself, fitted.
        """
        data = np.asarray(postures)
        data = check_data(data, data.shape[-1] if data.ndim == 2 else -1, "postures")
        if len(data) <= self.latent_dim + 1:
            raise InvalidInput(f"postures must have more than latent_dim + 1 = {self.latent_dim + 1} rows, got "
                               f"{len(data)}")
        _check_size(len(data))
        tried = []
        n, q = len(data), self.latent_dim
        sizes = np.geomspace(0.5, 2.0 * n ** (1.0 / q), self.scales)
        for name in self.starts:
            embedding = pca_embedding(data, q) if name == "pca" else isomap(data, q, min(self.neighbours, n - 1))
            spread = embedding.std(axis=0)
            unit = embedding / np.where(spread > 0, spread, 1.0)
            tried += [(loo_error(unit * size, data), name, float(size), unit) for size in sizes]
        start_error, name, size, unit = min(tried, key=lambda entry: entry[0])  # ties: the first tried
        latent, error, steps = self._refine(unit * size, data, progress, "UKR fit")
        self._set(latent, data)
        self.history = [{"kind": "fit", "postures": n, "start": name, "scale": size, "loo_start": start_error,
                         "loo": error, "iterations": steps, "data_fingerprint": fingerprint(data)}]
        return self

    def resume(self, postures: np.ndarray, *, iterations: int = 50, progress: bool | None = None) -> UKR:
        """Resumed learning (the paper's Section 5 for a SOM): the new postures join the training postures, each
        starting at the latent point that completes it best from all its joints, and all latent points are refined.

        Args:
            postures: (m, dim) new postures, rad.
            iterations: the most L-BFGS iterations.
            progress: show a bar (None: as `progress.show_progress` says).

        Returns:
            Itself.
        """
        fitted_latent, fitted_postures = self._require()
        new = check_data(postures, self.dim, "postures")
        _check_size(len(fitted_postures) + len(new))
        iterations = check_int(iterations, "iterations", low=0, high=100_000)
        places, _ = self.complete_latent_batch(new)
        data = np.vstack([fitted_postures, new])
        before = loo_error(np.vstack([fitted_latent, places]), data)
        latent, error, steps = self._refine(np.vstack([fitted_latent, places]), data, progress, "UKR resume",
                                            iterations)
        self._set(latent, data)
        self.history = [*self.history, {"kind": "resume", "postures": len(new), "loo_start": before, "loo": error,
                                        "iterations": steps, "data_fingerprint": fingerprint(new)}]  # a copy's own
        return self

    def _refine(self, latent: np.ndarray, data: np.ndarray, progress: bool | None, label: str,
                iterations: int | None = None) -> tuple[np.ndarray, float, int]:
        """L-BFGS on the leave-one-out error from `latent`: the refined points, their error, the iterations run."""
        iterations = self.iterations if iterations is None else iterations
        shape = latent.shape
        if iterations == 0:
            return latent, float(loo_error(latent, data)), 0

        unit = float(loo_error(latent, data)) or 1.0  # the error relative to the start's: L-BFGS's tolerances

        def objective(flat: np.ndarray) -> tuple[float, np.ndarray]:
            error, gradient = loo_error(flat.reshape(shape), data, gradient=True)
            return error / unit, gradient.ravel() / unit

        with progress_bar(iterations, label, "iterations", enabled=progress) as report:
            result = minimize(objective, latent.ravel(), jac=True, method="L-BFGS-B",
                              options={"maxiter": iterations}, callback=lambda _: report.update(1))
        best = result.x.reshape(shape)
        return best, float(loo_error(best, data)), int(result.nit)

    def _set(self, latent: np.ndarray, data: np.ndarray) -> None:
        self.latent = np.ascontiguousarray(latent, dtype=float)
        self.postures = np.ascontiguousarray(data, dtype=float)
        self.latent.flags.writeable = self.postures.flags.writeable = False
        self.keep_references(self.manifold(self.latent))
        order = np.argsort(self.latent[:, 0], kind="stable")  # the completion kernel reads a window of them
        self._sorted = (np.ascontiguousarray(self.latent[order]), np.ascontiguousarray(self.postures[order]),
                        np.ascontiguousarray(self.latent[order, 0]))
        self._rank = np.argsort(order)

    def _require(self) -> tuple[np.ndarray, np.ndarray]:
        """The fitted latent points and postures, or a refusal of an unfitted UKR."""
        if self.latent is None or self.postures is None:
            raise NotFittedError("this UKR is not fitted yet; call fit(postures) first")
        return self.latent, self.postures

    # -- the manifold ----------------------------------------------------------------------------
    def manifold(self, latent: np.ndarray) -> np.ndarray:
        """The manifold's postures at latent points.

        Args:
            latent: (m, q) or (q,) latent points.

        Returns:
            (m, dim) or (dim,) postures, rad.
        """
        fitted_latent, fitted_postures = self._require()
        points = np.asarray(latent, dtype=float)
        single = points.ndim == 1
        points = np.atleast_2d(points)
        if points.ndim != 2 or points.shape[1] != self.latent_dim or not np.all(np.isfinite(points)):
            raise InvalidInput(f"latent must be finite points ({self.latent_dim},) or (m, {self.latent_dim}), got "
                               f"shape {np.shape(latent)}")
        out = np.concatenate([_kernel_rows(squared_distances(points[s:s + _BLOCK], fitted_latent)) @ fitted_postures
                              for s in range(0, len(points), _BLOCK)])
        return out[0] if single else out

    def loo_error(self) -> float:
        """The leave-one-out reconstruction error of the fitted manifold, rad^2 (mean squared norm)."""
        return float(loo_error(*self._require()))

    # -- masked completion (the Experience protocol) ----------------------------------------------
    def complete_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`complete` of every query.

        Args:
            X: queries (m, dim), rad.
            masks: None, one mask (dim,) for every query, or one per query (m, dim).

        Returns:
            Postures (m, dim), rad.
        """
        return self.complete_latent_batch(X, masks)[1]

    def complete_latent_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Masked completion of every query, with the latent points it ends at.

        Args:
            X: queries (m, dim), rad; NaN allowed where the mask is 0.
            masks: None, one mask (dim,) for every query, or one per query (m, dim).

        Returns:
            The latent points (m, q) and the postures there (m, dim), rad.
        """
        latent, postures = self._require()
        queries, weights = check_queries(X, masks, self.dim)
        starts = self.masked_search().nearest_batch(queries, weights)
        if not compiled():
            return complete_reference(latent, postures, queries, weights, starts, self.completion_steps)
        assert self._sorted is not None and self._rank is not None  # kept with the latent points (`_set`)
        out_latent, out_postures = np.empty((len(queries), self.latent_dim)), np.empty_like(queries)
        parts = max(1, min(usable_cores(), len(queries) // _PER_THREAD))
        bounds = np.linspace(0, len(queries), parts + 1).astype(int)
        work = [(tuple(self._sorted), queries, weights, self._rank[starts], self.completion_steps,
                 (out_latent, out_postures), (int(a), int(b))) for a, b in zip(bounds[:-1], bounds[1:])]
        if parts == 1:
            ukr_complete_rows(*work[0])
        else:  # the kernel releases the GIL
            with ThreadPoolExecutor(parts) as pool:
                list(pool.map(lambda args: ukr_complete_rows(*args), work))
        return out_latent, out_postures

    # -- files -----------------------------------------------------------------------------------
    NPZ_KIND = "ukr"
    NPZ_REQUIRED = {"latent": (None, None), "postures": (None, None)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        latent, postures = self._require()
        return {"latent": latent, "postures": postures}, {
            "latent_dim": self.latent_dim, "dim": self.dim, "starts": list(self.starts), "scales": self.scales,
            "iterations": self.iterations, "neighbours": self.neighbours, "completion_steps": self.completion_steps,
            "history": self.history, "units": "postures rad; latent points dimensionless (kernel bandwidth 1)"}

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> UKR:
        try:
            ukr = cls(meta["latent_dim"], starts=tuple(meta["starts"]), scales=meta["scales"],
                      iterations=meta["iterations"], neighbours=meta["neighbours"],
                      completion_steps=meta["completion_steps"])
        except KeyError as missing:
            raise InvalidInput(f"{path} lacks UKR metadata {missing}") from None
        latent, postures = arrays["latent"], arrays["postures"]
        if latent.shape != (len(postures), ukr.latent_dim):
            raise InvalidInput(f"{path}: latent must be ({len(postures)}, {ukr.latent_dim}), one point per posture, "
                               f"got {latent.shape}; the file is corrupt")
        bad = ~(np.isfinite(latent) & (np.abs(np.nan_to_num(latent)) <= MAX_LATENT)).all(axis=1)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InvalidInput(f"{path}: latent row {row} is not a finite point within +-{MAX_LATENT:g} "
                               f"({latent[row].tolist()}); the file is corrupt")
        ukr._set(latent, check_file_postures(postures, path, "postures"))
        ukr.history = list(meta.get("history", []))
        return ukr

    def __repr__(self) -> str:
        state = "unfitted" if self.postures is None else f"fitted on {len(self.postures)} postures"
        return f"UKR(latent_dim={self.latent_dim}, {state})"
