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
    from graspmanifold.control.dexgraspbench import open_loop_grasps
    from graspmanifold.control.generator import GeneratorParams, generate_postures

    postures = generate_postures("box", 2, seed=0, workers=1, progress=False,
                                 params=GeneratorParams(designs="grasp_types"))
    return postures, open_loop_grasps(postures)


#: the test files that take longest, longest first (seconds of one core in a local run of 868 tests, 1,233 s in all:
#: reproduce 217, meshes 155, recipes 90, last_bits 82, generator 78, uncertainty 66, readme 65, learning_curve 59,
#: examples 47, dataset 47, trials 40, dexgraspbench 35). With `--dist loadfile` a worker takes a whole file; taken in
#: alphabetical order, a long file late left the other core idle at the end (a schedule of these sums: 648 s on two
#: workers in that order, 617 s longest first, 616 s the even split)
SLOWEST_FILES = ("test_reproduce.py", "test_meshes.py", "test_recipes.py", "test_last_bits.py", "test_generator.py",
                 "test_uncertainty.py", "test_readme.py", "test_learning_curve.py", "test_examples.py", "test_dataset.py",
                 "test_trials.py", "test_dexgraspbench.py")


def pytest_collection_modifyitems(items: list) -> None:
    """The slowest files first, the rest in their order (every worker collects in this same order)."""
    rank = {name: k for k, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
