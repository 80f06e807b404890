"""Argument checks that every layer shares: whole numbers and data arrays, with errors that name
the argument and say what was expected."""

from __future__ import annotations

import functools
import math
import os
import re
import stat
import warnings
from typing import TypeVar, cast
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InvalidInput, MissingFile

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


@dataclass(frozen=True)
class Bounds:
    """The range a numeric setting of a value must lie in (`check_fields`).

    Attributes:
        low: the least value.
        high: the largest finite value.
        above_low: the value must be greater than `low`, not equal to it.
        whole: the value must be a whole number.
        infinite: +inf is taken too (e.g. 'no limit').
        unit: the unit, for the message ('s', 'N', 'm').
    """

    low: float = 0.0
    high: float = math.inf
    above_low: bool = False
    whole: bool = False
    infinite: bool = False
    unit: str = ""

    def describe(self) -> str:
        """The range in words.

        Returns:
            E.g. 'a finite number > 0 and at most 60 s (or inf)'.
        """
        kind = "a whole number" if self.whole else "a finite number"
        text = f"{kind} {'>' if self.above_low else '>='} {self.low:g}"
        if math.isfinite(self.high):
            text += f" and at most {self.high:g}"
        return text + (f" {self.unit}" if self.unit else "") + (" (or inf)" if self.infinite else "")

    def holds(self, value: object) -> bool:
        """Whether `value` is a number in this range (a bool is not a number here; a whole number must be an int).

        Args:
            value: the value given.

        Returns:
            True where it lies in the range.
        """
        if isinstance(value, bool) or not isinstance(value, (int, np.integer) if self.whole
                                                     else (int, float, np.integer, np.floating)):
            return False
        if self.infinite and value == math.inf:
            return True
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an int beyond any float (10 ** 400)
            return False
        if not finite or value < self.low or (self.above_low and value == self.low) or value > self.high:
            return False
        return True


def check_number(value: object, name: str, bounds: Bounds) -> float:
    """`value` as a number in `bounds`; an error naming `name` and the range otherwise.

    Args:
        value: the value given.
        name: the setting's name, for the message ('JudgingRules.hold_seconds').
        bounds: its range.

    Returns:
        The value (an int where `bounds.whole`).

    Raises:
        InvalidInput: not a number in the range (NaN, a bool, a string, out of range).
    """
    if not bounds.holds(value):
        raise InvalidInput(f"{name} must be {bounds.describe()}, got {value!r}")
    return int(cast(float, value)) if bounds.whole else value  # type: ignore[return-value]


def check_fields(value: object, numbers: Mapping[str, Bounds], flags: Iterable[str] = ()) -> None:
    """The one check of a configuring value's fields, called from its `__post_init__` (so `dataclasses.replace`
    checks too): each numeric field within its bounds, each flag True or False; the message names the class, the
    field and its range.

    Args:
        value: the value (a dataclass instance).
        numbers: its numeric fields and their bounds.
        flags: its on/off fields.

    Raises:
        InvalidInput: the first field that is out of its range.
    """
    owner = type(value).__name__
    for field_name, bounds in numbers.items():
        check_number(getattr(value, field_name), f"{owner}.{field_name}", bounds)
    for field_name in flags:
        if not isinstance(getattr(value, field_name), (bool, np.bool_)):
            raise InvalidInput(f"{owner}.{field_name} must be True or False, got {getattr(value, field_name)!r}")


def check_directions(value: object, name: str) -> tuple[tuple[float, float, float], ...]:
    """Disturbance directions: at least one, each three finite numbers of unit length (within 1e-6).

    Args:
        value: the directions given (a sequence of 3-vectors).
        name: the setting's name, for the message.

    Returns:
        The directions as a tuple of float triples.

    Raises:
        InvalidInput: none given, a direction not of three numbers, or not of unit length.
    """
    try:
        rows = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be unit 3-vectors, got {value!r}") from None
    if rows.ndim != 2 or rows.shape[1] != 3 or len(rows) == 0:
        raise InvalidInput(f"{name} must hold at least one direction of three numbers (k, 3), got shape {rows.shape}: "
                           "a test with no direction tests nothing")
    length = np.linalg.norm(rows, axis=1)
    if not np.all(np.isfinite(rows)) or np.any(np.abs(length - 1.0) > 1e-6):
        raise InvalidInput(f"{name} must be unit vectors (length 1), got lengths {np.round(length, 6).tolist()}")
    return tuple((float(row[0]), float(row[1]), float(row[2])) for row in rows)


#: a value checked against choices, returned as it is
Chosen = TypeVar("Chosen")


