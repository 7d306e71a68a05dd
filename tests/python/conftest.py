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


SHARED_RUNS = ("s0_report", "s1_report", "s2_report")
"""Runs of the claims' context computed once per parallel run, not once per worker (tens of seconds of CPU each,
picklable, seeded: the same object whichever worker makes it); the others are cheap or hold compiled models."""


def _shared_context(folder: Path | None, **kw):
    """A :class:`tendyn.claims.Context` whose :data:`SHARED_RUNS` go through ``folder`` (the run's temporary
    folder, common to the workers): the first worker to need one computes it under a file lock and pickles it, the
    others wait for the lock and read it. ``folder=None`` (one process): a plain context."""
    import fcntl
    import pickle

    from tendyn.claims import Context

    class WorkersContext(Context):
        def get(self, name, make):
            if folder is None or name in self._cache or name not in SHARED_RUNS:
                return super().get(name, make)
            path = folder / f"{name}.pickle"
            with open(folder / f"{name}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)          # released when the file closes, even on an error
                if path.is_file():
                    value = pickle.loads(path.read_bytes())
                else:
                    value = make()
                    try:
                        data = pickle.dumps(value)
                    except (pickle.PicklingError, TypeError, AttributeError):
                        data = None                        # not picklable: each worker makes its own
                    if data is not None:
                        part = path.with_suffix(f".part{os.getpid()}")
                        part.write_bytes(data)
                        part.replace(path)
            self._cache[name] = value
            return value

    return WorkersContext(**kw)


@pytest.fixture(scope="session")
def claims_ctx(request, tmp_path_factory):
    """The twins and expensive runs of the claims' checks (tendyn.claims), shared by every test file of a session:
    the tests and `tendyn claims` run the same definitions. In a parallel run the :data:`SHARED_RUNS` are computed
    by one worker for all (through the run's temporary folder, which pytest-xdist's workers have in common)."""
    folder = None
    if os.environ.get("PYTEST_XDIST_WORKER"):
        folder = tmp_path_factory.getbasetemp().parent / "claims-context"
        folder.mkdir(exist_ok=True)
    return _shared_context(folder, quick=False, seed=request.config.getoption("--seed"),
                           count=request.config.getoption("--count"))


@pytest.fixture(scope="session")
def s1_quick_report(claims_ctx):
    """``run_s1(mcgill_bench, quick=True)``: the S1Report of `tendyn pipeline s1 --quick`, once per session, for
    the HTML report of test_reports.py (the JSON of the claims is tendyn.claims.twins.s1_json)."""
    from tendyn.claims import twins

    return twins.s1_report(claims_ctx)


@pytest.fixture(scope="session")
def s0_quick_report(claims_ctx):
    """``run_s0(lexos, quick=True)``: the document of `tendyn pipeline s0 --quick` before the command prints and
    publishes it, once per parallel run (its S1/S2 runs of every transmission are ~8 s of CPU), for the command's
    JSON test (test_fig7.py) and its HTML report (test_reports.py). The command pops the table and figures out of
    the document: pass it a copy (:func:`s0_quick_run`)."""
    from tendyn.pipelines.s0 import run_s0

    return claims_ctx.get("s0_report", lambda: run_s0("lexos", quick=True))


@pytest.fixture(scope="session")
def s0_quick_run(s0_quick_report):
    """A stand-in for :func:`tendyn.pipelines.s0.run_s0` on the L-EXOS twin in quick mode that returns a copy of
    the session's run (monkeypatch it onto ``tendyn.pipelines.s0.run_s0``)."""
    import copy

    from tendyn.device import load_device
    from tendyn.devices import bundled

    lexos = load_device(bundled("lexos")).name

    def run(device, quick=False):
        assert quick and getattr(device, "name", device) in ("lexos", lexos), (device, quick)
        return copy.deepcopy(s0_quick_report)

    return run


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


# ---- however the suite is started (issue 39) ----------------------------------------------------------------

@pytest.fixture
def sigint_default():
    """Python's own Ctrl-C handler (KeyboardInterrupt) for a test that interrupts this process itself.

    A suite started in a background job (``(trap '' INT; make test) &``) inherits SIGINT *ignored*, and then Python
    installs no handler: such a test would see its Ctrl-C vanish. It sets the handler itself and gives back the
    inherited one afterwards. (The product honouring an inherited ignore is tested in test_cli_guards.py.)"""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals are handled in the main thread only")
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _live_children() -> dict[int, str]:
    """pid → command line of this process's children that are still running (zombies excluded): Linux /proc."""
    import os

    pids: set[int] = set()
    try:
        for task in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{task}/children") as f:
                pids.update(int(p) for p in f.read().split())
    except OSError:                           # no /proc (not Linux): nothing to check
        return {}
    out = {}
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    continue
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace").strip()[:200]
        except OSError:
            continue                          # ended meanwhile
        if not any(helper in cmd for helper in PROCESS_HELPERS):
            out[pid] = cmd
    return out


PROCESS_HELPERS = ("multiprocessing.resource_tracker", "multiprocessing.forkserver")
"""Children that multiprocessing starts once and keeps for the life of this process (not a test's leak)."""

LEFT_PROCESS_GRACE_S = 10.0
"""How long a test's children still running at its end get to go (a Dask worker shutting down) [s]."""


@pytest.fixture(autouse=True)
def no_process_left_behind(request):
    """A test that leaves a child process running fails with its name (and the process is killed), so a leak
    cannot slow or hang the workers that follow. Set up before, torn down after every other fixture of the test;
    processes of module or session fixtures (a browser, a cluster) exist before it and are not counted."""
    import os
    import signal
    import time

    before = set(_live_children())
    yield
    deadline = time.monotonic() + LEFT_PROCESS_GRACE_S
    left = {p: c for p, c in _live_children().items() if p not in before}
    while left and time.monotonic() < deadline:
        time.sleep(0.05)
        left = {p: c for p, c in _live_children().items() if p not in before}
    if left:
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        pytest.fail(f"{request.node.nodeid} left {len(left)} process(es) running: "
                    + "; ".join(f"{p}: {c}" for p, c in sorted(left.items())), pytrace=False)


HEAVY_FIRST = ("test_any_device.py", "test_readme.py", "test_package.py", "test_reports.py", "test_examples.py",
               "test_cli_property_fuzz.py", "test_parallelogram_twin.py", "test_s2_ident.py", "test_s1.py",
               "test_file_fuzz.py", "test_report_hostile.py", "test_ident_friction.py", "test_realdata_mtm.py",
               "test_design.py", "test_cli_domain_fuzz.py")
"""Modules of a minute or more of work, handed to the workers first: a long module started last would leave the
other workers idle at the end of a parallel run (longest-first scheduling). Names only: a module missing here
is still run, in its place. pytest-xdist keeps this order only with ``--no-loadscope-reorder`` (the Makefile's
``XDIST``): by default it hands out the modules with the most tests first, which put the README walk-through (two
tests, 44 s) last (`test_suite_workers.py`)."""


def slow_asked(config) -> bool:
    """True when the run's ``-m`` expression names the ``slow`` marker (``-m slow``, ``-m "slow or not slow"``)."""
    return "slow" in (config.getoption("markexpr", "") or "")


def _deselect_slow(config, items) -> None:
    """Tests marked ``slow`` (a long variant of a fast test of the same code path, docs/testing.md) are deselected
    unless ``-m`` names the marker: `make test` runs the fast twin, `pytest -m slow` the long one. Deselected, not
    skipped: the summary counts them as deselected, and no test body decides it by itself."""
    if slow_asked(config):
        return
    slow = [item for item in items if item.get_closest_marker("slow") is not None]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if item.get_closest_marker("slow") is None]


