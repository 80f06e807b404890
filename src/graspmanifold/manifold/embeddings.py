"""Spectral embeddings of postures: the starts of a continuous manifold's fit (`ukr.UKR`) and its linear reference.

Two embeddings, each a few lines of NumPy and SciPy (scikit-learn's would add a dependency for the same numbers):

- `principal_axes`: the principal components of the postures (PCA): the mean, the orthonormal axes by decreasing
  variance and the share of the variance each explains. The linear manifold (`linear.LinearManifold`) is this.
- `isomap`: Tenenbaum's Isomap: distances along the graph of each posture's `neighbours` nearest postures (joined
  into one graph by the minimum spanning tree of all postures, so that clusters far apart, the grasps of different
  objects, still get distances), embedded by classical scaling. It unrolls a bent manifold that PCA flattens.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import minimum_spanning_tree, shortest_path
from scipy.sparse.linalg import eigsh
from scipy.spatial import cKDTree

from ..base.errors import InvalidInput
from ..base.validation import check_int


def _postures(postures: object) -> np.ndarray:
    data = np.asarray(postures, dtype=float)
    if data.ndim != 2 or len(data) < 2 or not np.all(np.isfinite(data)):
        raise InvalidInput(f"postures must be a finite (n, dim) array of at least 2 rows, got shape {data.shape}")
    return data


def squared_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances between the rows of two arrays, by one matrix product (no (n, m, dim) array).

    Args:
        a: (n, dim).
        b: (m, dim).

    Returns:
        (n, m), clipped at 0 (rounding can make the expansion slightly negative).
    """
    products = a @ b.T
    return np.maximum((a * a).sum(axis=1)[:, None] + (b * b).sum(axis=1)[None] - 2.0 * products, 0.0)


def principal_axes(postures: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The principal components of postures.

    Args:
        postures: (n, dim), rad, n >= 2.

    Returns:
        The mean (dim,) rad, the axes (min(n, dim), dim) orthonormal rows by decreasing variance (each axis's sign
        fixed: its largest entry positive, so that no last bit flips it), and the share of the variance each
        explains (min(n, dim),), summing to 1 (all zero for identical postures).
    """
    data = _postures(postures)
    mean = data.mean(axis=0)
    _, singular, axes = np.linalg.svd(data - mean, full_matrices=False)
    axes *= np.where(axes[np.arange(len(axes)), np.abs(axes).argmax(axis=1)] < 0, -1.0, 1.0)[:, None]
    variance = singular ** 2
    total = variance.sum()
    return mean, axes, variance / total if total > 0 else np.zeros_like(variance)


def pca_embedding(postures: np.ndarray, dimensions: int) -> np.ndarray:
    """The postures' coordinates along their first principal axes.

    Args:
        postures: (n, dim), rad.
        dimensions: how many axes, 1 <= dimensions <= min(n, dim).

    Returns:
        (n, dimensions) coordinates, rad.
    """
    data = _postures(postures)
    dimensions = check_int(dimensions, "dimensions", high=min(data.shape))
    mean, axes, _ = principal_axes(data)
    return (data - mean) @ axes[:dimensions].T


def isomap(postures: np.ndarray, dimensions: int, neighbours: int = 8) -> np.ndarray:
    """Isomap coordinates of postures (see the module doc).

    Args:
        postures: (n, dim), rad, n > dimensions.
        dimensions: the embedding's dimensions.
        neighbours: each posture's nearest postures joined to it in the graph.

    Returns:
        (n, dimensions) coordinates, rad along the graph; each axis's sign fixed (its largest-magnitude coordinate
        positive).
    """
    data = _postures(postures)
    n = len(data)
    dimensions = check_int(dimensions, "dimensions", high=n - 1)
    neighbours = check_int(neighbours, "neighbours", high=n - 1)
    distances, index = cKDTree(data).query(data, neighbours + 1)
    rows = np.repeat(np.arange(n), neighbours)
    graph = sparse.coo_matrix((distances[:, 1:].ravel(), (rows, index[:, 1:].ravel())), shape=(n, n)).tocsr()
    full = np.sqrt(squared_distances(data, data))
    graph = graph.maximum(minimum_spanning_tree(full))  # joins the graph's components by their shortest links
    geodesic = shortest_path(graph, directed=False)
    squared = geodesic ** 2
    centred = -0.5 * (squared - squared.mean(axis=0) - squared.mean(axis=1)[:, None] + squared.mean())
    start = np.linspace(1.0, 2.0, n)  # ARPACK's start vector fixed: its default is random
    values, vectors = eigsh(centred, k=dimensions, which="LA", v0=start)
    order = np.argsort(values)[::-1]
    coordinates = vectors[:, order] * np.sqrt(np.maximum(values[order], 0.0))
    signs = np.where(coordinates[np.abs(coordinates).argmax(axis=0), np.arange(dimensions)] < 0, -1.0, 1.0)
    return coordinates * signs
