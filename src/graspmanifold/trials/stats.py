"""Statistics for comparing grasp methods: Wilson intervals for rates, McNemar's test for paired
outcomes, Holm's correction for a family of tests, and the headroom of a benchmark.

Two methods evaluated on the same poses give paired outcomes; what tells them apart is the number
of poses where exactly one of them succeeds (b: only the first, c: only the second). McNemar's
exact test asks whether b and c could come from a fair coin (b ~ Binomial(b + c, 1/2)). A family of
such tests read together is corrected with Holm's step-down method (`holm`). Before methods are
compared on a benchmark, `headroom` says how much any choice among several strategies could gain
there: the per-pose oracle (a pose counts as held when any strategy holds it) against the best
single strategy, and beside it the chance oracle over as many noisy reruns of that one strategy (the part
of the headroom that noise alone gives). `stratified_split` draws the random selection and test splits such
a study tunes and tests on.

Trials of one plan are not independent (a plan that one method cannot execute fails it at every displacement), so
McNemar's pairs overstate what many trials of few plans show. `cluster_bootstrap` resamples whole clusters (plans,
their trials kept together) within strata (seeds); `bootstrap_difference` and `headroom_share` read a paired
difference and the share of a ceiling's headroom over a floor from its replicates, with percentile intervals.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.stats import binomtest, norm

from ..base.errors import InvalidInput
from ..base.validation import check_int


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval (low, high) for a rate of `successes` in `trials` (Wilson 1927).

    Unlike the normal approximation it stays inside [0, 1] and behaves at 0 and n successes.
    No trials give (0, 1): nothing is known.

    Args:
        successes: k >= 0.
        trials: n >= k.
        confidence: the interval's coverage, in (0, 1).

    Returns:
        (low, high), rates in [0, 1].
    """
    k, n = check_int(successes, "successes", low=0), check_int(trials, "trials", low=0)
    if k > n:
        raise InvalidInput(f"successes ({k}) must not exceed trials ({n})")
    if not 0.0 < confidence < 1.0:
        raise InvalidInput(f"confidence must be in (0, 1), got {confidence!r}")
    if n == 0:
        return 0.0, 1.0
    z = float(norm.ppf(0.5 + confidence / 2))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class PairedComparison:
    """Method A against method B on the same n poses: the counts, McNemar's p, the difference of the rates and its
    interval (`difference_interval`); `str()` says them in a line ('+6.7 pts [-2.9, +16.0] on 30 paired poses (+3 /
    -1, McNemar p = 0.62)')."""

    n: int
    both: int  # poses where both succeed
    only_a: int  # b of McNemar's table
    only_b: int  # c
    neither: int
    p_value: float  # McNemar's exact two-sided test

    @property
    def difference(self) -> float:
        """Rate of A minus rate of B."""
        return (self.only_a - self.only_b) / self.n if self.n else 0.0

    def difference_interval(self, confidence: float = 0.95) -> tuple[float, float]:
        """The interval of the difference of the paired rates, A's minus B's: Newcombe's hybrid score interval for
        paired proportions (his method 10, Stat. Med. 17:2635, 1998), from the two rates' Wilson intervals and the
        correlation of the pairs; it stays inside [-1, 1] and behaves where a rate is 0 or 1.

        Args:
            confidence: the interval's coverage, in (0, 1).

        Returns:
            (low, high), differences of rates in [-1, 1]; (-1, 1) with no pairs.
        """
        n, a, b, c, d = self.n, self.both, self.only_a, self.only_b, self.neither
        if n == 0:
            return -1.0, 1.0
        p1, p2 = (a + b) / n, (a + c) / n
        (l1, u1), (l2, u2) = wilson_interval(a + b, n, confidence), wilson_interval(a + c, n, confidence)
        spread = (a + b) * (c + d) * (a + c) * (b + d)
        phi = (a * d - b * c) / math.sqrt(spread) if spread else 0.0
        below = math.sqrt(max(0.0, (p1 - l1) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2))
        above = math.sqrt(max(0.0, (u1 - p1) ** 2 - 2 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2) ** 2))
        return max(-1.0, p1 - p2 - below), min(1.0, p1 - p2 + above)

    def __str__(self) -> str:
        low, high = self.difference_interval()
        return (f"{100 * self.difference:+.1f} pts [{100 * low:+.1f}, {100 * high:+.1f}] on {self.n} paired poses "
                f"(+{self.only_a} / -{self.only_b}, McNemar p = {self.p_value:.2g})")

    def verdict(self, alpha: float = 0.05) -> str:
        """'better', 'worse' or 'no difference' (A against B, at level alpha)."""
        if self.p_value >= alpha or self.only_a == self.only_b:
            return "no difference"
        return "better" if self.only_a > self.only_b else "worse"


