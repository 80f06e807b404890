"""Experiment files: a frozen dataclass of settings read from TOML and written back to it.

A configuration is read with the standard library's TOML reader (`tomllib`) into the very dataclass the
code validates (`ReproduceConfig`, with its `GeneratorParams` and `ControllerParams` as tables): a key the
dataclass does not have is refused by name, a value goes through the dataclass's own checks, lists become
tuples where the field is a tuple. `to_toml` writes a configuration back, so a run can keep the one it used. A
field whose value is one of several kinds (the controller's recall rule) is written as an inline table that names
its kind (its `to_table`) and read through its `with_table`; a dataclass with `upgrade_table` reads a table of an
older form, and one with `table_paths_from` reads the file paths a table names from the file's folder (a file
moved with the files it names still finds them, from any working directory).

    [generator]            # a nested dataclass is a table
    mode = "recording"
    postures = { box = 200, cylinder = 200 }   # a dict field is an inline table
    grid = "quick"

    [controller]
    recall = { rule = "base", reach = 0.03 }   # one of several kinds: named, with its settings
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tomllib
from typing import Any, TypeVar, cast
from pathlib import Path

from .errors import InvalidInput

#: a configuration: a dataclass value (`ReproduceConfig`, `GeneratorParams`, ...)
Config = TypeVar("Config")


def _value(field_type: object, value: object) -> object:
    """A TOML value as the field wants it: lists as tuples for a tuple field (nested too)."""
    if isinstance(value, list) and "tuple" in str(field_type):
        return tuple(tuple(v) if isinstance(v, list) else v for v in value)
    return value


def apply_table(base: Config, table: dict, where: str) -> Config:
    """`base` (a dataclass) with the fields a TOML table sets; nested dataclass fields take sub-tables.

    Args:
        base: the configuration the table changes.
        table: the table ({field: value}).
        where: the table's name, for messages ('' for the top level).

    Returns:
        A new configuration, checked by its own class.
    """
    upgrade = getattr(type(base), "upgrade_table", None)  # a table of an older form, in today's
    table = upgrade(table) if upgrade is not None else table
    fields = {f.name: f for f in dataclasses.fields(cast(Any, base))}
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise InvalidInput(f"unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} in "
                           f"{'[' + where + ']' if where else 'the configuration'}; {type(base).__name__} has "
                           f"{', '.join(fields)}")
    changes = {}
    for name, value in table.items():
        current = getattr(base, name)
        if hasattr(current, "with_table") and isinstance(value, (dict, str)):  # one of several kinds, by name
            changes[name] = current.with_table(value)
        elif dataclasses.is_dataclass(current) and isinstance(value, dict):
            changes[name] = apply_table(current, value, f"{where}.{name}" if where else name)
        else:
            changes[name] = _value(fields[name].type, value)
    return cast(Config, dataclasses.replace(cast(Any, base), **changes))


def read_config(path: str | os.PathLike, base: Config) -> Config:
    """A configuration from a TOML file, over a base configuration.

    Args:
        path: the .toml file; a relative path it names is read from its folder (where the class says which
            values are paths: `table_paths_from`).
        base: the configuration its keys change (a dataclass).

    Returns:
        The configuration, validated by its class.

    Raises:
        ValueError: the file is missing or not TOML (its line named), or a key or value is refused.
    """
    path = Path(path)
    try:
        table = tomllib.loads(path.read_text())
    except OSError as error:
        raise InvalidInput(f"configuration file {path}: cannot be read ({error.strerror})") from None
    except tomllib.TOMLDecodeError as error:
        raise InvalidInput(f"configuration file {path}: not TOML ({error})") from None
    paths_from = getattr(type(base), "table_paths_from", None)
    if paths_from is not None:
        table = paths_from(table, path.resolve().parent)
    try:
        return apply_table(base, table, "")
    except (InvalidInput, TypeError) as error:
        raise InvalidInput(f"configuration file {path}: {error}") from None


def _toml_value(value: object) -> str:
    if hasattr(value, "with_table"):  # a value of one of several kinds: an inline table that names its kind
        value = cast(Any, value).to_table()
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):  # a nested value: an inline table
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else "nan"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{json.dumps(str(k))} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise InvalidInput(f"a configuration value must be a number, a string, a list or a table, got {value!r}")


def to_toml(config: object, written: dict | None = None) -> str:
    """A configuration (a dataclass, nested ones as tables) as TOML text that `read_config` reads back.

    Args:
        config: the configuration.
        written: values to write for some fields instead of the configuration's own (a file's path relative to
            the folder the text goes to, say).

    Returns:
        The text.
    """
    plain, tables = [], []
    for field in dataclasses.fields(cast(Any, config)):
        value = (written or {}).get(field.name, getattr(config, field.name))
        if dataclasses.is_dataclass(value) and not hasattr(value, "with_table"):
            tables.append(f"\n[{field.name}]\n" + "".join(
                f"{f.name} = {_toml_value(getattr(value, f.name))}\n" for f in dataclasses.fields(value)))
        else:
            plain.append(f"{field.name} = {_toml_value(value)}\n")
    return "".join(plain) + "".join(tables)
