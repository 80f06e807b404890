"""The library's version, in one place: pyproject.toml, `graspmanifold.__version__`, `--version`
and the metadata of every saved file read it from here; and the fingerprint of the code that every
stored intermediate result (a reproduce stage, a checkpoint part, a stored benchmark cell) is keyed by."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

__version__ = "0.1.0"
"""The library's version (pyproject.toml reads it from here)."""


@functools.cache
def _source_digest() -> str:
    """A digest of the library's modules and model files (the hand's MJCF, the starting postures)."""
    package = Path(__file__).resolve().parents[1]
    assets = package / "assets" if (package / "assets").is_dir() else package.parents[1] / "assets"
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")) + (sorted(assets.glob("*.*")) if assets.is_dir() else []):
        digest.update(path.relative_to(package if path.suffix == ".py" else assets).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def code_fingerprint() -> str:
    """'<version>+<digest>': the library's version and a digest of its code and model files.

    Part of every key under which the library keeps an intermediate result, so that a result made by
    other code (another version, or an edited checkout) is made again instead of reused.

    Returns:
        The fingerprint, e.g. '0.1.0+3f2a9c0d1b2e4f56'.
    """
    return f"{__version__}+{_source_digest()}"
