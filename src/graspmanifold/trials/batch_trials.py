"""Grasp trials in batches: `trial.run_trial` for N grid poses at once.

Every world goes through the single trial's steps (support spring, controller until done,
release, six-direction hold test, margin ramp, epsilon at release) on its own clock of control
periods, but the controller is one `BatchController` for all of them and the physics is one
`Worlds` object (`worlds.CpuWorlds`, or `warp_worlds.WarpWorlds` on a GPU), so nothing is done
per trial in Python except the rare moments a world moves from one stage of its judging to the
next. With the CPU worlds the trials are those of `run_trial`, bit for bit (tests/test_batch.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..base.errors import QualityError
from ..control.batch_controller import BatchController, row_norms
from ..control.judge import HOLD_DIRECTIONS, JUDGING, reading_epsilon
from ..sim.hand import N_FINGER_JOINTS, SEGMENTS
from ..sim.scene import GRAVITY
from ..sim.worlds import CpuWorlds, Worlds
from .trial import Noise, Trial, TrialSetup, trial_scene

_GRASP, _HOLD, _MARGIN, _FINISHED = range(4)


def make_worlds(setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator],
                initial: np.ndarray) -> Worlds:
    """The trial scenes of these grid poses (placed as `run_trial` places them) on the set-up's backend."""
    scenes = [trial_scene(setup, pose, rng, initial) for pose, rng in zip(poses, rngs)]
    if setup.backend == "cpu":
        return CpuWorlds(scenes)
    from ..sim.warp_worlds import WarpWorlds

    return WarpWorlds(scenes)


def run_trials(setup: TrialSetup, poses: np.ndarray, rngs: Sequence[np.random.Generator]) -> list[Trial]:
    """One trial per grid pose, as `run_trial(setup, pose, rng)` runs it, all at once."""
    poses = np.asarray(poses, dtype=float)
    controller = BatchController(len(poses), setup.experience, setup.params, preshape=setup.preshape)
    worlds = make_worlds(setup, poses, rngs, controller.initial)
    return _judged_trials(worlds, controller, poses, rngs, setup.noise, setup.object.friction)


