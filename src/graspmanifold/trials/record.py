"""The record of one trial (`Trial`): its judgement, what its controller did, and the features it sensed
(`FIRST_CONTACT_FEATURES`, `FAILURE_FEATURES`); how each field is a column of a file (`TRIAL_COLUMNS`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..judging.judge import JUDGING
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS


#: the length of `Trial.first_contact` (time, joints, segment forces) and of `Trial.failure` (joints, forces)
FIRST_CONTACT_FEATURES = 1 + N_FINGER_JOINTS + len(SEGMENTS)
FAILURE_FEATURES = N_FINGER_JOINTS + len(SEGMENTS)


@dataclass
class Trial:
    """The outcome of one grasp trial."""

    grid_pose: np.ndarray
    posture: np.ndarray
    touching: np.ndarray  # (len(SEGMENTS),) bool
    epsilon: float
    hold: bool
    hold_displacement: float
    time_to_grasp: float
    matches: int
    margin: float = 0.0  # N of extra disturbance held (JUDGING.margin_force when never dropped; NaN: not measured)
    penetration: float = 0.0  # m, the deepest contact at the end of any control period (Scene.max_penetration)
    fault: str = ""  # why the physics of this trial failed; empty when it did not
    #: the best match of every experience query the controller used (`matches` of them), in order: rows of
    #: `experience.references` (a SOM's flat node indices); None when not recorded (a file of library 0.1.0)
    winners: np.ndarray | None = field(default_factory=lambda: np.zeros(0, dtype=int))
    #: s of the hold test run: 6 x `JUDGING.hold_seconds` for a grasp that held, less for one that dropped its
    #: object (the test ends there), 0 when the physics failed; NaN when not recorded (a file written before
    #: it was kept)
    hold_time: float = float("nan")
    #: grasp attempts the controller made (`TrialSetup.regrasp`), 1 without a regrasp
    attempts: int = 1
    #: what the controller sensed at its first contact: [s since the start, the 22 joints (rad), the segment forces
    #: (N, `SEGMENTS` order)] (`FIRST_CONTACT_FEATURES`); NaN when nothing was touched or not recorded
    first_contact: np.ndarray = field(default_factory=lambda: np.full(FIRST_CONTACT_FEATURES, np.nan))
    #: what it sensed when its first attempt failed the lift probe: [the 22 joints (rad), the segment forces (N)]
    #: (`FAILURE_FEATURES`); NaN when no probe failed
    failure: np.ndarray = field(default_factory=lambda: np.full(FAILURE_FEATURES, np.nan))
    #: m, where the controller's touch first placed the object (`BatchController.object_estimate`), in the palm
    #: frame the trial put the hand in (a planned trial's: the plan's for the nominal object); NaN where it placed
    #: it nowhere (a palm that does not re-centre) or not recorded
    object_estimate: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))

    def __repr__(self) -> str:
        outcome = f"invalid: {self.fault}" if self.fault else (
            f"{'held' if self.hold else 'dropped'}, epsilon {self.epsilon:.3f}, "
            f"{'' if math.isnan(self.margin) else f'margin {self.margin:.1f} N, '}{self.time_to_grasp:.2f} s")
        return f"Trial(pose {np.round(self.grid_pose, 3).tolist()}: {outcome})"

    @property
    def valid(self) -> bool:
        """The physics of this trial worked: its outcome says something about the controller."""
        return not self.fault

    @property
    def force_closure(self) -> bool:
        return self.valid and self.epsilon > JUDGING.epsilon_threshold


#: the kinds of value a column of trials holds
COLUMN_KINDS: dict[str, type] = {"float": float, "bool": bool, "int": int, "str": str}


@dataclass(frozen=True)
class Column:
    """How one field of `Trial` is a column of a file of trials (`evaluation.EvaluationResult.save`).

    Attributes:
        file: its name in the file.
        width: values per trial (None: one).
        kind: 'float', 'bool', 'int' or 'str'.
        about: what it is, in the file's metadata ("fields").
        older: the value a trial of a file written before the column was kept gets (None: every file has it).
    """

    file: str
    width: int | None
    kind: str
    about: str
    older: object = None

    def array(self, values: Sequence[object]) -> np.ndarray:
        """The column of these trials' values.

        Args:
            values: one per trial.

        Returns:
            (n,) or (n, width) of the column's kind.
        """
        column: np.ndarray = np.array(values, dtype=COLUMN_KINDS[self.kind])
        return column.reshape(-1, self.width) if self.width else column

    def value(self, column: np.ndarray, row: int) -> Any:  # Any: the kind the column says
        """One trial's value of a column read from a file.

        Args:
            column: the column as the file holds it.
            row: the trial.

        Returns:
            The value as `Trial` holds it (a row array, or a Python number, bool or string).
        """
        if self.width:
            return column[row]
        return COLUMN_KINDS[self.kind](column[row])

    @property
    def dtype_kinds(self) -> str:
        """The NumPy dtype kinds a file's column of this kind may have (a bool or int column read as numbers too)."""
        return {"float": "biuf", "bool": "bi", "int": "biu", "str": "U"}[self.kind]

    def missing(self) -> Any:  # Any: the kind the column says
        """The value of a trial whose file was written before the column was kept (a fresh copy of an array).

        Returns:
            `older`.
        """
        return np.array(self.older) if isinstance(self.older, np.ndarray) else self.older


