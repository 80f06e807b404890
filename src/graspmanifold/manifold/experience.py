"""Experience bases: the interface the grasp controller uses, and the raw posture database.

The paper represents grasp experience either as a database of successful grasp postures
(Section 2, matched with the PCP distance of Eq. 2) or as a SOM approximating the grasp manifold
(Section 4, the same masked distance in Eq. 4). Both answer one question: which stored posture
best matches the current partial contact posture? `Experience` is that question as a protocol;
`SOM` and `PostureDatabase` both satisfy it.

Beyond the paper (issue 66), an experience may also know where the object sat in the palm's frame in each grasp: its
`places`, (k, 3) m aligned with `references` (None where it does not know). They are never matched, only recalled with
the posture of the same row: a database keeps each posture's (`object_places` of a `PostureSet`), a SOM node the place
of its nearest training posture (`SOM.carry_places`). An experience of one's own without them still runs.

Likewise (issue 84) an experience may know how hard each grasp pressed when it was verified: its `squeezes`, (k, 22)
rad aligned with `references`, each the verified squeeze's posture less the grasp's (the press that held, joint by
joint: `plans.OpenLoopGrasp.squeeze_offset`). The approach execution presses a holding finger by the squeeze of the
grasp it recalled (`recall.ApproachRecall.pressed`) where the experience has them, by a fixed press where it has
none. A database keeps each posture's, a SOM node its nearest training posture's (`SOM.carry_squeezes`).
`carried_values` names what an experience carries; it belongs to a trial's identity (`TrialSetup.key`).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from ..base.errors import InvalidInput
from ..base.io import NpzRecord, fingerprint
from ..base.poses import invert
from ..base.validation import check_data, check_int
from ..sim.hand import N_FINGER_JOINTS
from .nearest import MaskedNearest, ReferenceMatcher
from .postureset import PostureSet


@runtime_checkable
class Experience(Protocol):
    """A set of reference postures answering masked best-match queries (Eq. 2 / Eq. 4): what the
    controller recalls from. `PostureDatabase` and `SOM` are two; a user's own needs only these members
    (`trials.conformance.check_experience_contract` checks one). The controller recalls what `complete_batch`
    returns (a recall of one's own may blend postures there) and records the rows `best_match_batch` names.

    The API reference shows an experience base of one's own, recalled in a trial.
    """

    @property
    def dim(self) -> int | None:
        """The postures' dimension (a map before its first fit may not know it yet)."""
        ...

    @property
    def references(self) -> np.ndarray:
        """The reference postures (k, dim) that `best_match` indexes."""
        ...

    def best_match(self, x: np.ndarray, mask: np.ndarray | None = None) -> int:
        """The reference posture nearest to x under the masked distance of Eq. 2.

        Args:
            x: the query (dim,), rad; it may hold NaN where the mask is 0.
            mask: None (plain Euclidean), boolean, or weights p_k >= 0, not all zero (the PCP mask, Eq. 2).

        Returns:
            Its index: a row of `references`.
        """
        ...

    def best_match_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`best_match` of every query.

        Args:
            X: queries (m, dim), rad.
            masks: None, one mask (dim,) for every query, or one per query (m, dim).

        Returns:
            Indices (m,).
        """
        ...

    def complete(self, x: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """The best-matching reference posture in full: x completed from what the mask specifies.

        Args:
            x: the query (dim,), rad; it may hold NaN where the mask is 0.
            mask: None (plain Euclidean), boolean, or weights p_k >= 0, not all zero (the PCP mask, Eq. 2).

        Returns:
            The posture (dim,), rad.
        """
        ...

    def complete_batch(self, X: np.ndarray, masks: np.ndarray | None = None) -> np.ndarray:
        """`complete` of every query.

        Args:
            X: queries (m, dim), rad.
            masks: None, one mask (dim,) for every query, or one per query (m, dim).

        Returns:
            Postures (m, dim), rad.
        """
        ...


def object_places(postures: PostureSet) -> np.ndarray:
    """Where the object sat in the palm's frame in each grasp of a set: the object frame's origin seen from the palm
    pose the grasp was verified at (`PostureSet.hand_poses`).

    Args:
        postures: the grasps.

    Returns:
        (n, 3) m, palm frame (x across the fingers, y out of the palm's back, z along the fingers).
    """
    return np.array([invert(pose[:3], pose[3:])[0] for pose in postures.hand_poses]).reshape(-1, 3)


#: m, the farthest an object may sit from the palm in a place (`check_places`): a hand's reach, with room
MAX_PLACE = 1.0
#: rad, the largest joint change a squeeze may make (`check_squeezes`): any joint's whole range, with room
MAX_SQUEEZE = float(np.pi)


def _check_rows(values: object, count: int, width: int, name: str, what: str, bound: float) -> np.ndarray:
    """Values carried per reference row checked: (count, width) real, finite, within +-bound; a read-only copy."""
    try:
        array = np.asarray(values)
        if np.iscomplexobj(array):
            raise TypeError("complex")
        array = np.array(array, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be ({count}, {width}) {what}, one per posture: got values that are not real "
                           "numbers") from None
    if array.shape != (count, width):
        raise InvalidInput(f"{name} must be ({count}, {width}) {what}, one per posture, got shape {array.shape}")
    bad = ~(np.isfinite(array) & (np.abs(np.nan_to_num(array)) <= bound)).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InvalidInput(f"{name} must be finite {what}, got {array[row].tolist()} in row {row} (each within "
                           f"+-{bound:g})")
    array.flags.writeable = False
    return array


#: rad, the largest finger joint angle a posture may hold (every joint's range of every hand lies within it)
MAX_JOINT_ANGLE = float(np.pi)
#: rad, how far an experience's reference posture may lie outside the hand's joint range (`check_within_hand`):
#: simulated postures pass a limit by a little, another hand's postures by more
JOINT_RANGE_SLACK = 0.1


def check_file_postures(values: np.ndarray, path: Path, what: str) -> np.ndarray:
    """Postures read from an experience file, checked before they are used: finite, and hand postures (22 wide)
    within +-`MAX_JOINT_ANGLE` (a file of 50-rad or 1e14-rad postures completed to them).

    Args:
        values: (n, dim) values, rad where dim is 22.
        path: the file, for the message.
        what: what they are in it ('weights', 'mean').

    Returns:
        The values as a float array.

    Raises:
        InvalidInput: non-finite values, or hand postures beyond the bound, the file and the row named.
    """
    array = check_data(values, np.shape(values)[-1] if np.ndim(values) else 0, f"{path} {what}")
    if array.shape[1] == N_FINGER_JOINTS:
        beyond = (np.abs(array) > MAX_JOINT_ANGLE).any(axis=1)
        if beyond.any():
            row = int(np.flatnonzero(beyond)[0])
            raise InvalidInput(f"{path}: {what} row {row} holds joint angles beyond +-pi rad ({array[row].tolist()}); "
                               "no hand's joint turns that far: the file is corrupt")
    return array


def check_within_hand(experience: Experience, limits: np.ndarray, hand: str) -> None:
    """Warn of an experience whose reference postures lie outside a hand's joint ranges (by more than
    `JOINT_RANGE_SLACK`): postures of another hand, or numbers no grasp has (a synthetic experience may mean it:
    the hand's servos stop each joint at its range).

    Args:
        experience: the experience (22-wide references; others are not hand postures and pass).
        limits: (22, 2) rad, the hand's joint ranges.
        hand: the hand's name, for the message.

    Warns:
        UserWarning: the first reference and joint outside, with the range.
    """
    references = np.asarray(experience.references, dtype=float)
    if references.ndim != 2 or references.shape[1] != N_FINGER_JOINTS:
        return
    outside = (references < limits[:, 0] - JOINT_RANGE_SLACK) | (references > limits[:, 1] + JOINT_RANGE_SLACK)
    if outside.any():
        row, joint = (int(i) for i in np.argwhere(outside)[0])
        warnings.warn(f"the experience's reference posture {row} has joint {joint} at {references[row, joint]:.3f} "
                      f"rad, outside the {hand!r} hand's range [{limits[joint, 0]:.3f}, {limits[joint, 1]:.3f}] (by "
                      f"more than {JOINT_RANGE_SLACK} rad): is it another hand's experience?", stacklevel=3)


def check_places(places: object, count: int) -> np.ndarray:
    """Places (`object_places`) checked against the rows they belong to.

    Args:
        places: (count, 3) m, one per row.
        count: how many rows they belong to.

    Returns:
        A read-only copy, (count, 3) m.

    Raises:
        InvalidInput: another shape, a value that is not a finite real number, or one farther than `MAX_PLACE`.
    """
    return _check_rows(places, count, 3, "places", "positions in m", MAX_PLACE)


def check_squeezes(squeezes: object, count: int) -> np.ndarray:
    """Squeezes (each a verified squeeze's posture less its grasp's, `plans.OpenLoopGrasp.squeeze_offset`) checked
    against the rows they belong to.

    Args:
        squeezes: (count, 22) rad, one per row.
        count: how many rows they belong to.

    Returns:
        A read-only copy, (count, 22) rad.

    Raises:
        InvalidInput: another shape, a value that is not a finite real number, or one beyond `MAX_SQUEEZE`.
    """
    return _check_rows(squeezes, count, N_FINGER_JOINTS, "squeezes", "joint changes in rad", MAX_SQUEEZE)


def carried_values(experience: object) -> dict[str, np.ndarray]:
    """What an experience carries besides its reference postures, recalled with them: its `places` and `squeezes`
    where it has them (an experience of one's own may have neither).

    Args:
        experience: an `Experience` (or None).

    Returns:
        {"places": (k, 3) m, "squeezes": (k, 22) rad}, those it has.
    """
    out = {}
    for name in ("places", "squeezes"):
        value = getattr(experience, name, None)
        if value is not None:
            out[name] = np.asarray(value, dtype=float)
    return out


class PostureDatabase(ReferenceMatcher, NpzRecord):
    """All stored postures (n, dim); best matches are row indices into `postures`, `places` where the object
    sat in each and `squeezes` how hard each pressed (None: not known)."""

    def __init__(self, postures: np.ndarray, places: np.ndarray | None = None, squeezes: np.ndarray | None = None):
        """The database of these postures.

        Args:
            postures: (n, dim) finite postures, rad; stored read-only.
            places: (n, 3) m, where the object sat in the palm's frame in each (`object_places`), or None.
            squeezes: (n, 22) rad, each grasp's verified squeeze less its posture
                (`plans.OpenLoopGrasp.squeeze_offset`), or None.
        """
        data = np.asarray(postures, dtype=float)
        if data.ndim != 2:
            raise InvalidInput(f"postures must be an (n, dim) array, got shape {data.shape}")
        self.postures = check_data(data, data.shape[1], "postures")
        self.postures.flags.writeable = False
        self.places = None if places is None else check_places(places, len(self.postures))
        self.squeezes = None if squeezes is None else check_squeezes(squeezes, len(self.postures))
        self.dim = self.postures.shape[1]
        self._search = MaskedNearest(self.postures)

    def __len__(self) -> int:
        return len(self.postures)

    @property
    def references(self) -> np.ndarray:
        """The stored postures (n, dim), read-only: `best_match` gives a row of them."""
        return self.postures

    def masked_search(self) -> MaskedNearest:
        """The masked nearest search over the stored postures (`ReferenceMatcher.masked_search`).

        Returns:
            The `MaskedNearest` over `references`.
        """
        return self._search

    NPZ_KIND = "posture_database"
    NPZ_REQUIRED = {"postures": (None, None)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        arrays = {"postures": self.postures, **carried_values(self)}
        return arrays, {"dim": self.dim, "count": len(self), "data_fingerprint": fingerprint(self.postures),
                        "units": "postures rad; places m, the object in the palm's frame; squeezes rad"}

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> PostureDatabase:
        return cls(check_file_postures(arrays["postures"], path, "postures"), arrays.get("places"), arrays.get("squeezes"))

    def __repr__(self) -> str:
        carried = "".join(f", with {name}" for name in carried_values(self))
        return f"PostureDatabase({len(self)} postures, dim={self.dim}{carried})"


_PROTOCOL_MEMBERS = tuple(dict.fromkeys([*Experience.__annotations__,
                                         *(name for name in vars(Experience) if not name.startswith("_"))]))


def check_experience(experience: object) -> Experience | None:
    """The experience base a controller uses: None (the purely tactile controller), any `Experience`
    (a PostureDatabase, a SOM), or a PostureSet, which becomes the database of its postures and their places."""
    if experience is None:
        return None
    if isinstance(experience, PostureSet):
        experience = PostureDatabase(experience.postures, object_places(experience))
    if not isinstance(experience, Experience):
        missing = [name for name in _PROTOCOL_MEMBERS if not hasattr(experience, name)]
        raise InvalidInput(f"experience must be None, a PostureSet or an Experience (the protocol in "
                           f"graspmanifold.manifold.experience: a PostureDatabase, a SOM or one's own class); "
                           f"{type(experience).__name__} lacks {', '.join(missing)}")
    if experience.dim != N_FINGER_JOINTS:
        raise InvalidInput(f"experience must hold {N_FINGER_JOINTS}-joint postures, it has dim {experience.dim}")
    return experience


def scrambled(postures: np.ndarray, seed: int = 0) -> np.ndarray:
    """The null experience's postures: each joint column permuted on its own, so that every joint keeps the
    distribution it has over the postures and no grasp is left in any row (the control an experience claim is made
    against: an experience that pays must beat a map trained on these).

    Args:
        postures: (n, dim) postures, rad.
        seed: seeds the permutations (column j: the generator seeded [seed, j]).

    Returns:
        (n, dim) the scrambled postures (a new array).
    """
    data = np.asarray(postures, dtype=float)
    if data.ndim != 2 or len(data) == 0:
        raise InvalidInput(f"postures must be a non-empty (n, dim) array, got shape {data.shape}")
    seed = check_int(seed, "seed", low=0)  # NumPy's "expected non-negative integer" named nothing
    return np.column_stack([data[np.random.default_rng([seed, j]).permutation(len(data)), j]
                            for j in range(data.shape[1])])
