"""tendyn.progress: step lines when stderr is not a terminal, a tqdm bar with ETA when it is, and Dask's worker and
nanny warnings hidden unless --debug (issue 20 item 5)."""

from __future__ import annotations

import io
import logging

from tendyn.progress import Steps, Ticker, quiet_dask


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_step_lines_off_a_terminal():
    err = io.StringIO()
    with Steps(3, "job", stream=err) as s:
        for k in ("a", "b", "c"):
            s.step(k)
    assert err.getvalue().splitlines() == ["[job] a (1/3) …", "[job] b (2/3) …", "[job] c (3/3) …"]
    t = Ticker("pipeline", stream=err)
    t("x")
    assert err.getvalue().endswith("[pipeline] x …\n")


def test_a_bar_with_eta_on_a_terminal():
    err = _Terminal()
    with Steps(4, "claims", stream=err) as s:
        s.step("C1")
        s.step("C2")
    text = err.getvalue()
    assert "claims" in text and "C2" in text and "<" in text and "[claims]" not in text   # elapsed<remaining
    t = Ticker("pipeline", expected=3, stream=err)
    t("one")
    t("two")
    t.close()
    assert "two" in err.getvalue()
    quiet = io.StringIO()
    with Steps(2, "x", stream=quiet, quiet=True) as s:
        s.step("a")
    assert quiet.getvalue() == ""


def test_dask_warnings_hidden_unless_debug(monkeypatch):
    for name in ("distributed", "distributed.nanny", "distributed.worker"):
        logging.getLogger(name).setLevel(logging.NOTSET)
    monkeypatch.setenv("TENDYN_DEBUG", "1")
    monkeypatch.delenv("DASK_LOGGING__DISTRIBUTED", raising=False)
    quiet_dask()
    assert logging.getLogger("distributed.nanny").level == logging.NOTSET
    monkeypatch.setenv("TENDYN_DEBUG", "")
    quiet_dask()
    assert logging.getLogger("distributed.nanny").getEffectiveLevel() == logging.ERROR
    assert logging.getLogger("distributed.worker").getEffectiveLevel() == logging.ERROR
    import os

    assert os.environ["DASK_LOGGING__DISTRIBUTED"] == "error"        # read by the worker processes at start
