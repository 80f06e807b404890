import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(params=["compiled", "numpy"])
def engine(request) -> str:
    """Run a test with the compiled kernels and again with their NumPy references."""
    from graspmanifold.base import compiled as switch

    previous = switch.use_compiled(request.param == "compiled")
    yield request.param
    switch.use_compiled(previous)


@pytest.fixture(autouse=True, scope="session")
def _own_cache(tmp_path_factory):
    """The searched starting postures go to a folder of this test session's, not the user's cache (set before
    any worker process starts, so the workers share it)."""
    import os

    previous = os.environ.get("GRASPMANIFOLD_CACHE")
    os.environ["GRASPMANIFOLD_CACHE"] = str(tmp_path_factory.mktemp("cache"))
    yield
    if previous is None:
        os.environ.pop("GRASPMANIFOLD_CACHE")
    else:
        os.environ["GRASPMANIFOLD_CACHE"] = previous


@pytest.fixture(scope="session")
def box_plans():
    """Two verified grasps of the box (one of every grasp type's design) and their plans: the planned trials' tests."""
    from graspmanifold.judging.plans import open_loop_grasps
    from graspmanifold.synthesis.generator import GeneratorParams, generate_postures

    postures = generate_postures("box", 2, seed=0, workers=1, progress=False,
                                 params=GeneratorParams(designs="grasp_types"))
    return postures, open_loop_grasps(postures)
