"""Wilson intervals and McNemar's test against textbook values, and the study's verdict logic."""

import numpy as np
import pytest

from graspmanifold.base.io import markdown_row, markdown_table
from graspmanifold.studies.runner import comparison_table, holm_family
from graspmanifold.trials.stats import (
    bootstrap_difference,
    cluster_bootstrap,
    headroom,
    headroom_share,
    holm,
    mcnemar,
    rate_text,
    wilson_interval,
)
from graspmanifold.trials.experience_pays import judge_target


@pytest.mark.parametrize("k, n, low, high", [
    (81, 263, 0.2553, 0.3662),  # Newcombe (1998), Stat. Med. 17:857, Table I, method 3
    (15, 148, 0.0624, 0.1605),
    (0, 20, 0.0, 0.1611),
    (1, 29, 0.0061, 0.1718),
])
def test_wilson_interval_gives_the_textbook_values(k, n, low, high):
    assert wilson_interval(k, n) == pytest.approx((low, high), abs=1e-4)


def test_mcnemar_exact_test_on_a_hand_made_table():
    # 9 poses only A holds, 1 only B, 5 both, 3 neither: p = 2 * P(X <= 1 | X ~ Bin(10, 1/2)) = 22 / 1024
    a = np.array([True] * 9 + [False] + [True] * 5 + [False] * 3)
    b = np.array([False] * 9 + [True] + [True] * 5 + [False] * 3)
    result = mcnemar(a, b)
    assert (result.n, result.both, result.only_a, result.only_b, result.neither) == (18, 5, 9, 1, 3)
    assert result.p_value == pytest.approx(22 / 1024, rel=1e-12)
    assert result.verdict() == "better" and mcnemar(b, a).verdict() == "worse"
    assert result.difference == pytest.approx(8 / 18)
    # equal discordant counts, or none at all: no difference, p = 1
    assert mcnemar(a, a).p_value == 1.0 and mcnemar(a, a).verdict() == "no difference"
    # 6 against 1 is not significant (p = 16 / 128 = 0.125)
    six = np.array([True] * 6 + [False]), np.array([False] * 6 + [True])
    assert mcnemar(*six).p_value == pytest.approx(0.125) and mcnemar(*six).verdict() == "no difference"
    # poses where either trial's physics failed are left out of the pairs
    valid = np.array([True] * 5 + [False] * 4 + [True] * 9)
    assert mcnemar(a, b, valid=valid) == mcnemar(a[valid], b[valid]) and mcnemar(a, b, valid=valid).n == 14


@pytest.mark.parametrize("call, message", [
    (lambda: wilson_interval(5, 3), "exceed"),
    (lambda: wilson_interval(-1, 3), "successes"),
    (lambda: wilson_interval(1, 3, confidence=1.5), "confidence"),
    (lambda: mcnemar([True, False], [True]), "one length"),
    (lambda: mcnemar([1, 0], [0, 1]), "boolean"),
    (lambda: mcnemar(np.ones(2, bool), np.ones(2, bool), valid=[1, 0]), "valid must be a boolean array"),
    (lambda: markdown_table(["a", "b"], [[1, 2, 3]]), "rows must have 2 cells"),
])
def test_bad_statistics_input_raises(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_rate_text_and_the_verdict():
    assert rate_text(8, 10) == "80 % [49, 94]"
    row = {"method": "som", "control": "none_preshape", "verdict": "better", "control_rate": 0.6, "p_value": 0.01}
    rows = [{**row, "object": "box", "grid": "far"}, {**row, "object": "cylinder", "grid": "far"}]
    assert judge_target(rows).met
    assert "the strongest control (none_preshape)" in judge_target(rows).text
    assert not judge_target(rows[:1]).met  # one object is not enough
    easy = [{**r, "control_rate": 0.9} for r in rows]
    assert not judge_target(easy).met  # wins where the control already holds 90 % do not count
    lost = rows + [{**row, "object": "sphere", "grid": "paper", "verdict": "worse"}]
    verdict = judge_target(lost)
    assert not verdict.met and verdict.losses == [("sphere", "paper")]


def test_holm_gives_the_textbook_values():
    # Holm (1979), Scand. J. Statist. 6:65, by hand: sorted 0.005, 0.01, 0.03, 0.04 are multiplied by
    # 4, 3, 2, 1 (0.02, 0.03, 0.06, 0.04) and made monotone (0.02, 0.03, 0.06, 0.06)
    p = [0.01, 0.04, 0.03, 0.005]
    assert holm(p) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])  # capped at 1
    assert holm([0.02]) == pytest.approx([0.02])  # one test: no correction
    assert len(holm([])) == 0
    with pytest.raises(ValueError, match="p_values must lie in"):
        holm([0.1, 1.5])


