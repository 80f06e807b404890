"""Checkpoints: one mechanism for every long job that resumes after an interruption (the generator's
jobs, the evaluation's chunks of trials, the stages of `reproduce`).

A job's stored results are filed under a key (`result_key`) made of its explicit configuration, the
bytes of its inputs and the library's code fingerprint, never of a pickle: a pickled SOM changes after a
single `best_match` (its search cache goes with it), so a key made of one threw valid checkpoints away.
A result filed under another key is never reused. A `PartStore` keeps the finished parts of one job in a
folder; parts of another key, or that cannot be read, are removed, with one warning naming them (only files
named as its parts are: names are matched whole, never globbed).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import linecache
import os
import re
import secrets
import types
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Generic, TypeVar

import numpy as np

from .errors import InvalidInput
from .io import TEMPORARY_SUFFIX
from .version import code_fingerprint

Part = TypeVar("Part")

#: the names of the generator's checkpoint parts (job_<start>_<chunk>.npz) and of an evaluation's (part_<first>.npz)
JOB_PARTS = re.compile(r"job_\d{3,}_\d{4,}\.npz")
TRIAL_PARTS = re.compile(r"part_\d{5,}\.npz")


def result_key(*parts: object) -> str:
    """The key of a result: a digest of what decides it and of the code that computes it.

    Args:
        parts: the configuration (anything JSON can write: dataclasses as `asdict`), arrays (their dtype,
            shape and bytes) and input files (`Path`: their bytes).

    Returns:
        A 20-character hexadecimal key.
    """
    digest = hashlib.sha256(code_fingerprint().encode())
    for part in parts:
        if isinstance(part, Path):
            digest.update(part.read_bytes())
        elif isinstance(part, np.ndarray):
            array = np.ascontiguousarray(part)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        else:
            digest.update(json.dumps(part, sort_keys=True, default=str).encode())
    return digest.hexdigest()[:20]


#: the identity of each class whose source could not be read, in this process (`code_identity`)
_UNREADABLE: dict[object, str] = {}
#: a stated version of one's own code: a class attribute of a recall rule or a controller (`code_identity`)
CODE_VERSION = "version"


def code_identity(thing: object) -> str | None:
    """What identifies the code of one's own class (a recall rule, a controller) in a result's key: the version it
    states (a `version` class attribute), else a digest of its source; None for the library's own classes (the
    library's code fingerprint covers them) and for plain values.

    A class whose source cannot be read (made in a notebook cell or by `exec`) and that states no version gets a key
    that is new every run, with a warning: trials of it are never resumed, since an edit could not be told apart.

    Args:
        thing: an instance, a class or a function (a controller's factory).

    Returns:
        "version:<stated>", "source:<digest>", "unknown:<random>" or None.
    """
    cls = thing if isinstance(thing, (type, types.FunctionType)) else type(thing)
    module = getattr(cls, "__module__", "") or ""
    if module == "builtins" or module.split(".")[0] in ("graspmanifold", "numpy", "functools"):
        return None
    stated = getattr(cls, CODE_VERSION, None)
    if isinstance(stated, (str, int)) and not isinstance(stated, bool):
        return f"version:{stated}"
    try:
        linecache.checkcache(inspect.getsourcefile(cls))  # an edited and reloaded module: its source as it is now
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        if cls not in _UNREADABLE:  # one identity per class and process: a run keys its own parts alike
            warnings.warn(f"the source of {cls.__qualname__} cannot be read and it states no `{CODE_VERSION}`: its "
                          "trials will not be resumed by a later run (state one, e.g. `version = \"2\"`, to resume "
                          "them)", stacklevel=3)
            _UNREADABLE[cls] = f"unknown:{secrets.token_hex(8)}"
        return _UNREADABLE[cls]
    return "source:" + hashlib.sha256(source.encode()).hexdigest()[:16]


class PartStore(Generic[Part]):
    """The finished parts of one job in a folder, each an .npz file whose metadata holds the job's key.

    Args:
        directory: the folder (made when missing).
        key: the job's `result_key`.
        read: reads one part file: its content and its metadata (raises `ValueError` when unreadable).
    """

    def __init__(self, directory: str | os.PathLike, key: str, read: Callable[[Path], tuple[Part, dict]]):
        if not isinstance(key, str) or not key:
            raise InvalidInput(f"key must be a non-empty string, got {key!r}")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.key, self._read = key, read

    def load(self, names: str | re.Pattern, accept: Callable[[Path, Part, dict], bool] = lambda *_: True
             ) -> dict[Path, Part]:
        """The parts of this job saved earlier; every other file with a part's name (another key, unreadable,
        or one `accept` refuses) is removed, with a warning naming them. No other file is touched: a name is
        matched whole, never as a glob.

        Args:
            names: the part files' names: one file name, or a compiled pattern that the whole name must match
                (e.g. `re.compile(r"part_\\d+\\.npz")`).
            accept: whether a part of this key fits the job as it is now planned.

        Returns:
            The parts by path.
        """
        matches = names.fullmatch if isinstance(names, re.Pattern) else names.__eq__
        found: dict[Path, Part] = {}
        discarded: list[str] = []
        for path in sorted(p for p in self.directory.iterdir() if p.is_file() and matches(p.name)):
            try:
                part, meta = self._read(path)
            except (ValueError, KeyError):  # truncated, or not a part of ours
                part, meta = None, {}
            if part is not None and isinstance(meta, dict) and meta.get("key") == self.key and accept(path, part, meta):
                found[path] = part
            else:
                discarded.append(path.name)
                path.unlink()
        if discarded:
            warnings.warn(f"discarded {len(discarded)} checkpoint part(s) in {self.directory} that belong to another "
                          f"configuration or could not be read: {', '.join(discarded[:4])}"
                          f"{' ...' if len(discarded) > 4 else ''}", stacklevel=3)
        return found

    def save(self, name: str, write: Callable[[Path, dict], object], **meta: object) -> Path:
        """Save one finished part (atomically, by `write`).

        Args:
            name: its file name in the folder.
            write: writes the part to a path, with this metadata added to the file's own.
            meta: what identifies the part within the job (the key is added).

        Returns:
            The part's path.
        """
        path = self.directory / name
        write(path, {"key": self.key, **meta})
        return path


def remove_checkpoints(directory: str | os.PathLike) -> None:
    """Delete a job's checkpoint folder once its result is saved: the part files the library wrote there
    (`JOB_PARTS`, `TRIAL_PARTS`) and its temporary files, then the folder if nothing else is left in it (a
    file of the user's own is never deleted).

    Args:
        directory: the folder (nothing happens when there is none).
    """
    directory = Path(directory)
    if not directory.is_dir():
        return
    for path in directory.iterdir():
        if path.is_file() and (JOB_PARTS.fullmatch(path.name) or TRIAL_PARTS.fullmatch(path.name)
                               or path.name.endswith(TEMPORARY_SUFFIX)):
            path.unlink(missing_ok=True)
    try:
        directory.rmdir()
    except OSError:  # something else is in it
        pass
