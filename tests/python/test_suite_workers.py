"""The parallel run's shared runs (issue 39, conftest.py): the claims' expensive runs (``SHARED_RUNS``) are computed by
the first worker that needs them and read by the others from the run's temporary folder; everything else stays per
worker. Two contexts on one folder stand for two workers (threads: the file lock is per open file)."""

from __future__ import annotations

import threading
import time

from conftest import SHARED_RUNS, _shared_context


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