def mcnemar(outcomes_a: object, outcomes_b: object, valid: object | None = None) -> PairedComparison:
    """McNemar's exact test on paired boolean outcomes (the same poses, in the same order): the one paired
    comparison of the library.

    Args:
        outcomes_a: success per pose of the first method, bool (n,).
        outcomes_b: of the second, on the same poses.
        valid: the poses to pair, bool (n,) (those where both trials' physics held: `a.valid & b.valid`);
            None: all.

    Returns:
        The `PairedComparison`: both, only a, only b, neither, and the exact two-sided p-value.
    """
    a = np.asarray(outcomes_a)
    b = np.asarray(outcomes_b)
    if a.ndim != 1 or a.shape != b.shape:
        raise InvalidInput(f"outcomes_a and outcomes_b must be 1-D and of one length, got {a.shape} and {b.shape}")
    if a.dtype != bool or b.dtype != bool:
        raise InvalidInput("outcomes_a and outcomes_b must be boolean arrays (success per pose)")
    if valid is not None:
        keep = np.asarray(valid)
        if keep.shape != a.shape or keep.dtype != bool:
            raise InvalidInput(f"valid must be a boolean array of the outcomes' shape {a.shape}, got {keep.dtype} "
                               f"{keep.shape}")
        a, b = a[keep], b[keep]
    only_a, only_b = int(np.sum(a & ~b)), int(np.sum(~a & b))
    discordant = only_a + only_b
    p = 1.0 if discordant == 0 else float(binomtest(only_a, discordant, 0.5).pvalue)
    return PairedComparison(len(a), int(np.sum(a & b)), only_a, only_b, int(np.sum(~a & ~b)), min(1.0, p))


def rate_text(successes: int, trials: int) -> str:
    """'72 % [64, 79]': the rate and its 95 % Wilson interval, in percent."""
    low, high = wilson_interval(successes, trials)
    if trials == 0:
        return "n/a"
    return f"{100 * successes / trials:.0f} % [{100 * low:.0f}, {100 * high:.0f}]"


def holm(p_values: object) -> np.ndarray:
    """Holm's step-down adjusted p-values (Holm 1979), in the order given.

    With the m p-values sorted, p(1) <= ... <= p(m), the adjusted value of p(i) is
    max over j <= i of min(1, (m - j + 1) p(j)); a test is significant at level alpha after the
    correction when its adjusted value is below alpha. The family-wise error rate stays at most
    alpha, whatever the dependence between the tests.

    Args:
        p_values: the family's p-values, each in [0, 1].

    Returns:
        The adjusted p-values (m,), float, in the order of `p_values`.
    """
    p = np.asarray(p_values, dtype=float)
    if p.ndim != 1:
        raise InvalidInput(f"p_values must be a 1-D sequence of p-values, got shape {p.shape}")
    if not np.all(np.isfinite(p)) or np.any((p < 0) | (p > 1)):
        raise InvalidInput(f"p_values must lie in [0, 1], got {p.tolist()}")
    m = len(p)
    order = np.argsort(p, kind="stable")
    stepped = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adjusted = np.empty(m)
    adjusted[order] = np.maximum.accumulate(stepped)
    return adjusted


#: A benchmark whose pooled headroom is below this cannot show a recall effect (issue 23): any
#: method that chooses among the strategies could gain at most this much over the best of them.
MIN_HEADROOM = 0.15
#: The gate when the chance oracle is measured (issue 38): the headroom beyond what k noisy reruns of the
#: best strategy give (five draws of noise alone gave 6.6 points on the benchmark of issue 23).
MIN_HEADROOM_BEYOND_CHANCE = 0.10


