"""Progress bars for long jobs: tqdm's, which render in a terminal, a log and a notebook alike."""

from __future__ import annotations

import sys

from tqdm.auto import tqdm


def progress_bar(total: int, label: str, unit: str, *, enabled: bool = True) -> tqdm:
    """A bar counting `total` units of work (call `.update(n)`, then `.close()`); disabled, it costs
    next to nothing in a hot loop. Written to stderr, refreshed at most every half second."""
    return tqdm(total=total, desc=label, unit=f" {unit}" if unit else "it", disable=not enabled, file=sys.stderr,
                mininterval=0.5, smoothing=0.1, dynamic_ncols=True, leave=True)
