"""The contracts that every implementation of the library's three interfaces must meet, as checks one
can run on a new one (as scikit-learn's `check_estimator`): an experience base (`Experience`: the raw
database, the SOM, a user's own), a grasp controller (`Controller`: ours, a user's own) and worlds
stepped together (`Worlds`: CPU MuJoCo, MuJoCo Warp). The test suite runs them over every one it ships.

Each check raises `AssertionError` naming the promise that is broken, and returns None otherwise.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..control.controller import Controller, ControllerFactory
from ..manifold.experience import Experience
from ..sim.flange import FlangeLimits
from ..sim.hand import DISTAL_SEGMENTS, N_FINGER_JOINTS, SEGMENTS, SHADOW_HAND, HandModel
from ..sim.objects import GraspObject, get_object
from ..sim.posture import closed_posture, open_posture
from ..sim.scene import GRAVITY, Scene
from ..sim.tactile import TactileReading
from ..sim.worlds import Worlds
from .episode import trial_scene
from .setup import TrialSetup


def _masked_nearest(references: np.ndarray, x: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    """Eq. 2 by brute force: the masked squared distance of x to every reference."""
    weights = np.ones(references.shape[1]) if mask is None else np.asarray(mask, dtype=float)
    return ((np.where(weights > 0, x, 0.0) - references) ** 2 * weights).sum(axis=1)


def check_experience_contract(experience: Experience, *, queries: int = 20, seed: int = 0) -> None:
    """What the controller relies on of an experience base.

    Its references are a finite (k, 22) array; `best_match` gives the row nearest to the query under the
    masked distance of Eq. 2 (NaN allowed where the mask is 0), with boolean or weighted masks; the
    batch methods equal their one-query twins; `complete` is a finite posture (the matched reference in full for
    a SOM or a database; a recall of one's own may blend references there, and the controller recalls it); a
    query leaves the experience's answers unchanged (no hidden state).

    Args:
        experience: the implementation to check (fitted, for a SOM).
        queries: random queries to try.
        seed: of the queries.
    """
    assert isinstance(experience, Experience), f"{type(experience).__name__} lacks a method of the Experience protocol"
    references = np.asarray(experience.references)
    assert experience.dim == N_FINGER_JOINTS, f"dim is {experience.dim}, a grasp posture has {N_FINGER_JOINTS} joints"
    assert references.ndim == 2 and references.shape[1] == experience.dim and len(references), \
        f"references must be a non-empty (k, {experience.dim}) array, got shape {references.shape}"
    assert np.all(np.isfinite(references)), "references hold non-finite values"
    rng = np.random.default_rng(seed)
    low, high = references.min(axis=0), references.max(axis=0)
    X = rng.uniform(low, high, (queries, experience.dim))
    masks = rng.random((queries, experience.dim)) < 0.5
    masks[:, 0] = True  # never all zero
    weights = masks * rng.uniform(0.5, 2.0, masks.shape)
    before = experience.best_match_batch(X, masks)
    for x, mask, weight in zip(X, masks, weights):
        for given in (None, mask, weight):
            index = experience.best_match(x, given)
            assert isinstance(index, (int, np.integer)) and 0 <= index < len(references), \
                f"best_match returned {index!r}, not a row of references"
            distances = _masked_nearest(references, x, given)
            assert np.isclose(distances[index], distances.min(), rtol=1e-9, atol=1e-12), \
                f"best_match is not the nearest reference under the {'plain' if given is None else 'masked'} " \
                f"distance (Eq. 2): {distances[index]:.6g} against {distances.min():.6g}"
        hidden = np.where(mask, x, np.nan)
        assert experience.best_match(hidden, mask) == experience.best_match(x, mask), \
            "best_match reads the query where the mask is 0 (NaN there must be allowed)"
        recalled = np.asarray(experience.complete(x, mask))
        assert recalled.shape == (experience.dim,) and np.all(np.isfinite(recalled)), \
            f"complete must return a finite posture ({experience.dim},), got shape {recalled.shape}"
    np.testing.assert_array_equal(before, [experience.best_match(x, m) for x, m in zip(X, masks)],
                                  err_msg="best_match_batch differs from best_match")
    np.testing.assert_array_equal(experience.best_match_batch(X, masks[0]),
                                  [experience.best_match(x, masks[0]) for x in X],
                                  err_msg="best_match_batch with one shared mask differs from best_match")
    np.testing.assert_allclose(experience.complete_batch(X, masks), [experience.complete(x, m) for x, m in zip(X, masks)],
                               rtol=0, atol=1e-12, err_msg="complete_batch differs from complete")
    np.testing.assert_array_equal(experience.best_match_batch(X, masks), before,
                                  err_msg="the answers changed after queries: the experience keeps hidden state")


def check_controller_contract(make: ControllerFactory, hand: HandModel = SHADOW_HAND, *,
                              seconds: float = 10.0) -> None:
    """What the trials rely on of a grasp controller (`controller.Controller`).

    Made for two worlds, it is driven with readings made up here, the hand still in its open posture: world 0
    feels nothing, world 1 its index and thumb tips from 0.1 s on. It must have the protocol's members, a
    period of whole physics steps, an open posture and (2, 22) finite targets in the hand's ranges, act on
    touch (the worlds' targets come apart), keep the worlds apart (swapped worlds, swapped targets), start
    again on `reset`, and finish a grasp whose five fingertips touch within `seconds`.

    Args:
        make: builds the implementation: `make(n, hand)`.
        hand: the hand model it drives.
        seconds: how long a grasp may take, s of controller time.
    """
    controller = make(2, hand)
    assert isinstance(controller, Controller), f"{type(controller).__name__} lacks a member of the Controller " \
        "protocol (n, control_period, initial, done, reset, step)"
    period, low, high = controller.control_period, *hand.limits().T
    steps = period / hand.timestep if isinstance(period, (int, float)) and period > 0 else 0.0
    assert controller.n == 2 and steps >= 1 and abs(steps - round(steps)) < 1e-6, \
        f"n {controller.n} for 2 worlds, control_period {period!r} s for whole {hand.timestep} s physics steps"
    inside = lambda postures: np.all((postures >= low - 1e-9) & (postures <= high + 1e-9))  # noqa: E731
    initial = np.asarray(controller.initial, dtype=float)
    assert initial.shape == (N_FINGER_JOINTS,) and inside(initial), "initial must be 22 angles in the hand's ranges"
    touched = np.zeros((2, len(SEGMENTS)))
    touched[1, [SEGMENTS.index(DISTAL_SEGMENTS[0]), SEGMENTS.index(DISTAL_SEGMENTS[-1])]] = 1.0

    def drive(swap: bool) -> list[np.ndarray]:
        controller.reset()
        assert np.asarray(controller.done).shape == (2,) and not np.any(controller.done), "done must be (2,) False"
        targets = []
        for cycle in range(max(2, round(1.0 / period))):
            forces = touched[::-1] if swap else touched
            target = np.asarray(controller.step(np.tile(initial, (2, 1)), forces * (cycle * period >= 0.1)))
            assert target.shape == (2, N_FINGER_JOINTS), f"step returned shape {target.shape}, not (2, 22)"
            assert np.all(np.isfinite(target)), f"step returned non-finite targets in cycle {cycle}"
            assert inside(target), f"step returned targets outside the hand's ranges in cycle {cycle}"
            targets.append(target[::-1] if swap else target)
        return targets

    first = drive(swap=False)
    assert any(not np.array_equal(t[0], t[1]) for t in first), \
        "the targets do not depend on the segment forces: the controller ignores touch"
    for check, message in ((drive(swap=True), "a world's targets depend on another world's readings"),
                           (drive(swap=False), "reset does not start a new grasp: the same readings, other targets")):
        assert all(np.array_equal(a, b) for a, b in zip(first, check)), message
    controller.reset()
    tips = np.zeros((2, len(SEGMENTS)))
    tips[:, [SEGMENTS.index(s) for s in DISTAL_SEGMENTS]] = 1.0
    for _ in range(round(seconds / period)):
        controller.step(np.tile(initial, (2, 1)), tips)
        if np.all(controller.done):
            return
    raise AssertionError(f"a grasp whose five fingertips touch did not finish within {seconds} s")


def check_worlds_contract(make: Callable[[list[Scene]], Worlds], obj: GraspObject | None = None, *,
                          atol: float = 1e-6) -> None:
    """What the batched trials rely on of a set of worlds.

    Two trial scenes are handed to `make`; the same two, built again, are stepped one by one with CPU
    MuJoCo as the reference. The worlds must report shapes the batched controller reads, advance the
    worlds asked for by the steps asked (others may advance too: the batched trials never read a world
    they did not step), follow the reference within `atol` (rad, m), and let a released object fall
    under the gravity they are given; moving the palms (`shift_hands`) may be refused, with a message. Worlds made
    of scenes whose hands hang on a flange (`sim.flange`) report where the flanges are and where their slides point,
    and move a flange its bounded step towards a target each time it is steered; a backend without flanges may
    refuse them, with a message.

    Args:
        make: builds the implementation from a list of scenes (e.g. `CpuWorlds`).
        obj: the object of the scenes (default the cylinder).
        atol: how closely joints and object positions must follow CPU MuJoCo (float32 GPUs need ~1e-3).
    """
    obj = obj or get_object("cylinder")
    poses = np.array([[0.0, 0.0, 0.01, 0.0], [0.005, 0.0, 0.02, 0.1]])

    def scenes() -> list[Scene]:
        return [trial_scene(TrialSetup(object=obj), pose, np.random.default_rng(k), open_posture())
                for k, pose in enumerate(poses)]

    worlds, reference = make(scenes()), scenes()
    everyone, first = np.arange(2), np.array([0])
    assert worlds.n == 2, f"n is {worlds.n} for 2 scenes"
    assert worlds.joints(everyone).shape == (2, N_FINGER_JOINTS), "joints must be (worlds, 22)"
    assert worlds.segment_forces(everyone).shape == (2, len(SEGMENTS)), "segment_forces must be (worlds, segments)"
    assert worlds.object_positions().shape == (2, 3), "object_positions must be (n, 3)"
    closing = np.tile(0.5 * (open_posture() + closed_posture()), (2, 1))  # halfway to the closed hand
    worlds.set_targets(everyone, closing)
    for scene, target in zip(reference, closing):
        scene.set_target(target)
    failed = worlds.step(first, 25)
    assert failed == {}, f"a healthy step reported failures: {failed}"
    reference[0].step(25)
    assert np.isclose(worlds.time(0), 25 * reference[0].model.opt.timestep), \
        "step must advance the worlds asked for by nstep timesteps"  # others may advance too (Warp steps them all)
    np.testing.assert_allclose(worlds.joints(first)[0], reference[0].data.qpos[reference[0].finger_qpos], atol=atol,
                               err_msg="joints after stepping differ from CPU MuJoCo")
    np.testing.assert_allclose(worlds.posture(0), reference[0].posture(), atol=atol, err_msg="posture differs")
    reading, centre = worlds.reading(0)
    assert isinstance(reading, TactileReading) and np.asarray(centre).shape == (3,), \
        "reading must be a TactileReading and the object's centre of mass (3,)"
    assert np.isfinite(worlds.max_penetration(0)) and worlds.max_penetration(0) >= 0, "max_penetration must be >= 0"
    start = worlds.object_positions()[1].copy()
    worlds.release(np.array([1]))
    worlds.set_gravity(np.array([1]), GRAVITY * np.array([[0.0, 0.0, -1.0]]))
    worlds.push(np.array([1]), np.zeros((1, 3)))
    try:  # the palm's reach is optional (MuJoCo Warp has none), but a backend without it must say so
        worlds.shift_hands(np.array([1]), np.zeros((1, 3)))
    except NotImplementedError as error:
        assert str(error), "shift_hands, where a backend lacks it, must say what to use instead"
    worlds.step(np.array([1]), 50)
    assert worlds.object_positions()[1][2] < start[2] - 1e-3, "a released object did not fall under the gravity given"
    _check_flanges(make, obj, poses)


def _check_flanges(make: Callable[[list[Scene]], Worlds], obj: GraspObject, poses: np.ndarray) -> None:
    """The flange part of `check_worlds_contract`."""
    limits = FlangeLimits()
    scenes = [trial_scene(TrialSetup(object=obj, palm=limits), pose, np.random.default_rng(k), open_posture())
              for k, pose in enumerate(poses)]
    try:
        worlds = make(scenes)
        everyone = np.arange(2)
        home = worlds.flanges(everyone)
        axes = worlds.flange_axes(everyone)
        assert home.shape == (2, 6) and np.allclose(home, 0.0, atol=1e-6), "flanges must be (worlds, 6), home at 0"
        assert axes.shape == (2, 3, 3) and np.allclose(axes @ axes.transpose(0, 2, 1), np.eye(3), atol=1e-9), \
            "flange_axes must be (worlds, 3, 3), orthonormal rows"
        period = 0.02
        for _ in range(5):  # 5 periods towards 5 cm along the palm's x: at most 1 cm at 0.1 m/s
            worlds.steer_flanges(np.array([0]), np.array([[0.05, 0, 0, 0, 0, 0]]), period)
            worlds.step(np.array([0]), round(period / scenes[0].model.opt.timestep))
        moved = worlds.flanges(np.array([0]))[0, 0]
        assert 0.005 < moved <= 5 * limits.speed * period + 1e-3, \
            f"steering a flange 5 periods towards 5 cm moved it {moved * 1000:.1f} mm (its speed allows 10 mm)"
    except NotImplementedError as error:
        assert str(error), "flanges, where a backend lacks them, must say what to use instead"
