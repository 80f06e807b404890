"""Argument checks that every layer shares: whole numbers and data arrays, with errors that name
the argument and say what was expected."""

from __future__ import annotations

import numpy as np

from .errors import InvalidInput

#: the largest magnitude accepted in a data array: the SOM's batch map scores in float32, whose
#: squares overflow near 1e19; anything this large is a unit error rather than a posture
MAX_ABS_VALUE = 1e15


def check_int(value: object, name: str, low: int = 1, high: int | None = None) -> int:
    """`value` as an int in [low, high] (no bool, no float); ValueError naming `name` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        expected = (f"a whole number in {low} ... {high}" if high is not None
                    else "a positive whole number" if low == 1 else f"a whole number >= {low}")
        raise InvalidInput(f"{name} must be {expected}, got {value!r}")
    return int(value)


def check_data(X: object, dim: int, name: str = "X") -> np.ndarray:
    """X as a float (n, dim) array with n >= 1 and only finite values of magnitude at most
    MAX_ABS_VALUE; errors name the bad row."""
    data = np.asarray(X, dtype=float)
    if data.ndim != 2 or data.shape[1] != dim or len(data) == 0:
        raise InvalidInput(f"{name} must have shape (n, {dim}) with n >= 1, got {data.shape}")
    finite = np.isfinite(data).all(axis=1)
    if not finite.all():
        row = int(np.flatnonzero(~finite)[0])
        raise InvalidInput(f"{name} row {row} has non-finite values: {data[row].tolist()}")
    huge = (np.abs(data) > MAX_ABS_VALUE).any(axis=1)
    if huge.any():
        row = int(np.flatnonzero(huge)[0])
        raise InvalidInput(f"{name} row {row} has values beyond +-{MAX_ABS_VALUE:g}: {data[row].tolist()}")
    return np.ascontiguousarray(data)
