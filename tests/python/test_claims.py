"""`tendyn claims` and its registry (tendyn.claims): every claim of CLAIMS.md has a check, each check is what its
tests run (one definition), the command's table, JSON, report, exit codes and quick mode."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

from tendyn.claims import QUICK_MODES, REGISTRY, Context, check, claim_ids
from tendyn.claims.core import Outcome
from tendyn.cli import main

TESTS = Path(__file__).parent


def test_every_claim_of_the_papers_has_a_check():
    ids = {REGISTRY[k].id for k in claim_ids()}
    assert ids == {f"C{n}" for n in range(1, 47)}
    for k in claim_ids():
        c = REGISTRY[k]
        assert c.paper in ("S0", "S1", "S2") and c.paper_value and c.band and c.quick in QUICK_MODES, k


def test_the_five_strict_expected_failures_carry_their_reason():
    xf = sorted(k for k in claim_ids() if REGISTRY[k].xfail)
    assert xf == ["C28:numbers", "C38:XX", "C38:viscous", "C42:natural", "C43:grid"]
    assert all(len(REGISTRY[k].xfail) > 40 for k in xf)


def _test_calls() -> dict[str, set[str]]:
    """test file::name → the claim keys it passes to assert_claim (read from the source, not run)."""
    calls = {}
    for path in TESTS.glob("test_*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name.startswith("test_"):
                keys = {c.args[0].value for c in ast.walk(node) if isinstance(c, ast.Call)
                        and getattr(c.func, "id", "") == "assert_claim" and c.args
                        and isinstance(c.args[0], ast.Constant)}
                calls[f"{path.name}::{node.name}"] = keys
    return calls


def test_each_check_is_what_its_tests_run_and_their_names_carry_the_claim():
    """One definition: every test a claim names calls assert_claim on that claim (so breaking the check fails the
    test), carries the claim id in its name or docstring, and expected failures are strict xfails in the test."""
    calls = _test_calls()
    for k in claim_ids():
        c = REGISTRY[k]
        assert c.tests, k
        for t in c.tests:
            assert t in calls, (k, t)
            assert k in calls[t], (k, t, calls[t])
            assert re.search(rf"{c.id}(?!\d)", t, re.IGNORECASE) or c.id in _docstring(t), (k, t)
            if c.xfail:
                src = (TESTS / t.split("::")[0]).read_text(encoding="utf-8")
                assert f'xfail(strict=True, reason=xfail_reason("{k}"))\ndef {t.split("::")[1]}' in src, (k, t)


def _docstring(test: str) -> str:
    path, name = test.split("::")
    tree = ast.parse((TESTS / path).read_text(encoding="utf-8"))
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    return ast.get_docstring(fn) or ""


def test_a_broken_check_fails_and_an_exception_is_an_error(monkeypatch):
    ctx = Context(quick=True)
    assert check("C6", ctx).status == "holds"
    import tendyn._core as core

    monkeypatch.setattr(core, "reducer_inverse_efficiency", lambda eta: (2 * eta - 1))   # forgot to divide by η_d
    o = check("C6", ctx)
    assert o.status == "FAILS" and o.bad and any("η_i" in f for f in o.failed)
    monkeypatch.setattr(core, "reducer_inverse_efficiency", lambda eta: 1 / 0)
    assert check("C6", ctx).status == "ERROR"


def test_quick_mode_skips_the_checks_marked_skip(monkeypatch):
    import dataclasses

    ctx = Context(quick=True)
    assert [k for k in claim_ids() if REGISTRY[k].quick == "skip"] == []        # none today (docs/claims.md)
    monkeypatch.setitem(REGISTRY, "C2", dataclasses.replace(REGISTRY["C2"], quick="skip"))
    assert check("C2", ctx).status == "skipped" and check("C2", Context()).status == "holds"
    assert Context(quick=True).count < Context().count                        # C1, C3: fewer random routings


def _run(argv, capsys):
    code = main(["claims", *argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_command_table_json_and_report(tmp_path, capsys):
    code, out, err = _run(["--only", "C2,C6,C13,C19", "--quiet"], capsys)
    assert code == 0, err
    assert out.splitlines()[0].split() == ["claim", "paper", "value", "tendyn", "value", "band", "status"]
    assert "C13" in out and "0.8889" in out and "4 hold" in out
    code, out, _ = _run(["--only", "C6", "--json", "--report", str(tmp_path / "rep")], capsys)
    doc = json.loads(out)
    assert code == 0 and doc["counts"]["holds"] == 1 and doc["claims"][0]["claim"] == "C6"
    row = doc["claims"][0]
    assert {"claim", "paper_value", "tendyn_value", "band", "status", "reason"} <= set(row)
    assert sorted(p.name for p in (tmp_path / "rep").iterdir()) == ["claims.json", "claims.txt", "report.html"]
    assert json.loads((tmp_path / "rep" / "claims.json").read_text(encoding="utf-8"))["claims"] == doc["claims"]


def test_command_exit_1_when_a_claim_that_held_fails_and_xfails_show_their_reason(monkeypatch, capsys):
    import tendyn.claims.core as core

    fake = {"C6": Outcome("C6", "FAILS", "η_i = 0.8", ["η_i(0.9)"]),
            "C42:natural": Outcome("C42:natural", "xfail", "447 g", ["447 g"], REGISTRY["C42:natural"].xfail)}
    monkeypatch.setattr("tendyn.claims.check", lambda k, ctx=None: fake.get(k) or core.check(k, ctx))
    code, out, err = _run(["--only", "C6,C2", "--quiet"], capsys)
    assert code == 1 and "FAILS" in out
    code, out, err = _run(["--only", "C42:natural", "--quiet"], capsys)
    assert code == 0 and "C42:natural xfail: the twin's natural (isotropic) pose gives 447 g" in out


def test_command_usage_errors_are_one_line(capsys, tmp_path):
    assert main(["claims", "--only", "C99"]) == 2
    err = capsys.readouterr().err
    assert "--only" in err and "C99" in err and len(err.strip().splitlines()) == 1
    (tmp_path / "f").write_text("x", encoding="utf-8")
    assert main(["claims", "--only", "C2", "--report", str(tmp_path / "f")]) == 2


def test_step_lines_when_stderr_is_not_a_terminal(capsys):
    code, _, err = _run(["--only", "C2,C13"], capsys)
    assert code == 0 and "[claims] C2" in err and "(2/2)" in err


def test_the_s1_summary_and_report_share_one_pipeline_run(monkeypatch):
    """`twins.s1_json` (C21–C28) is the summary of `twins.s1_report` (the test suite's HTML report): one
    `run_s1(quick=True)` per context for both, not one each (it was run twice, ~14 s of CPU each)."""
    import types

    import tendyn.pipelines.s1 as s1
    from tendyn.claims import twins

    calls = []

    def fake_run_s1(bench, quick=False, progress=None):
        calls.append((bench, quick))
        return types.SimpleNamespace(summary={"peak_hz": 12.5})

    monkeypatch.setattr(s1, "run_s1", fake_run_s1)
    ctx = Context(quick=True)
    doc = twins.s1_json(ctx)
    report = twins.s1_report(ctx)
    assert calls == [(twins.mcgill(ctx), True)], calls
    assert doc == dict(report.summary) == {"peak_hz": 12.5}
