"""The information ceiling: how much of a benchmark's headroom can what the controller senses predict?

A `StrategySelector` learns, from what a controller sensed on a pose (at its first contact,
`Trial.first_contact`, or when its attempt failed the lift probe, `Trial.failure`), which of several
strategies holds there, and picks the one most likely to (a random forest per strategy's success,
scikit-learn's, the `study` extra). `choose_cross_validated` picks for every pose with a model that
never saw that pose (k folds), so its hold rate is an honest estimate of what a controller that switches
strategy on that information could reach; set beside the oracle over the strategies and the chance
oracle (`stats.headroom`), it says how much of the headroom beyond chance is predictable.
A fitted selector is also a regrasp's chooser (`regrasp.Regrasp(chooser=...)`): given what a failed
attempt sensed, the preshape of the next one.
"""

from __future__ import annotations

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import check_int


def _learner():
    try:
        from sklearn.ensemble import RandomForestClassifier
    except ImportError as error:  # pragma: no cover - the message is the point
        raise ImportError("the strategy selector needs scikit-learn: pip install 'graspmanifold[study]' "
                          "(from a checkout: pip install '.[study]')") from error
    return RandomForestClassifier


def _design(features: np.ndarray) -> np.ndarray:
    """Features with NaN (nothing sensed) as -1 beside an indicator column of the rows that were sensed."""
    sensed = ~np.isnan(features).any(axis=1, keepdims=True)
    return np.hstack([np.nan_to_num(features, nan=-1.0), sensed.astype(float)])


class StrategySelector:
    """Picks, from sensed features, the strategy most likely to hold (see the module doc).

    Args:
        names: the strategies, best single one first (a tie goes to the earlier one).
        preshapes: (len(names), 22) rad, each strategy's preshape (NaN row: the plain heuristic), for a regrasp's
            chooser; None when the selector only picks names.
        seed: the forest's seed (the same seed, the same choices).
        trees: trees in the forest.
    """

    def __init__(self, names: list[str], preshapes: np.ndarray | None = None, seed: int = 0, trees: int = 200):
        if len(names) < 2 or len(set(names)) != len(names):
            raise InvalidInput(f"names must be at least two distinct strategies, got {names!r}")
        self.names = list(names)
        self.preshapes = None if preshapes is None else np.asarray(preshapes, dtype=float)
        if self.preshapes is not None and self.preshapes.shape != (len(names), 22):
            raise InvalidInput(f"preshapes must be ({len(names)}, 22): one per strategy, got {self.preshapes.shape}")
        self.seed = check_int(seed, "seed", low=0)
        self.trees = check_int(trees, "trees")
        self._model = None
        self._constant: np.ndarray | None = None

    def fit(self, features: np.ndarray, outcomes: np.ndarray) -> StrategySelector:
        """Learn each strategy's success from the features.

        Args:
            features: (m, f) what was sensed on each pose (NaN rows: nothing).
            outcomes: (m, len(names)) bool, whether each strategy held on that pose.

        Returns:
            self.
        """
        features, outcomes = self._check(features), np.asarray(outcomes)
        if outcomes.dtype != bool or outcomes.shape != (len(features), len(self.names)):
            raise InvalidInput(f"outcomes must be ({len(features)}, {len(self.names)}) bool, got dtype {outcomes.dtype} "
                               f"and shape {outcomes.shape}")
        varying = outcomes.any(axis=0) & ~outcomes.all(axis=0)
        self._constant = np.where(varying, np.nan, outcomes.mean(axis=0))  # a strategy that never or always held
        self._varying = np.flatnonzero(varying)
        self._model = None
        if len(self._varying):
            model = _learner()(n_estimators=self.trees, min_samples_leaf=2, random_state=self.seed, n_jobs=1)
            target = outcomes[:, self._varying]
            self._model = model.fit(_design(features), target[:, 0] if len(self._varying) == 1 else target)
        return self

    def probabilities(self, features: np.ndarray) -> np.ndarray:
        """(m, len(names)) the predicted chance that each strategy holds."""
        if self._constant is None:
            raise InvalidInput("the selector is not fitted yet: call fit(features, outcomes) first")
        features = self._check(features)
        chances = np.tile(self._constant, (len(features), 1))
        if self._model is not None:
            predicted, classes = self._model.predict_proba(_design(features)), self._model.classes_
            if len(self._varying) == 1:
                predicted, classes = [predicted], [classes]
            for column, p, labels in zip(self._varying, predicted, classes):
                chances[:, column] = p[:, list(labels).index(True)]
        return chances

    def predict(self, features: np.ndarray) -> np.ndarray:
        """(m,) the index into `names` of the strategy most likely to hold on each pose."""
        return np.argmax(self.probabilities(features), axis=1)  # the first of equals: the best single strategy

    def __call__(self, features: np.ndarray) -> np.ndarray:
        """A regrasp's chooser: the preshapes (m, 22), rad, of the strategies picked (NaN rows: the heuristic)."""
        if self.preshapes is None:
            raise InvalidInput("this selector was made without preshapes: it cannot choose a regrasp's preshape")
        return self.preshapes[self.predict(features)]

    def _check(self, features: np.ndarray) -> np.ndarray:
        features = np.asarray(features, dtype=float)
        if features.ndim != 2 or not len(features) or np.isinf(features).any():
            raise InvalidInput(f"features must be (m, f) with m >= 1, finite or NaN, got shape {features.shape}")
        return features


def choose_cross_validated(features: np.ndarray, outcomes: np.ndarray, names: list[str], folds: int = 5,
                           seed: int = 0) -> np.ndarray:
    """Every pose's pick by a selector trained on the other folds only.

    Args:
        features: (m, f) what was sensed on each pose.
        outcomes: (m, len(names)) bool, whether each strategy held there.
        names: the strategies, best single one first.
        folds: k of the k-fold split (at most m).
        seed: the folds' and the forests' seed.

    Returns:
        (m,) the index into `names` picked for each pose.
    """
    features = np.asarray(features, dtype=float)
    folds = check_int(folds, "folds", low=2)
    if folds > len(features):
        raise InvalidInput(f"folds must be at most the poses ({len(features)}), got {folds}")
    order = np.random.default_rng(seed).permutation(len(features))
    chosen = np.zeros(len(features), dtype=int)
    for fold in np.array_split(order, folds):
        train = np.setdiff1d(order, fold)
        selector = StrategySelector(names, seed=seed).fit(features[train], np.asarray(outcomes)[train])
        chosen[fold] = selector.predict(features[fold])
    return chosen
