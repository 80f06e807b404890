"""The Gymnasium environment of the tactile grasp task: Gymnasium's checker, a random and a controller-driven
episode (the latter the trial `evaluate` runs on the same pose), the vector environment against the single one."""

import warnings

import numpy as np
import pytest

import graspmanifold as gm

gymnasium = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

from graspmanifold.control.controller import BatchController  # noqa: E402
from graspmanifold.envs import TACTILE_GRASP, TactileGraspEnv, TactileGraspVectorEnv  # noqa: E402
from graspmanifold.trials.grid import check_grid  # noqa: E402
from graspmanifold import InvalidInput  # noqa: E402


def _drive(env, controller, obs):
    """Our controller's targets and its done flag until the episode ends: (steps, reward, info)."""
    steps = 0
    while True:
        targets = controller.step(obs[None, :22], obs[None, 22:44])
        obs, reward, terminated, truncated, info = env.step(np.append(targets[0], float(controller.done[0])))
        steps += 1
        if terminated or truncated:
            return steps, reward, info


@pytest.mark.parametrize("pcp", [False, True])
def test_the_environment_passes_gymnasiums_checker_and_is_registered(pcp):
    env = gymnasium.make(TACTILE_GRASP, object="box", pcp=pcp)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its advice on unnormalised Box bounds: the actions are radians
        check_env(env.unwrapped)
    assert env.observation_space.shape == (22 + len(gm.SEGMENTS) + (22 if pcp else 0),)
    assert env.action_space.shape == (23,)
    with pytest.raises(ValueError, match="render_mode must be None or 'rgb_array'"):
        TactileGraspEnv(render_mode="human")


def test_a_random_episode_ends_in_a_judgement():
    env = TactileGraspEnv(object="box", max_seconds=0.2)
    env.action_space.seed(0)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs) and info["pose"].shape == (4,)
    for step in range(100):
        action = env.action_space.sample()
        action[-1] = 0.0  # never done: the time limit judges it
        obs, reward, terminated, truncated, info = env.step(action)
        if terminated:
            break
    assert terminated and step == 9 and info["judged"] and reward in (0.0, 1.0) and reward == float(info["hold"])
    assert env.observation_space.contains(obs) and env.render() is None  # no render_mode asked for
    drawn = TactileGraspEnv(object="box", render_mode="rgb_array")
    drawn.reset(seed=0)
    try:
        image = drawn.render()
    except gm.RenderingUnavailable:  # no offscreen OpenGL here: the library says so
        return
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8 and image.std() > 0


def test_the_papers_controller_through_the_environment_holds_what_evaluate_reports():
    """Our controller (the paper's reading, recalling from a SOM) driving the environment grasps every pose as
    `evaluate` does: the same hold, the same epsilon."""
    som = gm.SOM(5, 5, 22, seed=0).fit(gm.open_posture() + np.linspace(0.1, 0.9, 40)[:, None]
                                        * (gm.closed_posture() - gm.open_posture()))
    poses = check_grid("quick", gm.get_object("cylinder"))[1][::8]
    evaluated = gm.evaluate("cylinder", som, poses, seed=0, workers=1, progress=False)
    env = TactileGraspEnv(object="cylinder")
    for pose, trial in zip(poses, evaluated.trials):
        obs, _ = env.reset(seed=0, options={"pose": pose})
        steps, reward, info = _drive(env, BatchController(1, som), obs)
        assert info["hold"] == trial.hold and reward == float(trial.hold)
        assert info["epsilon"] == pytest.approx(trial.epsilon, abs=1e-9)
        assert steps * env.control_period == pytest.approx(trial.time_to_grasp)


def test_the_vector_environment_gives_each_world_the_single_environments_episode():
    """World i of the vector environment reset with seed s runs the episode of the single environment reset with
    s + i (the same pose, the same outcome under the same controller); an ended world starts anew next step."""
    n, seed = 3, 11
    vector = gymnasium.make_vec(TACTILE_GRASP, num_envs=n, vectorization_mode="vector_entry_point", object="box")
    assert isinstance(vector.unwrapped, TactileGraspVectorEnv)
    obs, info = vector.reset(seed=seed)
    controller, ended = BatchController(n), np.zeros(n, dtype=bool)
    outcome = {}
    for step in range(400):
        targets = controller.step(obs[:, :22], obs[:, 22:44])
        obs, rewards, terminated, truncated, infos = vector.step(np.column_stack([targets, controller.done]))
        for world in np.flatnonzero(terminated & ~ended):
            outcome[world] = (step + 1, rewards[world], infos["epsilon"][world])
        ended |= terminated
        if ended.all():
            break
    assert len(outcome) == n
    single = TactileGraspEnv(object="box")
    for world in range(n):
        first, single_info = single.reset(seed=seed + world)
        assert np.array_equal(single_info["pose"], info["pose"][world])
        steps, reward, judged = _drive(single, BatchController(1), first)
        assert (steps, reward) == outcome[world][:2] and judged["epsilon"] == pytest.approx(outcome[world][2], abs=1e-12)
    last = np.flatnonzero(terminated)  # those that ended at the last step start anew at the next
    again, rewards, restarted, _, _ = vector.step(np.zeros((n, 23)))
    assert len(last) and not restarted[last].any() and (rewards[last] == 0).all()
    assert np.allclose(again[last, :22], gm.open_posture(), atol=0.05)


def test_with_a_palm_the_action_steers_the_flange_and_the_lift_judges_the_episode():
    from graspmanifold.sim.flange import FlangeLimits

    env = TactileGraspEnv(object="box", palm=FlangeLimits(speed=0.05), max_seconds=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env)
    assert env.action_space.shape == (29,) and env.observation_space.shape == (22 + len(gm.SEGMENTS) + 6,)
    assert np.allclose(env.action_space.high[22:28], [0.25] * 3 + [1.0] * 3)
    obs, _ = env.reset(seed=0)
    hold = np.append(env.scene.posture(), np.zeros(7))
    for _ in range(10):  # the palm's target 1 cm along its x: reached at 5 cm/s, in about 0.2 s
        obs, *_ = env.step(np.concatenate([hold[:22], [0.01, 0, 0, 0, 0, 0], [0.0]]))
    assert abs(obs[-6] - 0.01) < 2e-3 and np.abs(obs[-5:]).max() < 1e-3 and np.allclose(obs[-6:], env.scene.flange())
    with pytest.raises(InvalidInput, match="palm"):
        TactileGraspEnv(palm="yes")
    lifted = TactileGraspEnv(object="box", protocol="lift", max_seconds=0.1)  # the lift brings its arm
    assert lifted.action_space.shape == (29,)
    lifted.reset(seed=0)
    *_, terminated, _, info = lifted.step(np.append(lifted.scene.posture(), np.append(np.zeros(6), 1.0)))
    assert terminated and info["judged"] and not info["hold"]  # an open hand lifts nothing