@dataclass(frozen=True)
class Headroom:
    """How much choosing among strategies per pose could gain on a benchmark (see `headroom`)."""

    n: int  # poses (valid for every strategy)
    rates: dict[str, float]  # each strategy's success rate
    best: str  # the best single strategy
    oracle: int  # poses some strategy succeeds on
    best_successes: int
    gain: int  # poses the best strategy fails on and another succeeds on (oracle - best)
    neither: int  # poses no strategy succeeds on
    chance_oracle: int | None = None  # poses some of k runs of the best strategy succeeds on (None: not measured)

    @property
    def oracle_rate(self) -> float:
        return self.oracle / self.n if self.n else float("nan")

    @property
    def best_rate(self) -> float:
        return self.best_successes / self.n if self.n else float("nan")

    @property
    def headroom(self) -> float:
        """Oracle rate minus the best strategy's rate."""
        return self.gain / self.n if self.n else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        """95 % Wilson interval of the headroom: it is the share of poses the oracle adds, a rate itself."""
        return wilson_interval(self.gain, self.n)

    @property
    def chance(self) -> float:
        """The headroom that noise alone gives: the chance oracle's rate minus the best strategy's (NaN when the
        reruns were not given)."""
        if self.chance_oracle is None or not self.n:
            return float("nan")
        return (self.chance_oracle - self.best_successes) / self.n

    @property
    def beyond_chance(self) -> float:
        """The headroom less its chance part (NaN when the reruns were not given)."""
        return self.headroom - self.chance

    @property
    def sufficient(self) -> bool:
        """The benchmark can show a recall effect: a headroom beyond chance of at least
        MIN_HEADROOM_BEYOND_CHANCE where the chance oracle was measured, else (an older gate, which chance
        inflates) a headroom of at least MIN_HEADROOM."""
        if self.chance_oracle is not None:
            return self.n > 0 and self.beyond_chance >= MIN_HEADROOM_BEYOND_CHANCE
        return self.n > 0 and self.headroom >= MIN_HEADROOM

    def text(self) -> str:
        """'oracle 80 % [74, 85] vs best (none) 62 % [55, 68]: headroom 18 % [14, 24] (n = 200)', and the chance
        oracle where it was measured."""
        text = (f"oracle {rate_text(self.oracle, self.n)} vs best ({self.best}) "
                f"{rate_text(self.best_successes, self.n)}: headroom {rate_text(self.gain, self.n)} (n = {self.n})")
        if self.chance_oracle is not None:
            text += (f"; chance oracle over {len(self.rates)} runs of {self.best} "
                     f"{rate_text(self.chance_oracle, self.n)}: {100 * self.beyond_chance:.1f} points beyond chance")
        return text


