"""A Self-Organising Map on a rectangular lattice, vectorised with NumPy (paper Sections 3-5).

    som = SOM(25, 25, 22, seed=0).fit(postures)                         # the paper's schedule
    som.resume(new_postures)                   # resumed learning: 10 epochs, lr 0.1 -> 0.05, sigma 3 -> 0.7
    node = som.best_match(pcp, mask)                                      # Eq. 3 with Eq. 4
    posture = som.complete(pcp, mask)                                     # associative completion

Conventions follow scikit-learn where it has one: the training schedule is given to the
constructor (`epochs`, `learning_rate`, `sigma`, `algorithm`; the paper's values by default), and
`fit` always trains afresh. Continuing a trained map, the paper's resumed learning, is the explicit
`resume` (its own, gentler schedule). Unlike scikit-learn, fitted state has no trailing underscore
(`weights`, `history`), and `fit` accepts the schedule's values as keyword overrides for one run.

Training schedule. Learning rate and neighbourhood width decay exponentially from their start to
their end value over the run, one value per epoch: v_e = v_0 (v_end / v_0)^(e / (epochs - 1)).
Each epoch presents every sample once, in a fresh random order. The neighbourhood is the Gaussian
h = lr * exp(-|a - a*|^2 / (2 sigma^2)) on lattice coordinates; values below 1e-12 of the centre
are dropped (they would move a weight by less than 1e-12 of its distance to the sample).

Online training is the textbook update w <- w + h (x - w), one sample at a time, fused with the
winner search in a compiled kernel (`kernels.online_epoch`) that updates only the lattice window
where h can exceed the 1e-12 bound; `online_epoch_reference` is the same epoch in NumPy (the
tests compare them). `algorithm="batch"` is Kohonen's batch map (no learning rate) with the same
sigma schedule, for speed: it finds all winners of an epoch with single-precision matrix products
on centred data, on every core's BLAS thread, a block of samples at a time (winners closer than
~1e-6 in squared distance may resolve differently than in double precision, which moves the map
negligibly); the weights themselves are double precision.

Initialisation is from the principal components: the lattice spans the 5th to 95th percentile of
the data along its first two principal axes. It needs no random numbers, starts the map already
ordered (the paper's shrinking schedule then refines rather than untangles) and makes the seed
matter only for the presentation order.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import sparse
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ..base.errors import InvalidInput, NotFittedError
from ..base.io import NpzRecord, fingerprint
from ..base.paper_numbers import RESUME_SCHEDULE, TRAINING_SCHEDULE
from ..base.progress import progress_bar
from ..base.validation import check_choice, check_data, check_int
from ..base.workers import free_cores
from ..base.compiled import compiled
from .kernels import online_epoch
from .experience import carried_values, check_file_postures, check_places, check_squeezes
from .nearest import MaskedNearest, ReferenceMatcher, nearest_rows

ALGORITHMS = ("online", "batch")
_NEGLIGIBLE = 1e-12
_BATCH_BLOCK = 4096  # samples per winner product of batch training: bounds its memory


def decay_schedule(start: float, end: float, epochs: int) -> np.ndarray:
    """Per-epoch values decaying exponentially from `start` to `end`."""
    if epochs == 1:
        return np.array([float(start)])
    return start * (end / start) ** (np.arange(epochs) / (epochs - 1))


def check_schedule(value: object, name: str, upper: float | None = None) -> tuple[float, float]:
    """A decaying (start, end) schedule: positive, below `upper`, start >= end."""
    try:
        if not isinstance(value, Iterable):
            raise TypeError(name)
        start, end = (float(v) for v in value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be a (start, end) pair of numbers, got {value!r}") from None
    for v in (start, end):
        if not math.isfinite(v) or v <= 0 or (upper is not None and v >= upper):
            bound = f" and below {upper}" if upper is not None else ""
            raise InvalidInput(f"{name} values must be positive{bound}, got {value!r}")
    if start < end:
        raise InvalidInput(f"{name} must decay: (start, end) with start >= end, got {value!r} (reversed?)")
    return start, end


@dataclass(frozen=True)
class SOMSchedule:
    """A training schedule: `epochs`, and the learning rate and neighbourhood width decaying from
    their first to their second value (see the module doc). PAPER trains a map, RESUME continues one."""

    epochs: int
    learning_rate: tuple[float, float]
    sigma: tuple[float, float]

    def __post_init__(self) -> None:
        _schedule(self.epochs, self.learning_rate, self.sigma, ALGORITHMS[0])

    def as_dict(self) -> dict:
        """epochs, learning_rate and sigma as keyword arguments (of `SOM.fit` and `SOM.resume`)."""
        return {"epochs": self.epochs, "learning_rate": self.learning_rate, "sigma": self.sigma}


#: the largest map (nodes) and the most epochs a map trains for: far beyond any study (the paper: 625 nodes, 300
#: epochs), short of asking for terabytes (1e12 epochs asked for 7 TiB of presentation orders)
MAX_NODES = 250_000
MAX_EPOCHS = 100_000


def _schedule(epochs: object, learning_rate: object, sigma: object, algorithm: object
              ) -> tuple[int, tuple[float, float], tuple[float, float], str]:
    """A checked training schedule."""
    return (check_int(epochs, "epochs", high=MAX_EPOCHS), check_schedule(learning_rate, "learning_rate", upper=1.0),
            check_schedule(sigma, "sigma"), _algorithm(algorithm))


def _algorithm(value: object) -> str:
    return str(check_choice(value, ALGORITHMS, "algorithm"))


def online_epoch_reference(flat: np.ndarray, data: np.ndarray, order: np.ndarray, table: np.ndarray) -> None:
    """One online epoch in NumPy, in place on the nodes `flat` (n_nodes, dim): for each sample
    data[i], i in `order`, the winner b and w <- w + table[b] (x - w) (the reference of
    `kernels.online_epoch`; `table` from `SOM._neighbourhood_table`)."""
    for i in order:
        offsets = data[i] - flat
        winner = int(np.einsum("ij,ij->i", offsets, offsets).argmin())
        flat += table[winner][:, None] * offsets


#: the paper's schedules: training (Section 4) and resumed learning (Section 5)
PAPER = SOMSchedule(*TRAINING_SCHEDULE)
RESUME = SOMSchedule(*RESUME_SCHEDULE)


class SOM(ReferenceMatcher, NpzRecord):
    """A rows x cols Self-Organising Map with reference vectors of length `dim`."""

    def __init__(self, rows: int, cols: int, dim: int | None = None, *, seed: int = 0, epochs: int = PAPER.epochs,
                 learning_rate: tuple[float, float] = PAPER.learning_rate, sigma: tuple[float, float] = PAPER.sigma,
                 algorithm: str = "online", random_state: int | None = None, schedule: SOMSchedule | None = None):
        """The lattice, the seed (presentation order) and the training schedule `fit` uses.

        Args:
            rows: lattice rows.
            cols: lattice columns.
            dim: length of the reference vectors (None: taken from the data at the first `fit`).
            seed: the random presentation order's seed.
            epochs: training epochs (the paper: 300).
            learning_rate: (start, end), decaying exponentially (the paper: 0.95 -> 0.05).
            sigma: neighbourhood width in lattice units, (start, end) (the paper: 6 -> 0.7).
            algorithm: 'online' (the paper's) or 'batch'.
            random_state: another name for `seed`, as scikit-learn users look for it.
            schedule: the training schedule as one value (`PAPER`, `RESUME` or one's own `SOMSchedule`) instead of
                `epochs`, `learning_rate` and `sigma` one by one: `SOM(25, 25, schedule=PAPER)`.
        """
        if schedule is not None:
            if not isinstance(schedule, SOMSchedule):
                raise InvalidInput(f"schedule must be a SOMSchedule (som.PAPER, som.RESUME or one's own), got "
                                   f"{type(schedule).__name__}")
            if (epochs, learning_rate, sigma) != (PAPER.epochs, PAPER.learning_rate, PAPER.sigma):
                raise InvalidInput("give the schedule once: schedule=... or epochs, learning_rate and sigma, not both")
            epochs, learning_rate, sigma = schedule.epochs, schedule.learning_rate, schedule.sigma
        if random_state is not None:
            if seed != 0 and seed != random_state:
                raise InvalidInput(f"seed ({seed!r}) and random_state ({random_state!r}) name the same thing; give one")
            seed = random_state
        self.rows = check_int(rows, "rows")
        self.cols = check_int(cols, "cols")
        if self.rows * self.cols > MAX_NODES:  # a 100000 x 100000 map asked for 149 GiB at its first step
            raise InvalidInput(f"a map of rows x cols nodes must have at most {MAX_NODES}, got {self.rows} x {self.cols}")
        self.dim = None if dim is None else check_int(dim, "dim")
        self.seed = check_int(seed, "seed", low=0)
        self.epochs = check_int(epochs, "epochs", high=MAX_EPOCHS)
        self.learning_rate = check_schedule(learning_rate, "learning_rate", upper=1.0)
        self.sigma = check_schedule(sigma, "sigma")
        self.algorithm = _algorithm(algorithm)
        self.history: list[dict] = []
        #: (n_nodes, 3) m, where the object sat in the palm's frame for each node's posture (`carry_places`), or None
        self.places: np.ndarray | None = None
        #: (n_nodes, 22) rad, how hard each node's posture pressed when verified (`carry_squeezes`), or None
        self.squeezes: np.ndarray | None = None
        self._weights: np.ndarray | None = None
        self._search: MaskedNearest | None = None
        # lattice coordinates of every node, flat order row * cols + col
        self._grid = np.indices((self.rows, self.cols)).reshape(2, -1).T

    # -- state -----------------------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        return self.rows * self.cols

    @property
    def is_fitted(self) -> bool:
        return self._weights is not None

    @property
    def weights(self) -> np.ndarray:
        """Reference vectors, shape (rows, cols, dim) (read-only; assign a new array to change them)."""
        view = self._require_weights().view()
        view.flags.writeable = False
        return view

    @weights.setter
    def weights(self, value: np.ndarray) -> None:
        array = np.array(value, dtype=float)
        if self.dim is None or array.shape != (self.rows, self.cols, self.dim):
            raise InvalidInput(f"weights must have shape {(self.rows, self.cols, self.dim)}, got {array.shape}")
        check_data(array.reshape(-1, self.dim), self.dim, "weights")
        self._weights = array
        self._search = None
        self.places = self.squeezes = None  # they belonged to the old weights

    @property
    def references(self) -> np.ndarray:
        """The nodes' reference vectors as rows (n_nodes, dim), in the flat order of `best_match` (read-only)."""
        return self.weights.reshape(-1, self._known_dim())

    def carry_places(self, postures: np.ndarray, places: np.ndarray) -> SOM:
        """Let every node know where the object sat (issue 66): the place of its nearest posture among those the map
        stands for, never matched, recalled with the node's posture. New weights (training on) forget them.

        Args:
            postures: (m, dim) rad, the postures the map was trained on (or any it stands for).
            places: (m, 3) m, where the object sat in the palm's frame in each (`experience.object_places`).

        Returns:
            This map, its `places` set.
        """
        data = self._data(postures)
        places = check_places(places, len(data))
        self.places = check_places(places[nearest_rows(self.references, data)], self.n_nodes)
        return self

    def carry_squeezes(self, postures: np.ndarray, squeezes: np.ndarray) -> SOM:
        """Let every node know how hard its grasp pressed (issue 84): the verified squeeze of its nearest posture
        among those the map stands for (as `carry_places`), pressed by the approach execution when it recalls the
        node. New weights (training on) forget them.

        Args:
            postures: (m, dim) rad, the postures the map was trained on (or any it stands for).
            squeezes: (m, 22) rad, each one's verified squeeze less its posture (`plans.OpenLoopGrasp.squeeze_offset`).

        Returns:
            This map, its `squeezes` set.
        """
        data = self._data(postures)
        squeezes = check_squeezes(squeezes, len(data))
        self.squeezes = check_squeezes(squeezes[nearest_rows(self.references, data)], self.n_nodes)
        return self

    def _known_dim(self) -> int:
        """The postures' dimension, or a refusal of a map that has not seen any yet."""
        if self.dim is None:
            raise NotFittedError("this SOM has no weights yet: call fit() (or initialize()) first")
        return self.dim

    def _require_weights(self) -> np.ndarray:
        if self._weights is None:
            raise NotFittedError("this SOM has no weights yet: call fit() (or initialize()) first")
        return self._weights

    def masked_search(self) -> MaskedNearest:
        """The masked nearest search over the map's nodes: best match and completion (Eq. 3 with Eq. 4's distance).

        Returns:
            The `MaskedNearest` over the node weights.
        """
        if self._search is None:
            self._search = MaskedNearest(self._require_weights().reshape(-1, self._known_dim()))
        return self._search

    # -- training --------------------------------------------------------------------------------
    def _data(self, X: np.ndarray) -> np.ndarray:
        """X checked as training data; a map made without `dim` takes it from the first data it sees."""
        if self.dim is None:
            shape = np.shape(X)
            if len(shape) != 2 or not shape[1]:
                raise InvalidInput(f"X must be an (n, dim) array of training vectors, got shape {shape}")
            self.dim = check_int(shape[1], "dim")
        return check_data(X, self.dim)

    def initialize(self, X: np.ndarray) -> SOM:
        """Place the lattice on the data's first two principal axes (deterministic).

        Args:
            X: samples (n, dim), rad; a map made without `dim` takes it from X.

        Returns:
            This map, initialised.
        """
        data = self._data(X)
        mean = data.mean(axis=0)
        centred = data - mean
        if len(data) > 1:
            _, _, components = np.linalg.svd(centred, full_matrices=False)
        else:
            components = np.zeros((0, data.shape[1]))
        axes = np.zeros((2, data.shape[1]))
        axes[: min(2, len(components))] = components[:2]
        for axis in axes:  # a fixed sign per axis: its largest component is positive
            if np.any(axis):
                axis *= np.sign(axis[np.argmax(np.abs(axis))])
        spans = []
        for axis, count in zip(axes, (self.rows, self.cols)):
            low, high = np.percentile(centred @ axis, [5, 95])
            spans.append(np.linspace(low, high, count) if count > 1 else np.zeros(1))
        weights = mean + spans[0][:, None, None] * axes[0] + spans[1][None, :, None] * axes[1]
        self.weights = weights
        return self

    def fit(self, X: np.ndarray, *, epochs: int | None = None, learning_rate: tuple[float, float] | None = None,
            sigma: tuple[float, float] | None = None, algorithm: str | None = None, progress: bool | None = None) -> SOM:
        """Train afresh with the constructor's schedule (or these overrides).

        The map is initialised on the data's principal components and its history starts over.

        Args:
            X: training vectors (n, dim), rad for postures; a map made without `dim` takes it from X.
            epochs: override the constructor's epochs.
            learning_rate: override (start, end).
            sigma: override (start, end), lattice units.
            algorithm: override 'online' / 'batch'.
            progress: show a progress bar (None: as `progress.show_progress` says).

        Returns:
            This map, trained.
        """
        data = self._data(X)
        schedule = _schedule(self.epochs if epochs is None else epochs,
                             self.learning_rate if learning_rate is None else learning_rate,
                             self.sigma if sigma is None else sigma, algorithm or self.algorithm)
        self.history = []
        self.initialize(data)
        return self._train(data, *schedule, progress)

    def resume(self, X: np.ndarray, *, epochs: int = RESUME.epochs, learning_rate: tuple[float, float] = RESUME.learning_rate,
               sigma: tuple[float, float] = RESUME.sigma, algorithm: str | None = None, progress: bool | None = None) -> SOM:
        """Resumed learning (paper Section 5): continue training the fitted map from its current weights.

        By default with the paper's gentle schedule (10 epochs, learning rate 0.1 -> 0.05, sigma 3 -> 0.7), so
        new experience is folded in without unfolding the map.

        Args:
            X: the new samples (n, dim), rad.
            epochs: epochs.
            learning_rate: (start, end).
            sigma: (start, end), lattice units.
            algorithm: 'online' / 'batch' (default: the constructor's).
            progress: show a progress bar (None: as `progress.show_progress` says).

        Returns:
            This map, trained further.
        """
        data = check_data(X, self._known_dim())
        schedule = _schedule(epochs, learning_rate, sigma, algorithm or self.algorithm)
        if not self.is_fitted:
            raise NotFittedError("resume() continues a fitted map: call fit() first")
        return self._train(data, *schedule, progress)

    def _train(self, data: np.ndarray, epochs: int, learning_rate: tuple[float, float], sigma: tuple[float, float],
               algorithm: str, progress: bool | None) -> SOM:
        rates = decay_schedule(*learning_rate, epochs)
        widths = decay_schedule(*sigma, epochs)
        rng = np.random.default_rng([self.seed, len(self.history)])
        with progress_bar(epochs, f"SOM {self.rows}x{self.cols} {algorithm}", "epochs", enabled=progress) as report:
            if algorithm == "online":
                weights = self._train_online(data, rates, widths, rng, report)
            else:
                # the free cores' BLAS threads: 1.9x one thread on an idle machine (bench_som.py), and no fight
                # with other processes for busy cores (22 s instead of 0.7 s under load, issue 26)
                with threadpool_limits(limits=free_cores(), user_api="blas"):
                    weights = self._train_batch(data, widths, report)
        self.weights = weights
        self.history.append({"algorithm": algorithm, "epochs": epochs, "learning_rate": list(map(float, learning_rate)),
                             "sigma": list(map(float, sigma)), "samples": len(data),
                             "data_fingerprint": fingerprint(data)})
        return self

    def _train_online(self, data: np.ndarray, rates: np.ndarray, widths: np.ndarray,
                      rng: np.random.Generator, report: tqdm) -> np.ndarray:
        if not compiled():
            flat = self._require_weights().reshape(self.n_nodes, self._known_dim()).copy()
            for rate, sigma in zip(rates, widths):
                online_epoch_reference(flat, data, rng.permutation(len(data)), self._neighbourhood_table(rate, sigma))
                report.update()
            return flat.reshape(self.rows, self.cols, self._known_dim())
        weights_t = np.ascontiguousarray(self._require_weights().reshape(self.n_nodes, self._known_dim()).T)
        for rate, sigma in zip(rates, widths):
            online_epoch(weights_t, data, rng.permutation(len(data)), rate, sigma, self.rows, self.cols, _NEGLIGIBLE)
            report.update()
        return np.ascontiguousarray(weights_t.T).reshape(self.rows, self.cols, self._known_dim())

    def _neighbourhood_table(self, rate: float, sigma: float) -> np.ndarray:
        """(n_nodes, n_nodes) table: row b holds rate * exp(-|a - b|^2 / (2 sigma^2)) for every node a."""
        g_rows = np.exp(-0.5 * (np.subtract.outer(np.arange(self.rows), np.arange(self.rows)) / sigma) ** 2)
        g_cols = np.exp(-0.5 * (np.subtract.outer(np.arange(self.cols), np.arange(self.cols)) / sigma) ** 2)
        table = rate * np.einsum("ac,bd->abcd", g_rows, g_cols).reshape(self.n_nodes, self.n_nodes)
        table[table < _NEGLIGIBLE * rate] = 0.0
        return table

    def _train_batch(self, data: np.ndarray, widths: np.ndarray, report: tqdm) -> np.ndarray:
        rows, cols, dim = self.rows, self.cols, self._known_dim()
        centre = data.mean(axis=0)
        centred = data - centre
        augmented = np.hstack([centred, np.ones((len(data), 1))]).astype(np.float32)
        weights = self._require_weights().reshape(self.n_nodes, dim) - centre
        lattice_r = np.subtract.outer(np.arange(rows), np.arange(rows)) ** 2
        lattice_c = np.subtract.outer(np.arange(cols), np.arange(cols)) ** 2
        scores = np.empty((min(len(data), _BATCH_BLOCK), self.n_nodes), dtype=np.float32)
        # each sample's winner as a sparse (samples, nodes) membership matrix: one entry per row, so an
        # epoch only rewrites its column indices (in place, by the argmax below)
        membership = sparse.csr_matrix((np.ones(len(data)), np.zeros(len(data), dtype=np.intp),
                                        np.arange(len(data) + 1)), shape=(len(data), self.n_nodes))
        winners = membership.indices
        for sigma in widths:
            # winners: argmax of x.w - |w|^2 / 2, in single precision on centred data
            node_side = np.hstack([weights, -0.5 * np.einsum("ij,ij->i", weights, weights)[:, None]])
            node_side = node_side.T.astype(np.float32)
            for start in range(0, len(data), _BATCH_BLOCK):
                block = augmented[start:start + _BATCH_BLOCK]
                np.dot(block, node_side, out=scores[:len(block)])
                scores[:len(block)].argmax(axis=1, out=winners[start:start + len(block)])
            sums = np.asarray(membership.T @ centred).reshape(rows, cols * dim)
            counts = np.bincount(winners, minlength=self.n_nodes).reshape(rows, cols).astype(float)
            g_r = np.exp(-0.5 * lattice_r / sigma**2)
            g_c = np.exp(-0.5 * lattice_c / sigma**2)
            numerator = np.matmul(g_c, (g_r @ sums).reshape(rows, cols, dim))  # separable Gaussian
            denominator = (g_r @ counts @ g_c.T).ravel()
            update = denominator > 1e-300
            weights[update] = numerator.reshape(self.n_nodes, dim)[update] / denominator[update, None]
            report.update()
        return (weights + centre).reshape(rows, cols, dim)

    # -- quality and structure -------------------------------------------------------------------
    def quantization_error(self, X: np.ndarray) -> float:
        """Mean Euclidean distance from each sample to its best-matching reference vector.

        Args:
            X: samples (n, dim), rad.

        Returns:
            The mean distance, rad.
        """
        data = check_data(X, self._known_dim())
        flat = self._require_weights().reshape(-1, self._known_dim())
        return float(np.mean(np.linalg.norm(data - flat[self.best_match_batch(data)], axis=1)))

    def topographic_error(self, X: np.ndarray) -> float:
        """Fraction of samples whose best and second-best nodes are not lattice neighbours (8-neighbourhood).

        Args:
            X: samples (n, dim), rad.

        Returns:
            The fraction, 0 ... 1.
        """
        data = check_data(X, self._known_dim())
        flat = self._require_weights().reshape(-1, self._known_dim())
        errors = 0
        for start in range(0, len(data), 4096):
            block = data[start:start + 4096]
            d = (np.einsum("ij,ij->i", flat, flat)[None, :] - 2.0 * block @ flat.T)
            two = np.argsort(d, axis=1, kind="stable")[:, :2]
            gap = np.abs(self._grid[two[:, 0]] - self._grid[two[:, 1]]).max(axis=1)
            errors += int(np.count_nonzero(gap > 1))
        return errors / len(data)

    def hit_counts(self, X: np.ndarray) -> np.ndarray:
        """How many samples best-match each node.

        Args:
            X: samples (n, dim), rad.

        Returns:
            Counts (rows, cols).
        """
        return np.bincount(self.best_match_batch(check_data(X, self._known_dim())),
                           minlength=self.n_nodes).reshape(self.rows, self.cols)

    def unsupported_nodes(self, X: np.ndarray) -> np.ndarray:
        """The nodes that no sample falls on.

        Args:
            X: samples (n, dim), rad.

        Returns:
            Flat node indices.
        """
        return np.flatnonzero(self.hit_counts(X).ravel() == 0)

    def internode_distances(self) -> tuple[np.ndarray, np.ndarray]:
        """Euclidean distances between 4-neighbours: horizontal (rows, cols-1), vertical (rows-1, cols)."""
        w = self._require_weights()
        return (np.linalg.norm(np.diff(w, axis=1), axis=2), np.linalg.norm(np.diff(w, axis=0), axis=2))

    def distance_stats(self, degrees: bool = False) -> dict[str, float]:
        """Minimum, maximum, mean, standard deviation and coefficient of variation of the inter-node distances.

        Args:
            degrees: report distances between posture vectors in degrees (the paper's Fig. 4 text), not rad.

        Returns:
            The statistics by name ('min', 'max', 'mean', 'std', 'cv').
        """
        horizontal, vertical = self.internode_distances()
        d = np.concatenate([horizontal.ravel(), vertical.ravel()])
        if degrees:
            d = np.degrees(d)
        if len(d) == 0:
            raise InvalidInput("a 1 x 1 map has no inter-node distances")
        mean = float(d.mean())
        return {"min": float(d.min()), "max": float(d.max()), "mean": mean, "std": float(d.std()),
                "cv": float(d.std() / mean) if mean > 0 else float("nan"), "edges": int(len(d))}

    # -- files -----------------------------------------------------------------------------------
    NPZ_KIND = "som"
    NPZ_REQUIRED = {"weights": (None, None, None)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        """Its weights, with its shape, seed, schedule and training history."""
        meta = {"rows": self.rows, "cols": self.cols, "dim": self.dim, "seed": self.seed, "history": self.history,
                "schedule": {"epochs": self.epochs, "learning_rate": list(self.learning_rate),
                             "sigma": list(self.sigma), "algorithm": self.algorithm},
                "units": "as the training data (radians for postures)"}
        return {"weights": self._require_weights(), **carried_values(self)}, meta

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> SOM:
        """The map of a file (maps saved before the schedule was stored get the paper's)."""
        try:
            som = cls(meta["rows"], meta["cols"], meta["dim"], seed=meta["seed"], **meta.get("schedule", {}))
        except KeyError as missing:
            raise InvalidInput(f"{path} lacks SOM metadata {missing}") from None
        weights = arrays["weights"]
        if weights.ndim == 3:  # another shape is refused by the setter, named
            check_file_postures(weights.reshape(-1, weights.shape[-1]), path, "weights")
        som.weights = weights
        som.places = None if "places" not in arrays else check_places(arrays["places"], som.n_nodes)
        som.squeezes = None if "squeezes" not in arrays else check_squeezes(arrays["squeezes"], som.n_nodes)
        som.history = list(meta.get("history", []))
        return som

    def __repr__(self) -> str:
        state = f"trained {len(self.history)}x" if self.history else ("initialised" if self.is_fitted else "untrained")
        return f"SOM({self.rows}x{self.cols}, dim={self.dim}, seed={self.seed}, {state})"
