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


@pytest.fixture(scope="session")
def s1_quick_report(claims_ctx):
    """``run_s1(mcgill_bench, quick=True)``: the S1Report of `tendyn pipeline s1 --quick`, once per session, for
    the HTML report of test_reports.py (the JSON of the claims is tendyn.claims.twins.s1_json)."""
    from tendyn.claims import twins
    from tendyn.pipelines.s1 import run_s1

    return claims_ctx.get("s1_report", lambda: run_s1(twins.mcgill(claims_ctx), quick=True))


@pytest.fixture(scope="session")
def s2_quick_report(claims_ctx):
    """``run_s2(cea_branch, quick=True, seed=0)`` (tendyn.claims.twins.s2_report), once per session."""
    from tendyn.claims import twins

    return twins.s2_report(claims_ctx)
