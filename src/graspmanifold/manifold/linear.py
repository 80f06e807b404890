"""A linear grasp manifold: the postures' first principal components (PCA hand synergies, "eigengrasps").

    linear = LinearManifold(components=2).fit(postures)
    posture = linear.complete(pcp, mask)                      # masked completion in closed form

The manifold is the affine subspace mean + span(first k principal axes) (`embeddings.principal_axes`), read as
probabilistic PCA (Tipping and Bishop, 1999): the coordinates z along the axes have the variances the axes explain,
lambda_1..k, and each joint an independent residual variance s^2, the mean variance of the axes left out (at least
`MIN_RESIDUAL`). Masked completion is the posture's conditional mean given its specified joints, in closed form:

    (W^T P W + s^2 diag(1 / lambda)) z = W^T P (x - mean),    posture = mean + W z

(P the mask's weights). With every joint specified it is the projection, shrunk towards the mean by
lambda / (lambda + s^2) along each axis; with few specified joints the prior keeps z where the postures lie (a plain
least-squares fit over the specified joints would let the unconstrained coordinates run off).

It is the plain linear reference beside the SOM and UKR: an `experience.Experience` whose `references` are the
training postures projected onto the subspace (`best_match` the nearest of them under the masked distance).
`explained` holds the share of the variance each principal axis explains (the human hand's figure: 80 % with two,
Santello, Flanders and Soechting, 1998).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..base.errors import InvalidInput, NotFittedError
from ..base.io import NpzRecord, fingerprint
from ..base.validation import check_data, check_int
from .embeddings import principal_axes
from .experience import check_file_postures
from .nearest import ManifoldMatcher, check_queries

MIN_RESIDUAL = 1e-6  # rad^2: the smallest residual variance per joint (see the module doc)
_BLOCK = 4096  # queries per stacked solve: bounds memory at BLOCK x k x k


class _Subspace(NamedTuple):
    """A fitted linear manifold: the mean (dim,) rad, the principal axes (k, dim), every axis's share of the
    variance (dim,), the kept axes' variances (k,) rad^2."""

    mean: np.ndarray
    axes: np.ndarray
    explained: np.ndarray
    variances: np.ndarray


