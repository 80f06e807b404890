"""A planned trial's open-loop controller: the plan executed as a trial's controller (`OpenLoopController`), and its
factory for `TrialSetup(controller=OpenLoop(plan), plan=plan)` (`OpenLoop`). It senses nothing: every arm of a planned
trial starts from the same pregrasp and faces the same support, release and judge, and this is the arm that executes
the plan blind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..base.errors import InvalidInput
from ..base.poses import invert, rotate
from ..judging.plans import OpenLoopGrasp
from ..judging.protocols import DEXGRASPBENCH
from ..sim.grip import CONTROL_PERIOD
from ..sim.hand import HandModel

#: s each interpolated target of an approach lasts (DexGraspBench's steps per target at its own time step)
APPROACH_TARGET_SECONDS = DEXGRASPBENCH.steps_per_target * DEXGRASPBENCH.physics.timestep


class OpenLoopController:
    """An open-loop grasp executed as a trial's controller, N worlds at once; it senses nothing. From the pregrasp
    (where a planned trial starts every arm, `TrialSetup.plan`) it moves to the grasp and then the squeeze, each move
    in the replay's `approach_targets` interpolated targets of `APPROACH_TARGET_SECONDS` each (`replay_grasp`'s
    approach), the palm carried by the arm where the stages put it; then it is done and keeps the squeeze. It is the
    open-loop arm of a planned trial (`TrialSetup(controller=OpenLoop(grasp), plan=grasp)`): every arm then starts
    from the same state and faces the same support, release and judge. Given more attempts
    (`TrialSetup(regrasp=Regrasp(attempts=2))`), a world whose grasp fails the lift probe executes the plan again
    from its pregrasp (`restart`): the open loop with as many attempts as the arm it is compared with.

    Attributes:
        n: worlds; control_period: s; initial: (22,) rad, the pregrasp's posture; done: (N,) bool.
        offsets: (3, 3) m, the palm at each stage relative to the pregrasp's palm pose, in its frame.
        moves_palm: whether the stages move the palm; palm_offset: (N, 3) m, where the arm has carried each palm.
        cycle: (N,) control periods each world's attempt has run; attempt: (N,) each world's attempt, 1 the first.
    """

    #: what the trials read of it beyond the control step (`control.controller.READOUTS`)
    readouts = ("attempt", "palm_offset")

    def __init__(self, n: int, grasp: OpenLoopGrasp, control_period: float = CONTROL_PERIOD,
                 approach_targets: int = DEXGRASPBENCH.approach_targets):
        """An open-loop controller ready for its grasp in every world.

        Args:
            n: worlds.
            grasp: the pregrasp, grasp and squeeze (palm poses in the object frame).
            control_period: s between two `step` calls; a target lasts a whole number of them.
            approach_targets: interpolated targets per move (DexGraspBench's 10).

        Raises:
            InvalidInput: stages that turn the palm (the arm here only carries it), or a period that does not
                divide a target's seconds.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidInput(f"n (worlds) must be a positive integer, got {n!r}")
        if not isinstance(grasp, OpenLoopGrasp):
            raise InvalidInput(f"grasp must be an OpenLoopGrasp, got {type(grasp).__name__}")
        if np.any(np.abs(np.abs(grasp.poses[:, 3:] @ grasp.poses[0, 3:]) - 1.0) > 1e-9):
            raise InvalidInput("OpenLoopController: the stages turn the palm; the arm here carries it without turning")
        per_target = APPROACH_TARGET_SECONDS / control_period
        if round(per_target) < 1 or abs(per_target - round(per_target)) > 1e-6:
            raise InvalidInput(f"control_period must divide an approach target's {APPROACH_TARGET_SECONDS:g} s, got "
                               f"{control_period!r}")
        self.n, self.grasp, self.control_period = int(n), grasp, float(control_period)
        self.targets, self.periods_per_target = int(approach_targets), int(round(per_target))
        self.initial = grasp.postures[0].copy()
        to_palm = invert(np.zeros(3), grasp.poses[0, 3:])[1]
        self.offsets = np.array([rotate(pose[:3] - grasp.poses[0, :3], to_palm) for pose in grasp.poses])
        self.moves_palm = bool(np.any(self.offsets != 0.0))
        self.reset()

    def reset(self) -> None:
        """Start the grasp again in every world."""
        self.cycle = np.zeros(self.n, dtype=int)
        self.attempt = np.ones(self.n, dtype=int)
        self.done = np.zeros(self.n, dtype=bool)
        self.palm_offset = np.zeros((self.n, 3))

    def restart(self, worlds: np.ndarray, joints: np.ndarray, segment_forces: np.ndarray) -> None:
        """The next attempt in these worlds, whose grasp failed the lift probe: the plan executed again from its
        pregrasp (nothing sensed is read: it is the open loop).

        Args:
            worlds: the worlds' indices (m,).
            joints: (m, 22) rad (not read).
            segment_forces: (m, segments) N (not read).
        """
        worlds = np.asarray(worlds, dtype=int)
        self.cycle[worlds], self.done[worlds] = 0, False
        self.attempt[worlds] += 1

    def step(self, joints: np.ndarray, segment_forces: np.ndarray) -> np.ndarray:
        """One control period: the approach's target for it (what is sensed is not read).

        Args:
            joints: (N, 22) rad (not read).
            segment_forces: (N, segments) N (not read).

        Returns:
            (N, 22) rad, the targets.
        """
        moves = len(self.grasp.postures) - 1
        target = np.minimum(self.cycle // self.periods_per_target, moves * self.targets - 1)  # 0-based, every move
        move, k = np.divmod(target, self.targets)
        t = ((k + 1) / self.targets)[:, None]
        posture = (1 - t) * self.grasp.postures[move] + t * self.grasp.postures[move + 1]
        self.palm_offset[:] = (1 - t) * self.offsets[move] + t * self.offsets[move + 1]
        self.cycle += 1
        self.done[:] = self.cycle >= moves * self.targets * self.periods_per_target
        return posture


@dataclass(frozen=True, eq=False)
class OpenLoop:
    """The factory of `OpenLoopController`s of one grasp, for `TrialSetup(controller=...)` (picklable).

    Attributes:
        grasp: the open-loop grasp.
    """

    grasp: OpenLoopGrasp

    def __post_init__(self) -> None:
        if not isinstance(self.grasp, OpenLoopGrasp):  # was met only when the trials made their controllers
            raise InvalidInput(f"OpenLoop.grasp must be an OpenLoopGrasp (open_loop_grasp makes one), got "
                               f"{type(self.grasp).__name__}")

    def __call__(self, n: int, hand: HandModel) -> OpenLoopController:
        """A controller of the grasp for n worlds.

        Args:
            n: worlds.
            hand: the hand model.

        Returns:
            The controller.
        """
        return OpenLoopController(n, self.grasp)
