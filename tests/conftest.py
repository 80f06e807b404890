import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(params=["compiled", "numpy"])
def engine(request) -> str:
    """Run a test with the compiled kernels and again with their NumPy references."""
    from graspmanifold.manifold import kernels

    previous = kernels.use_compiled(request.param == "compiled")
    yield request.param
    kernels.use_compiled(previous)