class LinearManifold(ManifoldMatcher, NpzRecord):
    """The affine subspace of the postures' first `components` principal axes (see the module doc).

    Attributes (fitted): `mean` (dim,) rad, `axes` (components, dim) orthonormal rows, `variances` (components,)
    rad^2 along them, `residual` the residual variance per joint (rad^2), `explained` (min(n, dim),) the variance
    share of every principal axis (not only the kept ones), `references` (n, dim) the training postures projected,
    rad.
    """

    def __init__(self, components: int = 5):
        """An unfitted linear manifold.

        Args:
            components: the principal axes kept, k >= 1.
        """
        self.components = check_int(components, "components")
        self.mean: np.ndarray | None = None
        self.variances: np.ndarray | None = None
        self.residual = self.total_variance = 0.0
        self.axes: np.ndarray | None = None
        self.explained: np.ndarray | None = None
        self.data_fingerprint = ""

    @property
    def is_fitted(self) -> bool:
        """Whether it has its axes."""
        return self.axes is not None

    @property
    def dim(self) -> int:
        """The posture's dimensions (22 for the hand's postures)."""
        return self._require().axes.shape[1]

    def _require(self) -> _Subspace:
        """The fitted subspace, or a refusal of an unfitted manifold."""
        if self.mean is None or self.axes is None or self.explained is None or self.variances is None:
            raise NotFittedError("this LinearManifold is not fitted yet; call fit(postures) first")
        return _Subspace(self.mean, self.axes, self.explained, self.variances)

    def fit(self, postures: np.ndarray) -> LinearManifold:
        """The principal axes of the postures.

        Args:
            postures: (n, dim) training postures, rad, n >= 2 and components <= min(n, dim).

        Returns:
            Itself, fitted.
        """
        data = np.asarray(postures)
        data = check_data(data, data.shape[-1] if data.ndim == 2 else -1, "postures")
        if self.components > min(data.shape) or len(data) < 2:
            raise InvalidInput(f"components ({self.components}) must be at most min(n, dim) of postures, got shape "
                               f"{data.shape}")
        mean, axes, explained = principal_axes(data)
        total = float(((data - mean) ** 2).sum() / (len(data) - 1))  # the variance, rad^2
        self._set(mean, axes[:self.components], explained, total)
        self.keep_references(self.project(data))
        self.data_fingerprint = fingerprint(data)
        return self

    def _set(self, mean: np.ndarray, axes: np.ndarray, explained: np.ndarray, total: float) -> None:
        self.mean, self.axes, self.explained = (np.array(a, dtype=float) for a in (mean, axes, explained))
        self.total_variance = float(total)
        self.variances = np.maximum(self.explained[:self.components] * total, MIN_RESIDUAL)
        left = len(self.mean) - self.components
        self.residual = max(float(self.explained[self.components:].sum() * total / left) if left else 0.0,
                            MIN_RESIDUAL)

    def components_for(self, share: float) -> int:
        """The fewest principal axes that explain at least `share` of the variance.

        Args:
            share: in (0, 1].

        Returns:
            The count.
        """
        explained = self._require().explained
        if not 0 < share <= 1:
            raise InvalidInput(f"share must be in (0, 1], got {share!r}")
        return int(np.searchsorted(np.cumsum(explained), share - 1e-12) + 1)

    def project(self, postures: np.ndarray) -> np.ndarray:
        """Postures projected onto the subspace (orthogonally: no shrinkage).

        Args:
            postures: (m, dim), rad.

        Returns:
            (m, dim), rad.
        """
        mean, axes = self._require()[:2]
        data = check_data(postures, self.dim, "postures")
        return mean + ((data - mean) @ axes.T) @ axes

    def complete_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`complete` of every query.

        Args:
            X: queries (m, dim), rad.
            masks: None, one mask (dim,) for every query, or one per query (m, dim).

        Returns:
            Postures (m, dim), rad.
        """
        mean, axes, _, variances = self._require()
        queries, weights = check_queries(X, masks, self.dim)
        out = np.empty_like(queries)
        prior = np.diag(self.residual / variances)
        for start in range(0, len(queries), _BLOCK):
            block = slice(start, start + _BLOCK)
            p = weights[block]
            offset = np.where(p > 0, queries[block] - mean, 0.0)
            normal = np.einsum("kd,md,ld->mkl", axes, p, axes) + prior
            right = np.einsum("kd,md->mk", axes, p * offset)
            latent = np.linalg.solve(normal, right[..., None])[..., 0]
            out[block] = mean + latent @ axes
        return out

    # -- files -----------------------------------------------------------------------------------
    NPZ_KIND = "linear_manifold"
    NPZ_REQUIRED = {"mean": (None,), "axes": (None, None), "explained": (None,), "references": (None, None)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        mean, axes, explained, _ = self._require()
        return ({"mean": mean, "axes": axes, "explained": explained, "references": self.references},
                {"components": self.components, "dim": self.dim, "data_fingerprint": self.data_fingerprint,
                 "total_variance": self.total_variance,
                 "units": "mean, references rad; axes orthonormal; explained variance shares"})

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> LinearManifold:
        axes = arrays["axes"]
        linear = cls(len(axes))
        dim = axes.shape[1]
        if arrays["mean"].shape != (dim,) or arrays["references"].shape[1:] != (dim,) \
                or not np.allclose(axes @ axes.T, np.eye(len(axes)), atol=1e-8):
            raise InvalidInput(f"{path}: a linear manifold needs a mean ({dim},), orthonormal axes and references "
                               f"(n, {dim})")
        mean = check_file_postures(arrays["mean"][None], path, "mean")[0]
        try:
            linear._set(mean, axes, arrays["explained"], float(meta["total_variance"]))
        except (KeyError, TypeError, ValueError):
            raise InvalidInput(f"{path} lacks the linear manifold's total_variance") from None
        linear.keep_references(check_file_postures(arrays["references"], path, "references"))
        linear.data_fingerprint = str(meta.get("data_fingerprint", ""))
        return linear

    def __repr__(self) -> str:
        explained = self.explained
        state = "unfitted" if explained is None else f"{explained[:self.components].sum():.0%} of the variance"
        return f"LinearManifold(components={self.components}, {state})"
