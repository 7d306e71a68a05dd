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


# ---- the quick runs of the S1 and S2 pipelines, once per session (~40 s each) ---------------------------------
# test_s1.py and test_s2_ident.py check their numbers; test_reports.py publishes them as HTML reports.

@pytest.fixture(scope="session")
def s1_quick_report():
    """``run_s1(mcgill_bench, quick=True)``: the S1Report of `tendyn pipeline s1 --quick`."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.pipelines.s1 import run_s1

    return run_s1(load_device(bundled("mcgill_bench")), quick=True)


@pytest.fixture(scope="session")
def s2_quick_report():
    """``run_s2(cea_branch, quick=True, seed=0)``: the S2Report of `tendyn pipeline s2 --quick`."""
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.pipelines.s2 import run_s2

    return run_s2(load_device(bundled("cea_branch")), quick=True, seed=0)