def test_headroom_of_a_hand_made_table():
    # 10 poses, three strategies; b is the best (5 held); the oracle holds 8 (all but poses 8 and 9)
    a = np.array([1, 1, 0, 0, 0, 0, 1, 0, 0, 0], dtype=bool)
    b = np.array([1, 1, 1, 1, 1, 0, 0, 0, 0, 0], dtype=bool)
    c = np.array([0, 0, 0, 0, 0, 1, 0, 1, 0, 0], dtype=bool)
    room = headroom({"a": a, "b": b, "c": c})
    assert (room.n, room.best, room.best_successes, room.oracle, room.gain, room.neither) == (10, "b", 5, 8, 3, 2)
    assert room.headroom == pytest.approx(0.3) and room.oracle_rate == pytest.approx(0.8)
    assert room.rates == pytest.approx({"a": 0.3, "b": 0.5, "c": 0.2})
    assert room.interval == pytest.approx(wilson_interval(3, 10)) and room.sufficient
    assert room.text() == "oracle 80 % [49, 94] vs best (b) 50 % [24, 76]: headroom 30 % [11, 60] (n = 10)"
    # a pose invalid for one strategy leaves the table: pose 7 (only c held it)
    invalid = np.ones(10, dtype=bool)
    invalid[7] = False
    room = headroom({"a": a, "b": b, "c": c}, valid={"c": invalid})
    assert (room.n, room.oracle, room.gain) == (9, 7, 2)
    # one strategy alone has no headroom; a tie goes to the first named
    assert headroom({"b": b}).headroom == 0.0 and not headroom({"b": b}).sufficient
    assert headroom({"x": b, "y": b}).best == "x"
    with pytest.raises(ValueError, match="same poses"):
        headroom({"a": a, "b": b[:5]})
    with pytest.raises(ValueError, match="boolean"):
        headroom({"a": a.astype(int)})


def test_the_chance_oracle_of_a_hand_made_table():
    """Three strategies on ten poses; the chance oracle is over the best strategy's run and two noisy reruns of
    it (as many runs as strategies), and the gate reads the headroom beyond it."""
    t, f = True, False
    outcomes = {"a": np.array([t, t, t, t, t, f, f, f, f, f]),   # best: 5 of 10
                "b": np.array([t, f, f, f, f, t, t, t, f, f]),   # adds poses 5, 6, 7
                "c": np.array([f, f, f, f, f, f, f, f, t, f])}   # adds pose 8: oracle 9
    reruns = [np.array([t, t, t, t, f, t, f, f, f, f]),          # adds pose 5
              np.array([t, t, f, t, t, f, f, f, f, f])]          # adds nothing: chance oracle 6
    room = headroom(outcomes, reruns=reruns)
    assert (room.best, room.oracle, room.best_successes, room.chance_oracle) == ("a", 9, 5, 6)
    assert room.headroom == pytest.approx(0.4) and room.chance == pytest.approx(0.1)
    assert room.beyond_chance == pytest.approx(0.3) and room.sufficient
    assert "chance oracle over 3 runs of a 60 %" in room.text() and "30.0 points beyond chance" in room.text()
    noisy = headroom(outcomes, reruns=[outcomes["b"] | outcomes["a"], outcomes["c"] | outcomes["a"]])
    assert noisy.chance_oracle == 9 and noisy.beyond_chance == pytest.approx(0.0) and not noisy.sufficient
    assert np.isnan(headroom(outcomes).chance) and headroom(outcomes).chance_oracle is None
    with pytest.raises(ValueError, match="reruns must hold 2 runs of the best strategy"):
        headroom(outcomes, reruns=reruns[:1])
    with pytest.raises(ValueError, match=r"reruns\[1\] must be a boolean array of 10 poses"):
        headroom(outcomes, reruns=[reruns[0], reruns[1][:4]])


def test_stratified_splits_are_random_disjoint_and_keep_each_strata_share():
    from graspmanifold.trials.stats import stratified_split

    strata = [("pen", "palm")] * 40 + [("pen", "tips")] * 20 + [("marble", "palm")] * 10
    selection, test = stratified_split(strata, 0.3, seed=0)
    assert not set(selection) & set(test) and sorted([*selection, *test]) == list(range(70))
    assert [sum(strata[i] == s for i in selection) for s in dict.fromkeys(strata)] == [12, 6, 3]
    again, _ = stratified_split(strata, 0.3, seed=0)
    other, _ = stratified_split(strata, 0.3, seed=1)
    assert np.array_equal(again, selection) and not np.array_equal(other, selection)
    assert not set(selection) >= set(range(0, 70, 2))  # not a lattice of every other pose
    with pytest.raises(ValueError, match=r"selection must be a share in \(0, 1\)"):
        stratified_split(strata, 1.0, seed=0)


