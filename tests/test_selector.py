"""The strategy selector: it learns which strategy holds from what was sensed, cross-validated honestly."""

import numpy as np
import pytest

from graspmanifold.trials.benchmark import PLACEMENTS, benchmark_grid, benchmark_split, cells
from graspmanifold.trials.strategy_selector import StrategySelector, choose_cross_validated


def test_a_selector_finds_a_strategy_that_depends_on_what_was_sensed():
    rng = np.random.default_rng(0)
    features = rng.normal(size=(300, 4))
    outcomes = np.column_stack([features[:, 0] > 0.3, features[:, 0] < -0.3, np.zeros(300, dtype=bool)])
    picked = choose_cross_validated(features, outcomes, ["a", "b", "never"], folds=5, seed=0)
    held = outcomes[np.arange(300), picked].mean()
    assert held > outcomes.mean(axis=0).max() + 0.25  # far above the best single strategy
    assert held <= outcomes.any(axis=1).mean()  # and never above the oracle
    again = choose_cross_validated(features, outcomes, ["a", "b", "never"], folds=5, seed=0)
    assert np.array_equal(picked, again)  # the same seed, the same picks


def test_a_selector_without_information_picks_the_best_single_strategy():
    rng = np.random.default_rng(1)
    outcomes = np.column_stack([rng.random(100) < 0.6, np.ones(100, dtype=bool)])  # the second always holds
    selector = StrategySelector(["coin", "sure"]).fit(np.full((100, 3), np.nan), outcomes)
    assert (selector.predict(np.full((5, 3), np.nan)) == 1).all()
    assert selector.probabilities(np.zeros((2, 3))).shape == (2, 2)


def test_a_selector_chooses_a_regrasps_preshape():
    preshapes = np.vstack([np.full(22, np.nan), np.full(22, 0.3)])
    features = np.array([[0.0], [1.0]] * 20)
    outcomes = np.column_stack([features[:, 0] == 0, features[:, 0] == 1])
    chooser = StrategySelector(["none", "wide"], preshapes).fit(features, outcomes)
    chosen = chooser(np.array([[0.0], [1.0]]))
    assert np.isnan(chosen[0]).all() and np.allclose(chosen[1], 0.3)


@pytest.mark.parametrize("call, message", [
    (lambda: StrategySelector(["one"]), "at least two distinct"),
    (lambda: StrategySelector(["a", "b"]).predict(np.zeros((1, 2))), "not fitted"),
    (lambda: StrategySelector(["a", "b"]).fit(np.zeros((3, 2)), np.zeros((3, 3), bool)), r"outcomes must be \(3, 2\)"),
    (lambda: StrategySelector(["a", "b"]).fit(np.zeros(3), np.zeros((3, 2), bool)), "features must be"),
    (lambda: StrategySelector(["a", "b"])(np.zeros((1, 2))), "without preshapes"),
    (lambda: choose_cross_validated(np.zeros((3, 1)), np.zeros((3, 2), bool), ["a", "b"], folds=4), "at most the poses"),
])
def test_bad_selector_input_is_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_the_random_split_shares_no_pose_and_keeps_every_cells_share():
    split = benchmark_split(1 / 3, seed=0)
    for key in cells():
        everything = np.concatenate([benchmark_grid(*key, s) for s in ("test", "selection")])
        chosen, rest = split["selection"][key], split["test"][key]
        assert len(chosen) + len(rest) == len(everything)
        assert not {tuple(p) for p in np.round(chosen, 9)} & {tuple(p) for p in np.round(rest, 9)}
        assert abs(len(chosen) - len(everything) / 3) <= 1
    assert sum(len(v) for v in split["test"].values()) >= 600
    other = benchmark_split(1 / 3, seed=1)
    assert any(not np.array_equal(other["test"][k], split["test"][k]) for k in cells())
    assert set(PLACEMENTS) == {p for _, p in split["test"]}
