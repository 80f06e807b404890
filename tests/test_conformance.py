"""Every implementation of the library's interfaces meets its contract (`trials.conformance`)."""

import numpy as np
import pytest

import graspmanifold as gm
from graspmanifold.manifold.experience import check_experience
from graspmanifold.sim.worlds import CpuWorlds
from graspmanifold.trials.conformance import check_experience_contract, check_worlds_contract


@pytest.mark.parametrize("kind", ["database", "som", "posture_set"])
def test_every_experience_meets_the_contract(kind, rng):
    postures = rng.uniform(-0.2, 1.2, (80, 22))
    experience = {
        "database": lambda: gm.PostureDatabase(postures),
        "som": lambda: gm.SOM(5, 6, 22, seed=0).fit(postures, epochs=3),
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


def test_warp_worlds_meet_the_contract():
    pytest.importorskip("mujoco_warp")
    from graspmanifold.sim.warp_worlds import WarpWorlds

    try:
        check_worlds_contract(WarpWorlds, atol=2e-3)
    except gm.BackendUnavailable as error:
        pytest.skip(str(error))