def headroom(outcomes: Mapping[str, object], valid: Mapping[str, object] | None = None,
             reruns: Sequence[object] | None = None) -> Headroom:
    """The headroom of a benchmark: the per-pose oracle over several strategies against the best one.

    The oracle counts a pose as a success when any strategy succeeds there; the best strategy is the
    one with the most successes (the first of them on a tie, in the order given). The difference is
    the most that any method choosing among these strategies per pose could gain over always using
    the best of them (part of it may be chance: a pose that two runs of one strategy would split).

    Args:
        outcomes: strategy name -> success per pose (bool, the same poses in the same order).
        valid: strategy name -> whether that trial's physics worked (bool per pose); poses invalid for
            any strategy are left out, as in a paired comparison. None: every trial is valid.
        reruns: noisy reruns (e.g. with a jittered pose) of the best strategy, success per pose, one fewer
            than there are strategies: the chance oracle is over the best strategy's own run and these, as
            many runs as strategies. None: the chance oracle is not measured.

    Returns:
        The `Headroom` (counts, rates, the best strategy and, with reruns, the chance oracle).
    """
    if not outcomes:
        raise InvalidInput("outcomes must name at least one strategy")
    names = list(outcomes)
    table = [np.asarray(outcomes[name]) for name in names]
    for name, column in zip(names, table):
        if column.ndim != 1 or column.dtype != bool:
            raise InvalidInput(f"outcomes[{name!r}] must be a 1-D boolean array (success per pose), "
                             f"got dtype {column.dtype} and shape {column.shape}")
        if len(column) != len(table[0]):
            raise InvalidInput(f"outcomes must all cover the same poses: {names[0]!r} has {len(table[0])}, "
                             f"{name!r} has {len(column)}")
    keep = np.ones(len(table[0]), dtype=bool)
    for name, flags in (valid or {}).items():
        if name not in outcomes:
            raise InvalidInput(f"valid names strategy {name!r}, which outcomes does not have ({names})")
        flags = np.asarray(flags)
        if flags.dtype != bool or flags.shape != keep.shape:
            raise InvalidInput(f"valid[{name!r}] must be a boolean array of {len(keep)} poses")
        keep &= flags
    success = np.column_stack(table)[keep]
    counts = success.sum(axis=0)
    best = int(np.argmax(counts))
    oracle = int(success.any(axis=1).sum())
    n = int(keep.sum())
    chance = None
    if reruns is not None:
        if len(reruns) != len(names) - 1:
            raise InvalidInput(f"reruns must hold {len(names) - 1} runs of the best strategy (one fewer than the "
                               f"{len(names)} strategies), got {len(reruns)}")
        runs = [np.asarray(run) for run in reruns]
        for k, run in enumerate(runs):
            if run.dtype != bool or run.shape != keep.shape:
                raise InvalidInput(f"reruns[{k}] must be a boolean array of {len(keep)} poses, got dtype {run.dtype} "
                                   f"and shape {run.shape}")
        chance = int(np.column_stack([success[:, best], *(run[keep] for run in runs)]).any(axis=1).sum())
    return Headroom(n=n, rates={name: (int(c) / n if n else float("nan")) for name, c in zip(names, counts)},
                    best=names[best], oracle=oracle, best_successes=int(counts[best]),
                    gain=oracle - int(counts[best]), neither=n - oracle, chance_oracle=chance)


