import numpy as np
import pytest


def pytest_addoption(parser):
    parser.addoption("--seed", type=int, default=20261122, help="seed of the randomised tests")
    parser.addoption("--count", type=int, default=1000, help="number of random cases per randomised test")


@pytest.fixture
def rng(request):
    return np.random.default_rng(request.config.getoption("--seed"))


@pytest.fixture
def count(request):
    return request.config.getoption("--count")


@pytest.fixture(scope="session")
def claims_ctx(request):
    """The twins and expensive runs of the claims' checks (tendyn.claims), shared by every test file of a session:
    the tests and `tendyn claims` run the same definitions."""
    from tendyn.claims import Context

    return Context(quick=False, seed=request.config.getoption("--seed"), count=request.config.getoption("--count"))
