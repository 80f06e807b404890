"""The starting postures the generator uses, found once and kept: shipped for the paper's objects and the object
family, else searched by the generator's own check (`search_starting_postures`: a start kept only where it and its
neighbours hold, `springs.holds_with_neighbours`) and stored in `cache_directory()` for the next process. The
starts themselves (designs, the search, files) are `starts`.
"""

from __future__ import annotations

import os
import warnings
from functools import lru_cache, partial
from pathlib import Path

from ..base.checkpoints import result_key
from ..base.io import load_npz
from ..base.validation import check_choice
from ..sim.objects import GraspObject, get_object
from .starts import (DESIGN_FAMILIES, StartingPosture, find_starting_postures, geometry_params, read_entry,
                     save_starting_postures, shipped_starting_postures)
from .springs import holds_with_neighbours


def search_starting_postures(obj: str | GraspObject, family: str = "five_fingertip", *, perturbation: float = 0.0,
                             progress: bool | None = None, workers: int | None = None) -> list[StartingPosture]:
    """Search an object's starting postures as the generator uses them: `starts.find_starting_postures`, a
    grasp-types start kept only when it and its neighbours hold (`holds_with_neighbours`). What
    `starting_postures` runs for an object that ships none, and what `scripts/find_starting_postures.py` ships.

    Args:
        obj: an object or its name.
        family: a design family (`starts.DESIGN_FAMILIES`).
        perturbation: a relative change of every design's palm position (`starts.find_starting_postures`).
        progress: show the bar (None: as `progress.show_progress` says).
        workers: worker processes (None: `workers.default_workers()` in a main process, one inside a worker).

    Returns:
        The starting postures found, in the order of `designs_for(obj, family)`.
    """
    obj = get_object(obj)
    return find_starting_postures(obj, family, check=partial(holds_with_neighbours, obj), perturbation=perturbation,
                                  progress=progress, workers=workers)


def cache_directory() -> Path:
    """Where starting postures searched for an object that ships none are kept, so that another process
    finds them: `$GRASPMANIFOLD_CACHE`, else `$XDG_CACHE_HOME/graspmanifold`, else `~/.cache/graspmanifold`.

    Returns:
        The folder (made when something is first stored there).
    """
    if os.environ.get("GRASPMANIFOLD_CACHE"):
        return Path(os.environ["GRASPMANIFOLD_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "graspmanifold"


def starting_postures(obj: str | GraspObject, family: str = "five_fingertip") -> list[StartingPosture]:
    """The starting postures of an object in a design family (`starts.DESIGN_FAMILIES`): shipped for the
    paper's objects and the object family; else searched once (`search_starting_postures`: seconds to half a
    minute per object, with a progress bar) and stored in `cache_directory()`, under a key of the object's
    shape (`starts.geometry_params`: a mesh's digest, not its name) and the library's code, so that a second process,
    or the same mesh under another name, reads them instead of searching again.

    Args:
        obj: an object or its name.
        family: 'five_fingertip' (the paper's kind) or 'grasp_types' (power, precision, tripod, lateral).

    Returns:
        The valid starting postures, in the order of `designs_for(obj, family)`.
    """
    return list(_starting_postures(get_object(obj), check_choice(family, DESIGN_FAMILIES, "family")))


def starts_cache_path(obj: GraspObject, family: str) -> Path:
    """Where `starting_postures` keeps an object's searched starts: a file of its shape (`starts.geometry_params`: a
    mesh's digest, not its name, mass or friction) and the library's code, so the same mesh under another name, or
    given as a file and as a `Trimesh`, reads the one search.

    Args:
        obj: the object.
        family: a design family.

    Returns:
        The file's path in `cache_directory()`.
    """
    shape = geometry_params(obj.params())
    return cache_directory() / "starting_postures" / f"{obj.shape}_{family}_{result_key(shape, family)}.npz"


@lru_cache(maxsize=64)
def _starting_postures(obj: GraspObject, family: str) -> tuple[StartingPosture, ...]:
    shipped = shipped_starting_postures(obj, family)
    if shipped is not None:
        return tuple(shipped)
    cached = starts_cache_path(obj, family)
    if cached.exists():
        try:
            arrays, meta = load_npz(cached, "starting_postures", {})
            (key, entry), = meta["objects"].items()
            return tuple(read_entry(arrays, key, entry, obj, family))
        except (ValueError, KeyError, OSError) as error:  # a damaged file is searched again and replaced
            warnings.warn(f"the stored starting postures {cached} cannot be read ({error}): searching again",
                          stacklevel=3)
    warnings.warn(f"{obj.name} has no shipped starting postures ({family}): searching them now (seconds to half "
                  f"a minute); they are kept in {cached.parent} for the next process", stacklevel=3)
    found = search_starting_postures(obj, family)
    try:
        save_starting_postures(cached, {(obj, family): found})
    except OSError as error:  # a read-only home: the search is only lost for the next process
        warnings.warn(f"the starting postures could not be stored in {cached.parent} ({error}); set "
                      "GRASPMANIFOLD_CACHE to a writable folder to keep them", stacklevel=3)
    return tuple(found)