def stratified_split(strata: Sequence[Hashable], selection: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random split of poses into a selection set (to fix controls and tune on) and a test set (touched once),
    stratified: each stratum (an object and placement, say) is split in the same proportion.

    Args:
        strata: each pose's stratum (any hashable label, e.g. ``("pen", "fingertips")``).
        selection: the share of each stratum that goes to the selection set, in (0, 1); rounded per stratum.
        seed: the random seed; the same seed gives the same split.

    Returns:
        (selection, test): sorted pose indices; together every pose once, sharing none.
    """
    seed = check_int(seed, "seed", low=0)
    if not 0.0 < float(selection) < 1.0:
        raise InvalidInput(f"selection must be a share in (0, 1), got {selection!r}")
    labels = list(strata)
    rng = np.random.default_rng(seed)
    chosen = []
    for stratum in dict.fromkeys(labels):  # in order of first appearance: the split does not depend on hashing
        members = np.array([i for i, label in enumerate(labels) if label == stratum])
        chosen.append(rng.permutation(members)[: round(selection * len(members))])
    picked = np.sort(np.concatenate(chosen)).astype(np.int64) if chosen else np.zeros(0, dtype=np.int64)
    return picked, np.setdiff1d(np.arange(len(labels)), picked)


#: bootstrap replicates by default (`cluster_bootstrap`)
BOOTSTRAP_REPLICATES = 2000


def cluster_bootstrap(outcomes: object, clusters: Sequence[Hashable], strata: Sequence[Hashable] | None = None,
                      replicates: int = BOOTSTRAP_REPLICATES, seed: int = 0) -> np.ndarray:
    """Bootstrap replicates of several arms' success rates on the same trials, resampling whole clusters (a plan's
    trials together) with replacement within each stratum (a seed's plans), as many as the stratum has.

    Args:
        outcomes: (n, m) success per trial (bool or 0/1) of m arms, the same trials in the same order.
        clusters: (n,) each trial's cluster (any hashable label, a plan's).
        strata: (n,) each trial's stratum (a cluster lies in one); None: one stratum.
        replicates: bootstrap replicates, >= 1.
        seed: seeds the resampling; the same seed gives the same replicates.

    Returns:
        (replicates, m) the arms' rates in each replicate (trials weighted by how often their cluster was drawn).
    """
    table = np.asarray(outcomes)
    if table.ndim != 2 or not len(table):
        raise InvalidInput(f"outcomes must be an (n, m) table of successes with n >= 1, got shape {table.shape}")
    if table.dtype != bool and not np.isin(table, (0, 1)).all():
        raise InvalidInput("outcomes must be successes: booleans or 0/1")
    labels = list(clusters)
    groups = [0] * len(labels) if strata is None else list(strata)
    if len(labels) != len(table) or len(groups) != len(table):
        raise InvalidInput(f"clusters and strata must give one label per trial ({len(table)}), got {len(labels)} and "
                           f"{len(groups)}")
    replicates, seed = check_int(replicates, "replicates", low=1), check_int(seed, "seed", low=0)
    index = {label: k for k, label in enumerate(dict.fromkeys(labels))}
    of = np.array([index[label] for label in labels])
    stratum_of: dict[Hashable, Hashable] = {}
    for label, stratum in zip(labels, groups):
        if stratum_of.setdefault(label, stratum) != stratum:
            raise InvalidInput(f"cluster {label!r} lies in two strata ({stratum_of[label]!r} and {stratum!r})")
    sums = np.zeros((len(index), table.shape[1]))
    np.add.at(sums, of, table.astype(float))
    sizes = np.bincount(of, minlength=len(index)).astype(float)
    rng = np.random.default_rng(seed)
    draws = np.zeros((replicates, len(index)))
    for stratum in dict.fromkeys(stratum_of.values()):  # in order of first appearance: no hashing in the result
        members = np.array([index[label] for label, s in stratum_of.items() if s == stratum])
        draws[:, members] = rng.multinomial(len(members), np.full(len(members), 1 / len(members)), replicates)
    return (draws @ sums) / (draws @ sizes)[:, None]


def percentile_interval(replicates: object, confidence: float = 0.95) -> tuple[float, float]:
    """The percentile interval of bootstrap replicates (NaN replicates, where a statistic was undefined, left out).

    Args:
        replicates: (B,) a statistic's replicates.
        confidence: the interval's coverage, in (0, 1).

    Returns:
        (low, high); (NaN, NaN) where no replicate is defined.
    """
    if not 0.0 < confidence < 1.0:
        raise InvalidInput(f"confidence must be in (0, 1), got {confidence!r}")
    values = np.asarray(replicates, dtype=float)
    values = values[np.isfinite(values)]
    if not len(values):
        return float("nan"), float("nan")
    low, high = np.quantile(values, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(low), float(high)


@dataclass(frozen=True)
class ClusteredEstimate:
    """A statistic of clustered trials with its cluster-bootstrap interval (`bootstrap_difference`,
    `headroom_share`); `str()` says it in a line ('+6.7 pts [-2.9, +16.0], 630 trials of 90 plans')."""

    value: float
    low: float
    high: float
    trials: int
    clusters: int
    unit: str = "pts"  # 'pts': a difference of rates, shown x100; '%': a share, shown x100

    def __str__(self) -> str:
        sign = "+" if self.unit == "pts" else ""
        return (f"{100 * self.value:{sign}.1f} {self.unit} [{100 * self.low:{sign}.1f}, {100 * self.high:{sign}.1f}], "
                f"{self.trials} trials of {self.clusters} plans")

    def to_dict(self) -> dict:
        """Plain values (a study's JSON)."""
        return {"value": self.value, "low": self.low, "high": self.high, "trials": self.trials,
                "clusters": self.clusters, "unit": self.unit}


def _paired(**columns: object) -> np.ndarray:
    """Outcome columns of the same trials side by side, (n, k): each one flat and as long as the others."""
    arrays = {name: np.asarray(column) for name, column in columns.items()}
    lengths = {name: array.shape for name, array in arrays.items()}
    if any(array.ndim != 1 for array in arrays.values()) or len({shape for shape in lengths.values()}) != 1:
        raise InvalidInput(f"{', '.join(arrays)} must be outcomes of the same trials, one flat array each of one "
                           f"length, got shapes {', '.join(f'{name} {shape}' for name, shape in lengths.items())}")
    return np.column_stack(list(arrays.values()))


def bootstrap_difference(outcomes_a: object, outcomes_b: object, clusters: Sequence[Hashable],
                         strata: Sequence[Hashable] | None = None, replicates: int = BOOTSTRAP_REPLICATES,
                         seed: int = 0, confidence: float = 0.95) -> ClusteredEstimate:
    """A's rate minus B's on the same trials, with the cluster bootstrap's percentile interval (`cluster_bootstrap`).

    Args:
        outcomes_a: (n,) success per trial of the first arm (bool).
        outcomes_b: of the second, on the same trials.
        clusters: (n,) each trial's cluster (`cluster_bootstrap`).
        strata: (n,) each trial's stratum, or None.
        replicates: bootstrap replicates.
        seed: seeds the resampling.
        confidence: the interval's coverage.

    Returns:
        The `ClusteredEstimate` of the difference (rates, not points: 0.1 is ten points).
    """
    table = _paired(outcomes_a=outcomes_a, outcomes_b=outcomes_b)
    rates = cluster_bootstrap(table, clusters, strata, replicates, seed)
    low, high = percentile_interval(rates[:, 0] - rates[:, 1], confidence)
    value = float(table[:, 0].mean() - table[:, 1].mean())
    return ClusteredEstimate(value, low, high, len(table), len(set(clusters)))


def headroom_share(arm: object, floor: object, ceiling: object, clusters: Sequence[Hashable],
                   strata: Sequence[Hashable] | None = None, replicates: int = BOOTSTRAP_REPLICATES, seed: int = 0,
                   confidence: float = 0.95) -> ClusteredEstimate:
    """The share of a ceiling's headroom over a floor that an arm takes, (arm - floor) / (ceiling - floor) in rates
    on the same trials (the open loop the floor, an oracle the ceiling), with the cluster bootstrap's interval
    (replicates where the ceiling does not rise above the floor are left out).

    Args:
        arm: (n,) success per trial of the arm (bool).
        floor: of the floor (the open loop), on the same trials.
        ceiling: of the ceiling (an oracle), on the same trials.
        clusters: (n,) each trial's cluster (`cluster_bootstrap`).
        strata: (n,) each trial's stratum, or None.
        replicates: bootstrap replicates.
        seed: seeds the resampling.
        confidence: the interval's coverage.

    Returns:
        The `ClusteredEstimate` of the share (NaN where the ceiling is no higher than the floor).
    """
    table = _paired(arm=arm, floor=floor, ceiling=ceiling)
    rates = cluster_bootstrap(table, clusters, strata, replicates, seed)

    def share(r: np.ndarray) -> np.ndarray:
        room = r[..., 2] - r[..., 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(room > 0, (r[..., 0] - r[..., 1]) / np.where(room > 0, room, 1.0), np.nan)

    low, high = percentile_interval(share(rates), confidence)
    return ClusteredEstimate(float(share(table.mean(axis=0))), low, high, len(table), len(set(clusters)), "%")


class PairedTrials(Protocol):
    """What `compare` reads of a method's trials (`evaluation.EvaluationResult` has it): its label, its trials (their
    grid poses), which are valid, and an outcome per trial."""

    method: str
    trials: list

    @property
    def valid(self) -> np.ndarray:
        """(n,) bool: the trials whose physics worked."""

    def outcomes(self, measure: str = "hold") -> np.ndarray:
        """(n,) bool: each trial's outcome by the measure."""


def compare(a: PairedTrials, b: PairedTrials, measure: str = "hold") -> PairedComparison:
    """McNemar's test of method a against method b; both must have run on the same poses. Poses
    where either trial's physics failed (`Trial.valid`) are left out of the pairs.

    Args:
        a: the first method's result (an `EvaluationResult`).
        b: the second's, on the same grid poses.
        measure: 'hold' or 'force_closure'.

    Returns:
        The paired comparison (`PairedComparison`: counts, p-value, verdict).
    """
    for name, result in (("a", a), ("b", b)):
        if not all(hasattr(result, member) for member in ("method", "trials", "valid", "outcomes")):
            raise InvalidInput(f"{name} must be one method's trials (an EvaluationResult: evaluate's), got "
                               f"{type(result).__name__}")
    grid_a = np.array([t.grid_pose for t in a.trials])
    grid_b = np.array([t.grid_pose for t in b.trials])
    if grid_a.shape != grid_b.shape or not np.array_equal(grid_a, grid_b):
        raise InvalidInput(f"{a.method} and {b.method} ran on different poses; a paired comparison needs the same grid")
    return mcnemar(a.outcomes(measure), b.outcomes(measure), valid=a.valid & b.valid)
