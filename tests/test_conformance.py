"""Every implementation of the library's interfaces meets its contract (`trials.conformance`)."""

import os

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.control.controller import BLEND, BatchController
from graspmanifold.manifold.experience import check_experience
from graspmanifold.sim.worlds import CpuWorlds
from graspmanifold.trials.conformance import check_controller_contract, check_experience_contract, check_worlds_contract


@pytest.mark.parametrize("kind", ["database", "som", "ukr", "linear", "posture_set"])
def test_every_experience_meets_the_contract(kind, rng):
    postures = rng.uniform(-0.2, 1.2, (80, 22))
    experience = {
        "database": lambda: gm.PostureDatabase(postures),
        "som": lambda: gm.SOM(5, 6, 22, seed=0).fit(postures, epochs=3),
        "ukr": lambda: gm.UKR(2, iterations=5).fit(postures, progress=False),
        "linear": lambda: gm.LinearManifold(4).fit(postures),
        "posture_set": lambda: check_experience(gm.PostureSet(
            postures=postures, hand_poses=np.tile([0, 0, 0, 1, 0, 0, 0.0], (80, 1)), start_ids=np.zeros(80, int),
            contacts=np.ones((80, len(gm.SEGMENTS)), bool), epsilon=np.zeros(80), hold_displacement=np.zeros(80),
            start_names=("s",), metadata={})),
    }[kind]()
    check_experience_contract(experience)


def test_the_contract_catches_a_broken_experience(rng):
    class FirstRowAlways(gm.PostureDatabase):
        def best_match(self, x, mask=None):
            return 0

    with pytest.raises(AssertionError, match="not the nearest reference"):
        check_experience_contract(FirstRowAlways(rng.uniform(-0.2, 1.2, (40, 22))))


def test_cpu_worlds_meet_the_contract():
    check_worlds_contract(CpuWorlds)


def test_the_contract_catches_worlds_that_step_too_little():
    class StepsOnce(CpuWorlds):
        def step(self, worlds, nstep):
            return super().step(worlds, 1)

    with pytest.raises(AssertionError, match="by nstep timesteps"):
        check_worlds_contract(StepsOnce)


def test_the_contract_catches_worlds_that_do_not_steer_their_flanges():
    class FlangesStuck(CpuWorlds):
        def steer_flanges(self, worlds, targets, period):
            pass

    with pytest.raises(AssertionError, match="steering a flange"):
        check_worlds_contract(FlangesStuck)


def test_warp_worlds_meet_the_contract():
    pytest.importorskip("mujoco_warp")
    from graspmanifold.sim.warp_worlds import WarpWorlds

    try:
        check_worlds_contract(WarpWorlds.from_scenes, atol=2e-3)
    except gm.BackendUnavailable as error:
        pytest.skip(str(error))


def _example(heading: str) -> dict:
    """Run the code block under a heading of the API reference's pages (docs/api/); its names."""
    import re
    from pathlib import Path

    pages = sorted((Path(__file__).resolve().parents[1] / "docs" / "api").glob("*.md"))
    page = "\n".join(p.read_text() for p in pages)
    code = re.search(rf"## {re.escape(heading)}\n.*?```python\n(.*?)```", page, re.S).group(1)
    names: dict = {}
    exec(code, names)  # noqa: S102 - the library's own documented example
    return names


@pytest.mark.parametrize("kind", ["none", "database", "som"])
@pytest.mark.parametrize("params", [gm.ControllerParams(), BLEND], ids=["target", "blend"])
def test_our_controller_meets_the_contract(kind, params, rng):
    postures = np.array([s.posture for s in gm.starting_postures("cylinder")])
    experience = {"none": None, "database": gm.PostureDatabase(postures),
                  "som": gm.SOM(3, 3, 22, seed=0).fit(postures, epochs=3, progress=False)}[kind]
    check_controller_contract(lambda n, hand: BatchController(n, experience, params, hand=hand))


def test_the_contract_catches_a_controller_that_ignores_touch_or_returns_nan():
    class Blind(BatchController):  # closes as the heuristic does, whatever it feels
        def step(self, joints, segment_forces):
            return super().step(joints, np.zeros_like(segment_forces))

    class Broken(BatchController):
        def step(self, joints, segment_forces):
            targets = super().step(joints, segment_forces)
            targets[:, 3] = np.nan
            return targets

    with pytest.raises(AssertionError, match="ignores touch"):
        check_controller_contract(lambda n, hand: Blind(n, hand=hand))
    with pytest.raises(AssertionError, match="non-finite targets"):
        check_controller_contract(lambda n, hand: Broken(n, hand=hand))


