"""Statistics for comparing grasp methods: Wilson intervals for rates, McNemar's test for paired outcomes.

Two methods evaluated on the same poses give paired outcomes; what tells them apart is the number
of poses where exactly one of them succeeds (b: only the first, c: only the second). McNemar's
exact test asks whether b and c could come from a fair coin (b ~ Binomial(b + c, 1/2)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import binomtest, norm

from .validation import check_int


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval (low, high) for a rate of `successes` in `trials` (Wilson 1927).

    Unlike the normal approximation it stays inside [0, 1] and behaves at 0 and n successes.
    No trials give (0, 1): nothing is known.
    """
    k, n = check_int(successes, "successes", low=0), check_int(trials, "trials", low=0)
    if k > n:
        raise ValueError(f"successes ({k}) must not exceed trials ({n})")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if n == 0:
        return 0.0, 1.0
    z = float(norm.ppf(0.5 + confidence / 2))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class PairedComparison:
    """Method A against method B on the same n poses."""

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

    def verdict(self, alpha: float = 0.05) -> str:
        """'better', 'worse' or 'no difference' (A against B, at level alpha)."""
        if self.p_value >= alpha or self.only_a == self.only_b:
            return "no difference"
        return "better" if self.only_a > self.only_b else "worse"


def mcnemar(outcomes_a: object, outcomes_b: object) -> PairedComparison:
    """McNemar's exact test on paired boolean outcomes (the same poses, in the same order)."""
    a = np.asarray(outcomes_a)
    b = np.asarray(outcomes_b)
    if a.ndim != 1 or a.shape != b.shape:
        raise ValueError(f"outcomes_a and outcomes_b must be 1-D and of one length, got {a.shape} and {b.shape}")
    if a.dtype != bool or b.dtype != bool:
        raise ValueError("outcomes_a and outcomes_b must be boolean arrays (success per pose)")
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
