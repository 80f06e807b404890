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


#: the test files that take longest (about a minute of one core or more, measured from a clean clone): they are
#: handed to the workers first, so that no long file starts last while the other worker has nothing left to do
#: (`--dist loadfile` hands out files in collection order)
LONGEST_FIRST = ("test_reproduce.py", "test_meshes.py", "test_readme.py", "test_learning_curve.py",
                 "test_last_bits.py", "test_uncertainty.py", "test_recipes.py", "test_generator.py", "test_dataset.py",
                 "test_examples.py", "test_hand_models.py", "test_dexgraspbench.py", "test_flange.py")


def pytest_collection_modifyitems(items):
    """The longest files first, the rest in their order (a stable sort: each file's tests stay together, in order)."""
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
