"""Progress bars for long jobs: tqdm's, in a terminal, a log and a notebook alike.

Every long job of the library (generating postures, verifying them, training a map, evaluating a
controller, a benchmark) shows a bar by default. `show_progress(False)`, or GRASPMANIFOLD_PROGRESS=0
in the environment, turns them all off; a job's own `progress=False` turns off its bar.
"""

from __future__ import annotations

import sys
from importlib.util import find_spec

from .validation import env_switch

if find_spec("ipywidgets") is not None:  # a notebook's widget bar; without ipywidgets tqdm.auto only warns
    from tqdm.auto import tqdm
else:
    from tqdm import tqdm

_shown: bool | None = None  # set by show_progress; until then GRASPMANIFOLD_PROGRESS says


def _progress_shown() -> bool:
    return env_switch("GRASPMANIFOLD_PROGRESS") if _shown is None else _shown


def show_progress(enabled: bool) -> bool:
    """Show the progress bars of every long job (or none); returns the previous setting.

    Args:
        enabled: True to show them (the default), False to silence them all.

    Returns:
        The setting before this call.
    """
    global _shown
    previous, _shown = _progress_shown(), bool(enabled)
    return previous


def progress_bar(total: int, label: str, unit: str, *, enabled: bool | None = None) -> tqdm:
    """A bar counting `total` units of work (call `.update(n)`, then `.close()`); disabled, it costs
    next to nothing in a hot loop. Written to stderr once the job has run 2 s (a quick one shows none),
    refreshed at most every half second.

    Args:
        total: units of work.
        label: what the job is, e.g. "evaluate box / som".
        unit: what a unit is, e.g. "trials" (the rate reads "12.3 trials/s", never "s/ trials").
        enabled: show it (None: as `show_progress` says).

    Returns:
        The bar.
    """
    shown = _progress_shown() if enabled is None else bool(enabled) and _progress_shown()
    return tqdm(total=total, desc=label, unit=f" {unit}" if unit else "it", disable=not shown, file=sys.stderr,
                mininterval=0.5, smoothing=0.1, dynamic_ncols=True, leave=True, delay=2.0,
                bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}, {rate_noinv_fmt}]")
