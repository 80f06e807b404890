"""PostureSet: generated grasp postures with where they came from, saved as validated .npz files."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import DTypeLike

from ..base.errors import InvalidInput
from ..base.io import NpzRecord, Tabular
from ..base.moved import current_name
from ..sim.hand import FINGER_JOINTS, N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND

#: the default of `epsilon` and `hold_displacement`: NaN for every posture (not judged)
_NOT_JUDGED = np.full(0, np.nan)


@dataclass(frozen=True)
class PostureSet(Tabular, NpzRecord):
    """n grasp postures (radians) with their palm poses in the object frame (x y z, qw qx qy qz),
    the starting posture each was generated around (`start_ids` into `start_names`), which segments
    touch the object (`contacts`, columns in SEGMENTS order), each posture's grasp quality when it
    was verified (`epsilon`, and `hold_displacement` in m during the hold test; NaN where not
    verified), and metadata."""

    postures: np.ndarray
    hand_poses: np.ndarray
    start_ids: np.ndarray
    contacts: np.ndarray
    start_names: tuple[str, ...]
    metadata: dict = field(default_factory=dict)
    epsilon: np.ndarray = field(default_factory=lambda: _NOT_JUDGED)
    hold_displacement: np.ndarray = field(default_factory=lambda: _NOT_JUDGED)

    def __post_init__(self) -> None:
        n = len(self.postures)
        for name in ("epsilon", "hold_displacement"):
            if getattr(self, name) is None or getattr(self, name) is _NOT_JUDGED:
                object.__setattr__(self, name, np.full(n, np.nan))
        expected = {"postures": (n, N_FINGER_JOINTS), "hand_poses": (n, 7), "start_ids": (n,), "contacts": (n, len(SEGMENTS)),
                    "epsilon": (n,), "hold_displacement": (n,)}
        for name, shape in expected.items():
            value = getattr(self, name)
            if np.shape(value) != shape:
                raise InvalidInput(f"{name} must have shape {shape}, got {np.shape(value)}")
        if not (np.all(np.isfinite(self.postures)) and np.all(np.isfinite(self.hand_poses))):
            raise InvalidInput("postures and hand_poses must be finite")
        if n and (self.start_ids.min() < 0 or self.start_ids.max() >= len(self.start_names)):
            raise InvalidInput(f"start_ids must index start_names (0 ... {len(self.start_names) - 1})")

    def rows(self) -> list[dict]:
        """One row per posture, for a table (`to_csv`, `to_frame`): its start, its 22 joints (rad, by `FINGER_JOINTS` name), its palm pose
        (m; quaternion w x y z), its quality when verified, and the segments touching.

        Returns:
            A list of dicts with the same keys (`to_csv`, `to_frame`).
        """
        pose_names = ("palm_x", "palm_y", "palm_z", "palm_qw", "palm_qx", "palm_qy", "palm_qz")
        return [{"start": self.start_names[int(start)], **dict(zip(FINGER_JOINTS, map(float, posture))),
                 **dict(zip(pose_names, map(float, pose))), "epsilon": float(epsilon),
                 "hold_displacement": float(displacement),
                 "touching": " ".join(s for s, on in zip(SEGMENTS, contacts) if on)}
                for posture, pose, start, contacts, epsilon, displacement in zip(
                    self.postures, self.hand_poses, self.start_ids, self.contacts, self.epsilon, self.hold_displacement)]

    def __len__(self) -> int:
        return len(self.postures)

    @property
    def hand(self) -> str:
        """The name of the hand model the postures are of (`metadata["hand"]`; ours for a set that names none)."""
        return str(current_name("hand", self.metadata.get("hand", SHADOW_HAND.name)))

    def __array__(self, dtype: DTypeLike | None = None, copy: bool | None = None) -> np.ndarray:
        """The (n, 22) postures, so a PostureSet goes wherever postures do (`np.asarray`, `SOM.fit`)."""
        return self.postures if dtype is None else self.postures.astype(dtype)

    def __getitem__(self, index: int | np.ndarray | slice) -> np.ndarray | PostureSet:
        """One posture (22,) for an integer; a PostureSet of the selection for a slice, mask or index array."""
        if isinstance(index, (int, np.integer)):
            return self.postures[index]
        return self.subset(index)

    def __repr__(self) -> str:
        obj = self.metadata.get("object", {})
        name = obj.get("name", "?") if isinstance(obj, dict) else "?"
        verified = np.isfinite(self.epsilon).sum()
        return (f"PostureSet({len(self)} postures of {name}, {len(self.start_names)} starting postures, "
                f"{verified} verified)")

    def subset(self, index: np.ndarray | slice) -> PostureSet:
        """The postures selected by an index array, boolean mask or slice, with their palm poses, starts,
        contacts and judgements.

        Args:
            index: row indices, a boolean mask (n,) or a slice.

        Returns:
            The selected set (the same metadata).
        """
        return PostureSet(self.postures[index], self.hand_poses[index], self.start_ids[index],
                          self.contacts[index], self.start_names, dict(self.metadata),
                          self.epsilon[index], self.hold_displacement[index])

    @classmethod
    def concatenate(cls, sets: list[PostureSet]) -> PostureSet:
        """One set holding all postures; start names are merged and ids remapped."""
        if not sets:
            raise InvalidInput("sets must hold at least one PostureSet")
        names: list[str] = []
        for s in sets:
            names.extend(n for n in s.start_names if n not in names)
        remapped = [np.array([names.index(s.start_names[i]) for i in s.start_ids], dtype=np.int64) for s in sets]
        return cls(np.concatenate([s.postures for s in sets]), np.concatenate([s.hand_poses for s in sets]),
                   np.concatenate(remapped) if remapped else np.zeros(0, np.int64),
                   np.concatenate([s.contacts for s in sets]), tuple(names),
                   {"concatenated_from": [s.metadata for s in sets]},
                   np.concatenate([s.epsilon for s in sets]), np.concatenate([s.hold_displacement for s in sets]))

    def cluster_separation(self) -> dict[str, float]:
        """Mean posture distance (degrees, over 22 joints) within and between starting postures.

        within: mean distance of a posture to the mean posture of its own start; between: mean
        distance between the mean postures of different starts. A ratio well below 1 is clustered data.
        An empty set has no clusters (nan distances, 0 starts).
        """
        ids = np.unique(self.start_ids)
        if not len(ids):
            return {"within_deg": float("nan"), "between_deg": float("nan"), "ratio": float("nan"), "starts": 0}
        means = np.array([self.postures[self.start_ids == i].mean(axis=0) for i in ids])
        within = np.mean(np.linalg.norm(self.postures - means[np.searchsorted(ids, self.start_ids)], axis=1))
        pairs = [np.linalg.norm(means[a] - means[b]) for a in range(len(ids)) for b in range(a + 1, len(ids))]
        between = float(np.mean(pairs)) if pairs else float("nan")
        return {"within_deg": float(np.degrees(within)), "between_deg": float(np.degrees(between)),
                "ratio": float(within / between) if pairs else float("nan"), "starts": int(len(ids))}

    NPZ_KIND = "posture_set"
    NPZ_REQUIRED = {"postures": (None, N_FINGER_JOINTS), "hand_poses": (None, 7), "start_ids": (None,),
                    "contacts": (None, len(SEGMENTS)), "epsilon": (None,), "hold_displacement": (None,)}

    def _to_npz(self) -> tuple[dict[str, np.ndarray], dict]:
        arrays = {"postures": self.postures, "hand_poses": self.hand_poses, "start_ids": self.start_ids,
                  "contacts": self.contacts, "epsilon": self.epsilon, "hold_displacement": self.hold_displacement}
        meta = {**self.metadata, "start_names": list(self.start_names), "joints": list(FINGER_JOINTS),
                "segments": list(SEGMENTS), "units": "radians; hand poses in m and unit quaternions (w x y z)"}
        return arrays, meta

    @classmethod
    def _from_npz(cls, arrays: dict[str, np.ndarray], meta: dict, path: Path) -> PostureSet:
        """The set of a file (postures in rad, palm poses in m and quaternions, in the object frame)."""
        if meta.get("joints") != list(FINGER_JOINTS) or meta.get("segments") != list(SEGMENTS):
            raise InvalidInput(f"{path} uses another joint or segment order than this library")
        names = tuple(meta.pop("start_names", ()))
        for key in ("joints", "segments", "units", "schema", "kind"):
            meta.pop(key, None)
        try:
            return cls(arrays["postures"].astype(float), arrays["hand_poses"].astype(float),
                       arrays["start_ids"].astype(np.int64), arrays["contacts"].astype(bool), names, meta,
                       arrays["epsilon"].astype(float), arrays["hold_displacement"].astype(float))
        except ValueError as error:
            raise InvalidInput(f"{path} is inconsistent: {error}") from None
