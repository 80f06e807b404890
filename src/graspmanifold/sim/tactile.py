"""Tactile sensing: per-segment hand-object contact readings from MuJoCo's contacts.

Only contacts between a hand segment and the object are tactile events; the hand touching
itself (or anything else) is not. A reading is what a tactile skin would report, plus the contact
geometry that grasp-quality measures need (points and normals, in the world frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..base.errors import InvalidInput
from .hand import SEGMENTS, SHADOW_HAND, HandModel, segment_of_geoms

_SEGMENT_INDEX = {s: i for i, s in enumerate(SEGMENTS)}


def _check_segment(segment: str) -> int:
    if segment not in _SEGMENT_INDEX:
        raise InvalidInput(f"unknown segment {segment!r}; expected one of {SEGMENTS}")
    return _SEGMENT_INDEX[segment]


@dataclass(frozen=True)
class TactileReading:
    """Hand-object contacts at one instant.

    `segments`: touching segments in SEGMENTS order; `segment_forces`: (len(SEGMENTS),) summed normal
    force per segment (N). Per contact: `contact_segments`, `points` (k, 3, world frame), `normals`
    (k, 3, unit, pointing into the object), `forces` (k,) normal force (N), `depths` (k,) penetration (m).
    """

    segments: tuple[str, ...]
    segment_forces: np.ndarray
    contact_segments: tuple[str, ...] = ()
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    forces: np.ndarray = field(default_factory=lambda: np.zeros(0))
    depths: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def touches(self, segment: str) -> bool:
        """Whether a segment touches the object.

        Args:
            segment: a name from `SEGMENTS`.

        Returns:
            True when it does.
        """
        _check_segment(segment)
        return segment in self.segments

    def force_on(self, segment: str) -> float:
        """Summed normal force on one segment.

        Args:
            segment: a name from `SEGMENTS`.

        Returns:
            The force, N.
        """
        return float(self.segment_forces[_check_segment(segment)])

    @property
    def max_penetration(self) -> float:
        """Deepest hand-object penetration (m), 0 without contact."""
        return float(self.depths.max()) if len(self.depths) else 0.0


def _geom_pairs(data: mujoco.MjData) -> np.ndarray:
    """The geom pairs (ncon, 2) of the current contacts."""
    n = data.ncon
    return np.column_stack([data.contact.geom1[:n], data.contact.geom2[:n]])


class TactileSensor:
    """Reads TactileReadings from a model holding the hand and a body named `object`."""

    def __init__(self, model: mujoco.MjModel, object_body: str = "object", min_force: float = 0.0,
                 hand: HandModel = SHADOW_HAND):
        """A sensor of the hand-object contacts of a model.

        Args:
            model: the scene's model.
            object_body: the object's body name.
            min_force: contacts with less normal force than this are not felt, N.
            hand: the hand model in the scene (its segments are read as the paper's `SEGMENTS`).
        """
        try:
            object_id = model.body(object_body).id
        except KeyError:
            raise InvalidInput(f"the model has no body named {object_body!r}") from None
        self.model = model
        self.min_force = float(min_force)
        self._segment_of_geom = segment_of_geoms(model, hand)
        self._is_object_geom = model.geom_bodyid == object_id
        # the segment a contact between two geoms is felt by (-1: not a hand-object pair), looked up in one step
        hand_first = (self._segment_of_geom[:, None] >= 0) & self._is_object_geom[None, :]
        self._pair_segment = np.where(hand_first, self._segment_of_geom[:, None], -1).astype(np.int16)
        self._pair_segment = np.maximum(self._pair_segment, self._pair_segment.T)
        self._wrench = np.zeros(6)
        self._elliptic = model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC

    def read(self, data: mujoco.MjData) -> TactileReading:
        """The current hand-object contacts (call after mj_step or mj_forward).

        Args:
            data: the simulation's data.

        Returns:
            The reading.
        """
        n, contact = data.ncon, data.contact
        return self.reading(_geom_pairs(data), self._normal_forces(data), contact.frame[:n, :3], contact.pos[:n],
                            contact.dist[:n])

    def segment_forces(self, data: mujoco.MjData) -> np.ndarray:
        """Only the summed normal force per segment of `read`: what the controller needs.

        Args:
            data: the simulation's data.

        Returns:
            Forces (len(SEGMENTS),), N, in `SEGMENTS` order.
        """
        n = data.ncon
        if not n:
            return np.zeros(len(SEGMENTS))
        contact = data.contact
        segments = self._pair_segment[contact.geom1[:n], contact.geom2[:n]]
        forces = self._normal_forces(data)
        with np.errstate(invalid="ignore"):
            felt = (segments >= 0) & (forces >= self.min_force)  # NaN (not in the solver) is never felt
        return np.bincount(segments[felt], forces[felt], minlength=len(SEGMENTS))

    def reading(self, geoms: np.ndarray, forces: np.ndarray, normals: np.ndarray, points: np.ndarray,
                dists: np.ndarray) -> TactileReading:
        """The reading of a list of contacts, from any engine; contacts other than hand-object ones are
        left out.

        Args:
            geoms: geom pairs (k, 2).
            forces: normal forces (k,), N (NaN: not in the constraint solver).
            normals: (k, 3), from the first geom to the second.
            points: (k, 3), m.
            dists: (k,), m.

        Returns:
            The reading.
        """
        segment_forces = np.zeros(len(SEGMENTS))
        segment_ids, forces, rows = self._hand_object(np.asarray(geoms), np.asarray(forces, dtype=float))
        if not len(rows):
            return TactileReading(segments=(), segment_forces=segment_forces)
        # the contact normal points from geom1 to geom2: into the object when the hand is geom1
        hand_first = self._segment_of_geom[np.asarray(geoms)[rows, 0]] >= 0
        normals = np.asarray(normals, dtype=float)[rows] * np.where(hand_first, 1.0, -1.0)[:, None]
        np.add.at(segment_forces, segment_ids, forces)
        touching = sorted(set(segment_ids.tolist()))
        return TactileReading(
            segments=tuple(SEGMENTS[i] for i in touching),
            segment_forces=segment_forces,
            contact_segments=tuple(SEGMENTS[i] for i in segment_ids),
            points=np.asarray(points, dtype=float)[rows].copy(),
            normals=normals,
            forces=forces,
            depths=np.maximum(-np.asarray(dists, dtype=float)[rows], 0.0),
        )

    def _normal_forces(self, data: mujoco.MjData) -> np.ndarray:
        """Normal force of every contact (ncon,), NaN where it is not in the solver (`mj_contactForce`:
        with elliptic cones the first of the contact's constraint forces)."""
        n = data.ncon
        address = data.contact.efc_address[:n]
        forces = np.full(n, np.nan)
        inside = address >= 0
        if self._elliptic:
            forces[inside] = data.efc_force[address[inside]]
        else:
            for row in np.flatnonzero(inside):
                mujoco.mj_contactForce(self.model, data, int(row), self._wrench)
                forces[row] = self._wrench[0]
        return forces

    def _hand_object(self, geoms: np.ndarray, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Segment (k,), normal force (k,) and row of every hand-object contact in the solver whose
        force reaches `min_force`."""
        segments = self._pair_segment[geoms[:, 0], geoms[:, 1]].astype(int)
        with np.errstate(invalid="ignore"):
            rows = np.flatnonzero((segments >= 0) & (forces >= self.min_force))  # NaN: not in the solver
        return segments[rows], forces[rows], rows
