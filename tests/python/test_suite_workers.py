"""The parallel run's shared runs (issue 39, conftest.py): the claims' expensive runs (``SHARED_RUNS``) are computed by
the first worker that needs them and read by the others from the run's temporary folder; everything else stays per
worker. Two contexts on one folder stand for two workers (threads: the file lock is per open file)."""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from pathlib import Path

from conftest import SHARED_RUNS, _shared_context

REPO = Path(__file__).resolve().parents[2]


def test_a_shared_run_is_made_once_and_read_by_the_other_worker(tmp_path):
    """The second context gets the first one's object (equal, not the same: read back) without calling its own
    maker, even when it asks while the first is still computing (it waits for the lock)."""
    name = SHARED_RUNS[0]
    made = []

    def maker(who):
        def make():
            made.append(who)
            time.sleep(0.3)
            return {"who": who, "values": list(range(5))}
        return make

    a, b = _shared_context(tmp_path, quick=True), _shared_context(tmp_path, quick=True)
    got = {}
    first = threading.Thread(target=lambda: got.setdefault("a", a.get(name, maker("a"))))
    first.start()
    time.sleep(0.05)                      # b asks while a computes
    got["b"] = b.get(name, maker("b"))
    first.join()
    assert made == ["a"], made
    assert got["a"] == got["b"] == {"who": "a", "values": [0, 1, 2, 3, 4]}
    assert b.get(name, maker("c")) is got["b"] and made == ["a"]          # then from the context's own cache


def test_other_runs_and_a_single_process_stay_per_context(tmp_path):
    """A name outside SHARED_RUNS is made by each context; without a folder (one process) nothing is written."""
    made = []
    a, b = _shared_context(tmp_path, quick=True), _shared_context(tmp_path, quick=True)
    for ctx in (a, b):
        ctx.get("lexos", lambda: made.append(1) or "dev")
    assert len(made) == 2
    alone = _shared_context(None, quick=True)
    alone.get(SHARED_RUNS[0], lambda: made.append(1) or "run")
    assert len(made) == 3 and not list(tmp_path.glob("*.pickle"))


def test_a_run_that_cannot_be_pickled_is_made_by_each_worker(tmp_path):
    """A shared run whose object does not pickle (a lambda inside) is returned all the same, and the next worker
    makes its own instead of failing."""
    name = SHARED_RUNS[0]
    a, b = _shared_context(tmp_path, quick=True), _shared_context(tmp_path, quick=True)
    va = a.get(name, lambda: {"f": lambda: 1})
    vb = b.get(name, lambda: {"f": lambda: 2})
    assert va["f"]() == 1 and vb["f"]() == 2


def _makefile_xdist(workers: int) -> list[str]:
    """`make test`'s pytest-xdist options (the Makefile's ``XDIST``) for ``workers`` workers."""
    line = re.search(r"^XDIST\s*:=(.*)$", (REPO / "Makefile").read_text("utf-8"), re.M).group(1)
    return line.replace("$(NPROC)", str(workers)).split()


def test_make_test_hands_out_modules_in_the_collection_order(tmp_path):
    """With `make test`'s xdist options a worker runs the modules in the order the collection hook leaves them
    (conftest.py's heaviest first), not xdist's own (most tests first, since pytest-xdist 3.5): a module of one
    test sorted first by a conftest runs before a module of four tests. One worker, so the order is the hand-out
    order."""
    (tmp_path / "conftest.py").write_text(
        "def pytest_collection_modifyitems(items):\n"
        "    items.sort(key=lambda item: item.path.name != 'test_few.py')\n", "utf-8")
    record = "def test_{k}():\n    open('ran.txt', 'a').write(__name__ + '\\n')\n"
    (tmp_path / "test_few.py").write_text(record.format(k=0), "utf-8")
    (tmp_path / "test_many.py").write_text("".join(record.format(k=k) for k in range(4)), "utf-8")
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
                        *_makefile_xdist(1), str(tmp_path)], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    ran = (tmp_path / "ran.txt").read_text("utf-8").split()
    assert ran == ["test_few"] + ["test_many"] * 4, ran


def test_a_test_that_leaves_a_process_running_fails_with_its_name_and_the_process_is_killed(tmp_path):
    """Issue 39 item 4, nothing hidden: the suite's own `no_process_left_behind` (conftest.py, loaded here under
    another name, its grace shortened) fails a test that leaves a child running (an error at its teardown), names
    it, and kills the child; a test that waits for its child passes."""
    (tmp_path / "conftest.py").write_text(
        "import importlib.util\n"
        f"spec = importlib.util.spec_from_file_location('suite_conftest', {str(Path(__file__).with_name('conftest.py'))!r})\n"
        "suite = importlib.util.module_from_spec(spec)\n"
        "spec.loader.exec_module(suite)\n"
        "suite.LEFT_PROCESS_GRACE_S = 0.2\n"
        "no_process_left_behind = suite.no_process_left_behind\n", "utf-8")
    (tmp_path / "test_children.py").write_text(
        "import subprocess\n"
        "def test_leaks():\n"
        "    open('pid.txt', 'w').write(str(subprocess.Popen(['sleep', '60']).pid))\n"
        "def test_waits():\n"
        "    subprocess.run(['true'], check=True)\n", "utf-8")
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
                        "-p", "no:xdist", str(tmp_path)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stdout[-2000:] + r.stderr[-2000:]
    assert "test_children.py::test_leaks left 1 process(es) running" in r.stdout, r.stdout
    assert "ERROR test_children.py::test_leaks" in r.stdout and "1 error" in r.stdout, r.stdout
    assert "test_waits" not in r.stdout.split("short test summary")[-1], r.stdout
    pid = int((tmp_path / "pid.txt").read_text("utf-8"))

    def state() -> str:          # Linux /proc: "Z" killed (not yet reaped), "gone" reaped, else still running
        try:
            return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return "gone"

    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and state() not in ("Z", "gone"):
        time.sleep(0.05)
    assert state() in ("Z", "gone"), state()
