"""The record of one trial (`Trial`): its judgement, what its controller did, and the features it sensed
(`FIRST_CONTACT_FEATURES`, `FAILURE_FEATURES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

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