def _wide_params(item) -> tuple:
    """(argname, index) of the parameters of item's module-, class- or session-scoped fixtures (test_any_device's
    devices, test_examples' build routes): the items sharing them share one set-up."""
    cs = getattr(item, "callspec", None)
    if cs is None:
        return ()
    scopes = getattr(cs, "_arg2scope", {})
    return tuple(sorted((a, i) for a, i in cs.indices.items()
                        if str(getattr(scopes.get(a), "value", "function")) != "function"))


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_collection_modifyitems(session, config, items):
    """After every other reordering (pytest-randomly's shuffle too, a wrapper itself): the HEAVY_FIRST modules
    first, each module's items together, and inside a module the items of one parameter of a module-scoped
    fixture together (a shuffle interleaving them rebuilt test_any_device's device chains up to four times each);
    any other order (pytest's, or the shuffled one) is kept. (`--dist loadgroup` would spread a module's
    parameters over the workers, but pytest-xdist 3.8 renames node ids through an attribute pytest 9 no longer
    reads: every test became its own group and module fixtures were built on each worker.)"""
    result = yield
    _deselect_slow(config, items)
    rank = {name: k for k, name in enumerate(HEAVY_FIRST)}
    first_module: dict = {}
    first_param: dict = {}
    for k, item in enumerate(items):
        first_module.setdefault(item.path, k)
        first_param.setdefault((item.path, _wide_params(item)), k)
    items.sort(key=lambda item: (rank.get(item.path.name, len(rank)), first_module[item.path],
                                 first_param[(item.path, _wide_params(item))]))
    return result


def pytest_terminal_summary(terminalreporter, config):
    """A shuffled run (`-p randomly`) names its seed at the end too (pytest-randomly prints it only in the header,
    which `-q` hides): `-p randomly --randomly-seed=N` repeats the order."""
    seed = getattr(config.option, "randomly_seed", None)
    if config.pluginmanager.has_plugin("randomly") and isinstance(seed, int):
        terminalreporter.write_line(f"pytest-randomly: shuffled with seed {seed} "
                                    f"(repeat: -p randomly --randomly-seed={seed})")
