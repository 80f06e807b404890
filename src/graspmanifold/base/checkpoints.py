"""Checkpoints: one mechanism for every long job that resumes after an interruption (the generator's
jobs, the evaluation's chunks of trials, the stages of `reproduce`).

A job's stored results are filed under a key (`result_key`) made of its explicit configuration, the
bytes of its inputs and the library's code fingerprint, never of a pickle: a pickled SOM changes after a
single `best_match` (its search cache goes with it), so a key made of one threw valid checkpoints away.
A result filed under another key is never reused. A `PartStore` keeps the finished parts of one job in a
folder; parts of another key, or that cannot be read, are removed, with one warning naming them.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Generic, TypeVar

import numpy as np

from .errors import InvalidInput
from .version import code_fingerprint

Part = TypeVar("Part")


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


class PartStore(Generic[Part]):
    """The finished parts of one job in a folder, each an .npz file whose metadata holds the job's key.

    Args:
        directory: the folder (made when missing).
        key: the job's `result_key`.
        read: reads one part file: its content and its metadata (raises `ValueError` when unreadable).
    """

    def __init__(self, directory: str | Path, key: str, read: Callable[[Path], tuple[Part, dict]]):
        if not isinstance(key, str) or not key:
            raise InvalidInput(f"key must be a non-empty string, got {key!r}")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.key, self._read = key, read

    def load(self, pattern: str, accept: Callable[[Path, Part, dict], bool] = lambda *_: True) -> dict[Path, Part]:
        """The parts of this job saved earlier; every other file matching `pattern` (another key, unreadable,
        or one `accept` refuses) is removed, with a warning naming them.

        Args:
            pattern: the part files' glob, e.g. 'part_*.npz'.
            accept: whether a part of this key fits the job as it is now planned.

        Returns:
            The parts by path.
        """
        found, discarded = {}, []
        for path in sorted(self.directory.glob(pattern)):
            try:
                part, meta = self._read(path)
            except (ValueError, KeyError):  # truncated, or not a part of ours
                part, meta = None, {}
            if isinstance(meta, dict) and meta.get("key") == self.key and accept(path, part, meta):
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
