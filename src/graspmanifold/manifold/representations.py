"""The experience representations by name: what `--experience`, `--manifold`, experiment files and studies say.

    experience = fit_representation("ukr", postures, seed=0)        # trained with the library's defaults
    experience = load_representation("maps/cylinder.npz")           # whichever kind the file holds

Each is an `experience.Experience` the controller recalls from: the raw database (the paper's Section 2), the
paper's 25 x 25 SOM with its schedule (Sections 3-5), a 2-d UKR manifold (the paper's future work, `ukr.UKR`) and
a 5-component linear manifold (PCA hand synergies, `linear.LinearManifold`).
"""

from __future__ import annotations

import os

import numpy as np

from ..base.errors import InvalidInput
from ..base.io import npz_kind
from ..base.paper_numbers import MAP_SIZE
from ..base.validation import check_choice
from .experience import Experience, PostureDatabase, object_places
from .linear import LinearManifold
from .postureset import PostureSet
from .som import SOM
from .ukr import UKR

#: the representations by name, with what each is
REPRESENTATIONS: dict[str, str] = {
    "database": "every training posture, matched as stored (the paper's Section 2)",
    "som": f"a {MAP_SIZE[0]} x {MAP_SIZE[1]} SOM on the paper's schedule (Sections 3-5)",
    "ukr": "a 2-d Unsupervised Kernel Regression manifold (the paper's future work)",
    "linear": "a 5-component linear manifold (PCA hand synergies)",
}
#: what a representation is: the kinds `fit_representation` trains and `load_representation` reads
Representation = SOM | UKR | LinearManifold | PostureDatabase
_REPRESENTATION_KINDS = {"database": PostureDatabase, "som": SOM, "ukr": UKR, "linear": LinearManifold}
_FILE_KINDS: dict[str, type[SOM] | type[UKR] | type[LinearManifold] | type[PostureDatabase]] = {
    SOM.NPZ_KIND: SOM, UKR.NPZ_KIND: UKR, LinearManifold.NPZ_KIND: LinearManifold,
    PostureDatabase.NPZ_KIND: PostureDatabase}


def fit_representation(name: str, postures: np.ndarray, *, seed: int = 0, progress: bool | None = None
                       ) -> Representation:
    """A representation of these postures, trained with the library's defaults (on fewer postures than they need,
    a UKR or linear manifold of fewer dimensions: at least 3 postures for a UKR, 2 for a linear one).

    Args:
        name: one of `REPRESENTATIONS`.
        postures: (n, 22) training postures, rad.
        seed: the SOM's presentation order (the others draw no random numbers).
        progress: show a progress bar while training (None: as `progress.show_progress` says).

    Returns:
        The experience.
    """
    check_choice(name, REPRESENTATIONS, "representation")
    data = np.asarray(postures, dtype=float)
    if name == "database":
        return PostureDatabase(data)
    if name == "som":
        return SOM(*MAP_SIZE, data.shape[-1], seed=seed).fit(data, progress=progress)
    if name == "ukr":  # a handful of postures: as many latent dimensions as they carry
        return UKR(max(1, min(2, len(data) - 2))).fit(data, progress=progress)
    return LinearManifold(max(1, min(5, len(data) - 1, data.shape[-1]))).fit(data)


def representation_name(experience: Experience) -> str:
    """The name (`REPRESENTATIONS`) of an experience's kind: 'som', 'ukr', 'linear' or 'database'.

    Args:
        experience: an experience of one of the representations.

    Returns:
        Its name.

    Raises:
        InvalidInput: an experience of another kind (one's own).
    """
    for name, kind in _REPRESENTATION_KINDS.items():
        if type(experience) is kind:
            return name
    raise InvalidInput(f"experience is a {type(experience).__name__}, none of the representations {tuple(REPRESENTATIONS)}")


def load_representation(path: str | os.PathLike) -> Experience:
    """The experience a file holds: a SOM, a UKR or linear manifold, a posture database, or a posture set (read as
    the database of its postures).

    Args:
        path: the .npz file.

    Returns:
        The experience.
    """
    kind = npz_kind(path)
    if kind == PostureSet.NPZ_KIND:
        postures = PostureSet.load(path)
        return PostureDatabase(postures.postures, object_places(postures))
    if kind not in _FILE_KINDS:
        raise InvalidInput(f"{path} holds a {kind!r}; an experience file holds one of "
                           f"{(*_FILE_KINDS, PostureSet.NPZ_KIND)}")
    return _FILE_KINDS[kind].load(path)