def _judged_trials(worlds: Worlds, controller: BatchController, poses: np.ndarray,
                   rngs: Sequence[np.random.Generator], noise: Noise, friction: float) -> list[Trial]:
    """Run every world's grasp and judging to the end (see `judge.judge_grasp` for the judging)."""
    n, period = worlds.n, controller.params.control_period
    nstep = max(1, round(period / worlds.scenes[0].model.opt.timestep))
    hold_cycles = JUDGING.cycles(JUDGING.hold_seconds, period)
    margin_cycles = JUDGING.cycles(JUDGING.margin_seconds, period)
    stage = np.full(n, _GRASP)
    direction = np.zeros(n, dtype=int)  # which of HOLD_DIRECTIONS the judging is at
    count = np.zeros(n, dtype=int)  # control cycles done in that direction (the margin ramp's k)
    start = np.zeros((n, 3))
    worst = np.zeros(n)
    held_force = np.zeros(n)
    trials: list[Trial | None] = [None] * n
    grasped: dict[int, tuple] = {}

    def finish(world: int) -> None:
        stage[world] = _FINISHED
        reading, posture, epsilon = grasped.pop(world)
        trials[world] = Trial(poses[world], posture, np.array([reading.touches(s) for s in SEGMENTS]), epsilon,
                              bool(worst[world] <= JUDGING.hold_limit), float(worst[world]),
                              float(controller.time_to_grasp[world]), int(controller.matches[world]),
                              float(held_force[world]), worlds.max_penetration(world),
                              winners=np.array(controller.winners[world], dtype=int))

    def fail(world: int, why: str) -> None:
        stage[world] = _FINISHED
        grasped.pop(world, None)
        trials[world] = Trial(poses[world], worlds.posture(world), np.zeros(len(SEGMENTS), dtype=bool), 0.0,
                              False, np.inf, worlds.time(world), int(controller.matches[world]), 0.0,
                              worlds.max_penetration(world), why, np.array(controller.winners[world], dtype=int))

    while (stage != _FINISHED).any():
        # judging begins for the worlds whose grasp ended in the last period
        begin = np.flatnonzero((stage == _GRASP) & controller.done)
        if len(begin):
            worlds.release(begin)
            positions = worlds.object_positions()
            for world in begin:
                reading, centre = worlds.reading(world)
                try:
                    epsilon = reading_epsilon(reading, centre, friction)
                except QualityError as error:
                    fail(world, str(error))
                    continue
                grasped[world] = (reading, worlds.posture(world), epsilon)
                start[world] = positions[world]
            begin = begin[stage[begin] == _GRASP]
            stage[begin], direction[begin], count[begin] = _HOLD, 0, 0
            worlds.set_gravity(begin, np.tile(GRAVITY * HOLD_DIRECTIONS[0], (len(begin), 1)))
        # the hold test: hold_cycles periods per gravity direction
        turn = np.flatnonzero((stage == _HOLD) & (count == hold_cycles))
        direction[turn] += 1
        count[turn] = 0
        done_holding = turn[direction[turn] == len(HOLD_DIRECTIONS)]
        held = done_holding[worst[done_holding] <= JUDGING.hold_limit]
        for world in np.setdiff1d(done_holding, held):
            finish(world)
        stage[held], direction[held], count[held], held_force[held] = _MARGIN, 0, 0, JUDGING.margin_force
        turn = turn[stage[turn] == _HOLD]
        worlds.set_gravity(turn, GRAVITY * HOLD_DIRECTIONS[direction[turn]])
        # the margin: a push ramping up over margin_cycles periods per direction
        ramp = np.flatnonzero(stage == _MARGIN)
        count[ramp] += 1
        turn = ramp[count[ramp] > margin_cycles]
        direction[turn] += 1
        count[turn] = 1
        for world in turn[direction[turn] == len(HOLD_DIRECTIONS)]:
            worlds.push(np.array([world]), np.zeros((1, 3)))
            finish(world)
        ramp = ramp[stage[ramp] == _MARGIN]
        worlds.set_gravity(ramp, GRAVITY * HOLD_DIRECTIONS[direction[ramp]])
        worlds.push(ramp, (JUDGING.margin_force * count[ramp] / margin_cycles)[:, None] * HOLD_DIRECTIONS[direction[ramp]])

        live = np.flatnonzero(stage != _FINISHED)
        if not len(live):
            break
        # one control period: the controller, then the physics
        # finished worlds are not read (a failed world's state may not be finite); their controller no longer matters
        sensed, forces = np.tile(controller.initial, (n, 1)), np.zeros((n, len(SEGMENTS)))
        sensed[live], forces[live] = worlds.joints(live), worlds.segment_forces(live)
        if noise.joints:
            for world in np.flatnonzero(stage == _GRASP):
                sensed[world] += rngs[world].normal(0.0, noise.joints, N_FINGER_JOINTS)
        targets = controller.step(sensed, forces)
        worlds.set_targets(live, targets[live])
        if controller.params.reach > 0:  # the arm carries each palm where its recalled grasp wants it
            worlds.shift_hands(live, controller.palm_offset[live])
        for world, why in worlds.step(live, nstep).items():
            fail(world, why)
        with np.errstate(invalid="ignore"):
            moved = row_norms(worlds.object_positions() - start)
        holding = np.flatnonzero(stage == _HOLD)
        worst[holding] = np.maximum(worst[holding], moved[holding])
        count[holding] += 1
        ramp = np.flatnonzero(stage == _MARGIN)
        for world in ramp[moved[ramp] > JUDGING.hold_limit]:
            held_force[world] = JUDGING.margin_force * (count[world] - 1) / margin_cycles
            worlds.push(np.array([world]), np.zeros((1, 3)))
            finish(world)
    return trials
