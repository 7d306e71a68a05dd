import os
import socket
import subprocess
import sys
import time
from pathlib import Path

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


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_cluster(tmp_path):
    """A real `dask scheduler` and `dask worker` processes (2 single-threaded workers) on free ports, started
    for the test and stopped afterwards; yields the scheduler address (issue 32)."""
    pytest.importorskip("distributed")
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ)
    exe = Path(sys.executable).parent / "dask"
    cmd = [str(exe)]
    if not exe.exists():
        pytest.skip("no dask command beside the interpreter")
    procs = [subprocess.Popen(cmd + ["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.time() + 30
        while time.time() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.2)
        procs.append(subprocess.Popen(cmd + ["worker", addr, "--nworkers", "2", "--nthreads", "1", "--no-dashboard",
                                             "--memory-limit", "0"], env=env, cwd=tmp_path,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from dask.distributed import Client

        with Client(addr, timeout="20s") as c:
            c.wait_for_workers(2, timeout=90)
        yield addr
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
