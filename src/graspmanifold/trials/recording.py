"""One trial run as `evaluate` runs it, with the scene's state kept along the way for pictures and animations
(`record_trial`, `Recording`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base.errors import InvalidInput
from ..base.validation import check_int
from ..judging.protocols import DEFAULT_PROTOCOL, JudgingProtocol, get_protocol
from ..manifold.experience import Experience
from ..sim.objects import GraspObject
from ..sim.scene import Scene
from ..sim.worlds import Worlds
from .grid import check_grid, grid_preset, reachable
from .episode import run_trial
from .record import Trial
from .setup import TrialSetup


@dataclass
class Recording:
    """A trial with the scene's state every `period` seconds, for pictures and animations."""

    trial: Trial
    scene: Scene
    states: np.ndarray  # (k, len(Scene.state()))
    period: float

    def frames(self, camera: str = "hand", width: int = 320, height: int = 240) -> np.ndarray:
        """Pictures of every recorded state from a named camera.

        Args:
            camera: one of `scene.CAMERAS`, or `render.THUMB_SIDE`.
            width: pixels.
            height: pixels.

        Returns:
            (k, height, width, 3) uint8.
        """
        from ..sim.render import render_states

        return render_states(self.scene, self.states, camera, width, height)

    def save_gif(self, path: str | os.PathLike, camera: str = "hand", width: int = 320, height: int = 240,
                 speed: float = 1.0) -> Path:
        """An animated GIF of the trial.

        Args:
            path: the file, ending in .gif.
            camera: one of `scene.CAMERAS`, or `render.THUMB_SIDE`.
            width: pixels.
            height: pixels.
            speed: times real time.

        Returns:
            The path written.
        """
        from ..sim.render import save_animation

        return save_animation(self.frames(camera, width, height), path, fps=speed / self.period)


#: (x, z, gap, yaw) m and rad: the pose `record_trial` records by default, the object centred 1 cm from the palm
RECORDED_POSE = (0.0, 0.0, 0.01, 0.0)


def _recorded_pose(setup: TrialSetup) -> np.ndarray:
    """`RECORDED_POSE` where a trial can start there, else the nearest pose of the object's quick grid."""
    pose = np.array([RECORDED_POSE])
    if setup.plan is not None or reachable(setup.object, pose, setup.table)[0]:
        return pose[0]
    quick = grid_preset("quick", setup.object, setup.table)
    return quick[int(np.argmin(np.linalg.norm((quick - pose)[:, :3], axis=1)))]


def record_trial(obj: str | GraspObject | TrialSetup, experience: Experience | None = None,
                 grid_pose: Iterable[float] | None = None, seed: int = 0, *, every: int = 2,
                 **fields: object) -> Recording:
    """Run one trial as `evaluate` runs it at a grid pose (any `TrialSetup`: a protocol, a regrasp, one's own
    controller); keep the scene's state along the way.

    `record_trial("box").save_gif("grasp.gif")` animates it; `recording.scene.render()` draws its final state.

    Args:
        obj: the object, or its name; or a whole `TrialSetup`.
        experience: the experience base (None: the plain tactile controller), as `evaluate` takes it.
        grid_pose: (x, z, gap, yaw) in m and rad; refused as `evaluate` refuses it (`why_unreachable` says why).
            None: `RECORDED_POSE` where the open hand can start there, else the nearest pose of the object's quick
            grid (a large object does not fit 1 cm from the palm).
        seed: the trial's seed (trial 0 of `evaluate` with this seed).
        every: keep the state every this many control periods.
        **fields: the `TrialSetup` fields by name, as `evaluate` takes them; `margin` is on unless given (a
            recording shows the whole judging, the pushes included) where the protocol allows it (ours).

    Returns:
        The recording: the trial's outcome, its scene and the kept states.

    Raises:
        ValueError: a bad pose or set-up; the 'warp' backend (a recording runs on the CPU).
    """
    if not isinstance(obj, TrialSetup) and "margin" not in fields:
        protocol = fields.get("protocol", DEFAULT_PROTOCOL)
        if isinstance(protocol, (str, JudgingProtocol)):  # anything else the set-up refuses by name
            fields["margin"] = get_protocol(protocol).physics is None
    setup = TrialSetup.build(obj, experience, **fields)
    if setup.backend != "cpu":
        raise InvalidInput(f"record_trial runs on the cpu backend (it keeps the scene's states), not {setup.backend!r}")
    check_int(every, "every (control periods)")
    grid_pose = _recorded_pose(setup) if grid_pose is None else np.asarray(tuple(grid_pose), dtype=float)
    if grid_pose.shape != (4,) or not np.all(np.isfinite(grid_pose)):
        raise InvalidInput(f"grid_pose must be four finite numbers (x, z, gap, yaw), got {grid_pose!r}")
    check_grid(grid_pose, setup.object, setup.table, setup.plan)  # refused as `evaluate` would refuse it
    states: list[np.ndarray] = []
    seen: dict[str, Scene] = {}

    def observe(worlds: Worlds) -> None:
        scene = seen["scene"] = worlds.scene  # the trial's one scene
        if not states or round(scene.time / period) % every == 0:
            states.append(scene.state())

    period = setup.params.control_period
    trial = run_trial(setup, grid_pose, np.random.default_rng([seed, 0]), observer=observe)
    return Recording(trial, seen["scene"], np.array(states), every * period)