def test_a_users_own_controller_runs_through_evaluate_on_our_poses_and_is_compared_with_ours():
    """The API reference's example: a 20-line controller of one's own meets the
    contract, runs through `evaluate` on the poses ours runs on, and `study.compare` pairs the two."""
    names = _example("A controller of one's own")
    mine, ours = names["mine"], names["ours"]
    check_controller_contract(names["CloseUntilTouch"])
    assert mine.method == "close_until_touch" and len(mine.trials) == len(ours.trials) == 8
    assert np.array_equal([t.grid_pose for t in mine.trials], [t.grid_pose for t in ours.trials])
    paired = gm.compare(mine, ours)
    assert paired.n == 8 and paired.both + paired.only_a + paired.only_b + paired.neither == 8
    assert all(t.matches == 0 and t.valid for t in mine.trials)
    with pytest.raises(ValueError, match="method label"):
        gm.evaluate("cylinder", None, ours.trials[0].grid_pose, controller=names["CloseUntilTouch"])
    with pytest.raises(ValueError, match="brings its own experience"):
        gm.evaluate("cylinder", gm.PostureDatabase(np.zeros((2, 22))), ours.trials[0].grid_pose,
                    controller=names["CloseUntilTouch"], method="x")


def test_a_users_own_experience_meets_the_contract_and_is_recalled_in_a_trial():
    """The API reference's example of an experience base of one's own."""
    names = _example("An experience base of one's own")
    check_experience_contract(names["mine"])
    result = names["result"]
    assert result.method == "one_by_one" and len(result.trials) == 4
    assert sum(t.matches for t in result.trials) > 0


@pytest.mark.parametrize("name", ["box", "cylinder", "sphere", "marble", "pen"])
def test_warp_buffers_hold_a_closed_hand_on_every_object(name, monkeypatch):
    """The contacts and constraint rows Warp allocates per world (`warp_worlds.CONTACTS_PER_WORLD`,
    `CONSTRAINTS_PER_WORLD`) hold a hand closed hard on each object, with room to spare; on Warp's CPU device
    where no GPU is lent (`GRASPMANIFOLD_WARP_DEVICE`); skipped without the gpu extra."""
    pytest.importorskip("mujoco_warp")
    monkeypatch.setenv("GRASPMANIFOLD_WARP_DEVICE", os.environ.get("GRASPMANIFOLD_WARP_DEVICE", "cpu"))
    from graspmanifold.sim import warp_worlds
    from graspmanifold.trials.benchmark import OBJECTS
    from graspmanifold.trials.grid import check_grid
    from graspmanifold.trials.episode import trial_scene
    from graspmanifold.trials.setup import TrialSetup

    obj = OBJECTS[name].object
    poses = check_grid("quick", obj)[1][:2] if name in gm.PAPER_OBJECTS else np.array([[0.0, 0.0, 0.01, 0.0]])
    scenes = [trial_scene(TrialSetup(object=obj), pose, np.random.default_rng(0), gm.open_posture()) for pose in poses]
    worlds = warp_worlds.WarpWorlds.from_scenes(scenes)
    everyone = np.arange(worlds.n)
    worlds.set_targets(everyone, np.tile(gm.closed_posture(), (worlds.n, 1)))  # the whole hand, squeezing
    peak_contacts, peak_rows = 0, 0
    for _ in range(40):  # 0.8 s: closed and pressing
        assert not worlds.step(everyone, 10)
        peak_contacts = max(peak_contacts, int(worlds._d.nacon.numpy()[0]))
        peak_rows = max(peak_rows, int(np.max(worlds._d.nefc.numpy())))
    print(f"{name}: at most {peak_contacts} contacts in {worlds.n} worlds, {peak_rows} constraint rows in one")
    assert not worlds.overflow().any()
    assert worlds.segment_forces(everyone).sum() > 0  # it does touch the object
    assert peak_contacts <= 0.5 * warp_worlds.CONTACTS_PER_WORLD * worlds.n, peak_contacts
    assert peak_rows <= 0.5 * warp_worlds.CONSTRAINTS_PER_WORLD, peak_rows