def check_choice(value: Chosen, choices: Iterable[object], name: str, also: str = "") -> Chosen:
    """`value` when it is one of `choices`; an error naming `name`, the choices and what was given otherwise.

    Args:
        value: the value given.
        choices: the values allowed (a registry's keys, a tuple of names).
        name: the argument's name, for the message (e.g. 'GeneratorParams.mode').
        also: what else is allowed, said after the choices (e.g. 'or a Protocol'), checked by the caller.

    Returns:
        The value.

    Raises:
        InvalidInput: not one of them.
    """
    allowed = tuple(choices)
    try:
        found = value in allowed
    except (TypeError, ValueError):  # an unhashable or incomparable value (an array) is none of them
        found = False
    if not found:
        raise InvalidInput(f"{name} must be one of {allowed}{' ' + also if also else ''}, got {value!r}")
    return value


def check_data(X: object, dim: int, name: str = "X") -> np.ndarray:
    """X as a float (n, dim) array with n >= 1 and only finite values of magnitude at most
    MAX_ABS_VALUE; errors name the bad row."""
    given = np.asarray(X)
    if given.dtype.kind not in "iuf":  # bool, complex (its imaginary part was dropped), strings, objects
        raise InvalidInput(f"{name} must hold real numbers (integers or floats), got an array of {given.dtype}")
    data = given.astype(float, copy=False)
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


def check_input_file(path: object, name: str) -> Path:
    """The absolute path of a file to read, refused unless it is an existing regular file (a directory, a FIFO,
    a device such as /dev/zero or a symlink loop are named as what they are, not as a missing file).

    Args:
        path: the path given.
        name: the argument's name, for the message.

    Returns:
        The resolved path.

    Raises:
        InvalidInput: not a path, a symlink loop, or not a regular file.
        MissingFile: there is no such file (an `InvalidInput` and a `FileNotFoundError`).
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InvalidInput(f"{name} must be the path of a file, got {path!r}")
    if "\x00" in str(path):
        raise InvalidInput(f"{name} must be the path of a file, got one with a NUL byte: {str(path)!r}")
    try:
        resolved = Path(path).expanduser().resolve()
        mode = resolved.stat().st_mode
    except FileNotFoundError:
        raise MissingFile(f"{name}: no such file: {path}", str(path)) from None
    except (OSError, RuntimeError) as error:  # a symlink loop (RuntimeError before Python 3.13), no permission
        raise InvalidInput(f"{name}: cannot read {path}: {getattr(error, 'strerror', None) or error}") from None
    if not stat.S_ISREG(mode):
        kind = ("a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a regular file")
        raise InvalidInput(f"{name}: {path} is {kind}, not a file")
    return resolved


#: a name that becomes part of a file name (a benchmark label, a method, an object): letters, digits and
#: `_ . + -`, starting with a letter or digit, at most 100 characters; no path separator, no `..`, no glob
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}")


def check_name(value: object, name: str) -> str:
    """A name that becomes part of a file name, refused unless it matches `SAFE_NAME` without `..`.

    Args:
        value: the name given.
        name: the argument's name, for the message.

    Returns:
        The name.

    Raises:
        InvalidInput: not such a name (the message says what is allowed).
    """
    if not isinstance(value, str) or not SAFE_NAME.fullmatch(value) or ".." in value:
        raise InvalidInput(f"{name} becomes part of a file name: it must be 1-100 letters, digits and _ . + - "
                           f"starting with a letter or digit (no '/', no '..', no '*'), got {value!r}")
    return value


def file_in(folder: str | os.PathLike, file_name: str, name: str) -> Path:
    """The path of `file_name` in `folder`, refused unless it stays inside the folder.

    Args:
        folder: the store.
        file_name: a file name made of checked names (`check_name`).
        name: the argument the file name comes from, for the message.

    Returns:
        folder / file_name.

    Raises:
        InvalidInput: the path would leave the folder.
    """
    path = Path(folder) / file_name
    if path.resolve().parent != Path(folder).resolve():
        raise InvalidInput(f"{name} would put {file_name!r} outside its store {folder}")
    return path


#: the values an on/off environment variable of the library takes
_ON, _OFF = ("1", "true", "yes", "on"), ("0", "false", "no", "off")


@functools.cache
def env_switch(name: str, default: bool = True) -> bool:
    """An on/off environment variable (`GRASPMANIFOLD_PROGRESS`, `GRASPMANIFOLD_COMPILED`), read once per process:
    1/true/yes/on or 0/false/no/off, any case; unset or empty gives `default`, and any other value gives it too,
    with one warning.

    Args:
        name: the variable.
        default: its value when unset.

    Returns:
        The switch.
    """
    value = os.environ.get(name, "").strip().lower()
    if value in _ON or value in _OFF:
        return value in _ON
    if value:
        warnings.warn(f"{name}={os.environ[name]!r} is neither on ({', '.join(_ON)}) nor off ({', '.join(_OFF)}): "
                      f"taken as {'on' if default else 'off'}", stacklevel=2)
    return default