#: every field of `Trial` but its best-match winners (a file keeps those one trial after the other), as a column
TRIAL_COLUMNS: dict[str, Column] = {
    "grid_pose": Column("grid", 4, "float", "(n, 4) grid pose: x, z, gap (m), yaw (rad)"),
    "posture": Column("postures", N_FINGER_JOINTS, "float", "(n, 22) rad, the posture at release"),
    "touching": Column("touching", len(SEGMENTS), "bool", "(n, len(segments)) bool, the segments touching at release"),
    "epsilon": Column("epsilon", None, "float", "Ferrari-Canny epsilon at release, per unit total normal force"),
    "hold": Column("hold", None, "bool", "bool, the object stayed within the hold limit in all six gravity directions"),
    "hold_displacement": Column("hold_displacement", None, "float", "m, the largest displacement in the hold test; "
                                "for a grasp that did not hold, where the object was in the period it first left the "
                                "bound (beyond the limit: the test stops there); inf when the physics failed"),
    "time_to_grasp": Column("time_to_grasp", None, "float", "s until the controller reported the grasp done"),
    "matches": Column("matches", None, "int", "experience queries the controller used"),
    "margin": Column("margin", None, "float", "N of extra disturbance held (margin_force when never dropped, 0 when "
                     "not held); NaN: not measured"),
    "penetration": Column("penetration", None, "float", "m, the deepest contact at the end of any control period"),
    "fault": Column("fault", None, "str", "why the physics failed; empty when it did not"),
    "hold_time": Column("hold_time", None, "float", "s of the hold test run (six hold_seconds when held, fewer when "
                        "dropped, 0 on a fault)", older=float("nan")),
    "attempts": Column("attempts", None, "int", "grasp attempts the controller made", older=1),
    "first_contact": Column("first_contact", FIRST_CONTACT_FEATURES, "float", "(n, 1 + 22 + len(segments)) what the "
                            "controller sensed at its first contact: s, joints (rad), segment forces (N); NaN: none",
                            older=np.full(FIRST_CONTACT_FEATURES, np.nan)),
    "failure": Column("failure", FAILURE_FEATURES, "float", "(n, 22 + len(segments)) what it sensed when its first "
                      "attempt failed the lift probe: joints (rad), segment forces (N); NaN: no probe failed",
                      older=np.full(FAILURE_FEATURES, np.nan)),
    "object_estimate": Column("object_estimate", 3, "float", "(n, 3) m, where the controller's touch first placed "
                              "the object, in the palm frame the trial put the hand in (NaN: nowhere)",
                              older=np.full(3, np.nan)),
}