def test_one_table_writer_and_one_family_of_paired_comparisons():
    assert markdown_table(["method", "hold"], [["som", "80 %"], ["none", 0.5]]) == [
        "| method | hold |", "|---|---|", "| som | 80 % |", "| none | 0.5 |"]
    assert markdown_row(["a", 1]) == "| a | 1 |"
    a = np.array([True] * 9 + [False] + [True] * 5 + [False] * 3)
    b = np.array([False] * 9 + [True] + [True] * 5 + [False] * 3)
    rows = holm_family([("a vs b", mcnemar(a, b)), ("b vs a", mcnemar(b, a)), ("a vs a", mcnemar(a, a))], "demo")
    assert [r["p_holm"] for r in rows] == pytest.approx(list(holm([22 / 1024, 22 / 1024, 1.0])))
    assert rows[0]["family"] == "demo" and (rows[0]["only_a"], rows[0]["only_b"], rows[0]["n"]) == (9, 1, 18)
    table = comparison_table(rows, family=True)
    assert table[0] == "| family | comparison | n | + | - | difference | p | p (Holm) |"
    assert table[2] == f"| demo | a vs b | 18 | 9 | 1 | +44.4 pts | 0.0215 | {rows[0]['p_holm']:.3g} |"


def _clustered_draw(rng, clusters=40, trials=20):
    """Paired outcomes of two arms on clustered trials: each cluster (a plan) has its own rates, the population's
    difference is 0.1 (cluster effects drawn around it), trials of one cluster share their rates."""
    base = rng.uniform(0.2, 0.6, clusters)  # with delta, rates in [0, 1]: nothing clipped
    delta = rng.uniform(-0.2, 0.4, clusters)  # the population's mean difference: 0.1
    u = rng.uniform(size=(clusters, trials))
    a = u < (base + delta)[:, None]
    b = u < base[:, None]
    return a.ravel(), b.ravel(), np.repeat(np.arange(clusters), trials)


def test_the_cluster_bootstrap_covers_the_true_difference_at_about_its_nominal_rate():
    rng = np.random.default_rng(7)
    covered = naive = 0
    runs = 200
    for run in range(runs):
        a, b, clusters = _clustered_draw(rng)
        estimate = bootstrap_difference(a, b, clusters, replicates=400, seed=run)
        covered += estimate.low <= 0.1 <= estimate.high
        trials = bootstrap_difference(a, b, np.arange(len(a)), replicates=400, seed=run)  # each trial its own cluster
        naive += trials.low <= 0.1 <= trials.high
    assert 0.88 <= covered / runs <= 0.99
    assert naive / runs < 0.8  # ignoring the clusters undercovers: what the cluster bootstrap is for


def test_the_cluster_bootstrap_resamples_whole_clusters_within_strata():
    outcomes = np.array([[1, 0], [1, 0], [0, 0], [1, 1], [0, 1]], dtype=bool)
    rates = cluster_bootstrap(outcomes, ["p", "p", "q", "r", "r"], strata=[0, 0, 0, 1, 1], replicates=50, seed=3)
    assert rates.shape == (50, 2)
    # stratum 1 has one cluster (r): it is drawn in every replicate, so arm 1 always has its one success of r
    assert np.all(rates[:, 1] > 0)
    assert np.array_equal(rates, cluster_bootstrap(outcomes, ["p", "p", "q", "r", "r"], [0, 0, 0, 1, 1], 50, 3))
    with pytest.raises(ValueError, match="two strata"):
        cluster_bootstrap(outcomes, ["p", "p", "q", "r", "r"], strata=[0, 1, 0, 1, 1])
    with pytest.raises(ValueError, match="one label per trial"):
        cluster_bootstrap(outcomes, ["p", "q"])
    with pytest.raises(ValueError, match="successes"):
        cluster_bootstrap(np.full((2, 2), 0.5), ["p", "q"])


def test_the_headroom_share_is_the_arms_part_of_the_ceilings_gain_over_the_floor():
    floor = np.array([True, False, False, False] * 5)
    ceiling = np.array([True, True, True, False] * 5)
    arm = np.array([True, True, False, False] * 5)
    share = headroom_share(arm, floor, ceiling, np.repeat(np.arange(5), 4), replicates=100)
    assert share.value == pytest.approx(0.5) and share.unit == "%"
    assert share.low == pytest.approx(0.5) and share.high == pytest.approx(0.5)  # every cluster the same
    assert "50.0 % [50.0, 50.0], 20 trials of 5 plans" == str(share)
    # no headroom: undefined, not a division by zero
    assert np.isnan(headroom_share(arm, ceiling, ceiling, np.repeat(np.arange(5), 4), replicates=10).value)
