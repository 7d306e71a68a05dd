"""`tendyn identify --consistent --bounds FILE` (issue 29): per-parameter boxes the physically consistent fit
respects, read from a TOML or JSON file whose domain is declared in tendyn.commands.args (BoxesDomain, OPTION_NEEDS).

A generated 2-joint cable arm and a log generated from it (test_ident_real_logs' arm and synthetic_log: RNEA
torques plus the test's friction and noise); the command runs in process. The free consistent fit is computed
once per module (≈ 1.5 s) and compared with the bounded ones.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tendyn.cli import main

from test_ident_real_logs import arm, synthetic_log  # noqa: F401 (fixture)

OPTS = ["--consistent", "--cutoff-hz", "20", "--decimate", "10", "--quiet", "--json"]


@pytest.fixture(scope="module")
def logfile(arm, tmp_path_factory):  # noqa: F811
    from tendyn.io import write_log

    path = tmp_path_factory.mktemp("log") / "log.parquet"
    write_log(synthetic_log(arm, duration=6.0, seed=4, noise=0.01), path)
    return path


def _identify(capsys, arm, logfile, *extra):  # noqa: F811
    code = main(["identify", str(arm.file), str(logfile), *OPTS, *map(str, extra)])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


@pytest.fixture(scope="module")
def free(arm, logfile):  # noqa: F811
    """The consistent fit without boxes: its JSON and its standard parameters (the same estimator, in process)."""
    from tendyn.ident import IDIM
    from tendyn.io import read_log

    est = IDIM(arm.device, cutoff_hz=20.0, decimate=10, consistent=True).fit(read_log(logfile), crossval=False)
    return {p["name"]: p["value"] for p in est.result_.to_dict()["params"]}, est.standard_params_


def _write(tmp_path, text, name="b.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _one_line(code, err, *words):
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("tendyn: error: --bounds"), err
    for w in words:
        assert w in lines[0], (w, lines[0])


def test_a_bound_that_binds_puts_the_parameter_on_it(arm, logfile, free, tmp_path, capsys):  # noqa: F811
    """FV1's upper bound at half the free estimate: the fit returns FV1 on the bound (the free value is
    outside), the file records the box, the value and FV1 as active; the residual grows."""
    base, _ = free
    hi = 0.5 * base["FV1"]
    code, doc, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, f"FV1 = [0.0, {hi!r}]\n"))
    assert code == 0, err
    v = {p["name"]: p["value"] for p in doc["params"]}
    assert v["FV1"] == pytest.approx(hi, rel=1e-5)
    assert doc["bounds"]["active"] == ["FV1"] and doc["bounds"]["boxes"] == {"FV1": [0.0, hi]}
    assert "bounds: 1 boxes" in err and "1 at a bound (FV1)" in err


def test_every_box_is_respected(arm, logfile, free, tmp_path, capsys):  # noqa: F811
    """Boxes on a mass (M2 held at its free value: a box of zero width), a centre of mass (CX2 = MX2 / M2 [m],
    excluding the free value), two frictions and an offset: every boxed quantity of the estimate inside its box
    (1e-6), the centre of mass on its box. Plant seen failing: the centre-of-mass box written on MX2 (not × M2)."""
    _, s0 = free
    cx = s0["MX2"] / s0["M2"]
    box = (cx + 0.02, cx + 0.05) if cx < 0 else (cx - 0.05, cx - 0.02)
    text = (f"M2 = [{s0['M2']!r}, {s0['M2']!r}]\nCX2 = [{box[0]!r}, {box[1]!r}]\n"
            f"FS1 = {{lower = 0.0, upper = 1.0}}\nFV2 = {{upper = 10.0}}\nOFFSET1 = [-0.5, 0.5]\n")
    code, doc, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, text))
    assert code == 0, err
    b = doc["bounds"]
    assert set(b["values"]) == set(b["boxes"]) == {"M2", "CX2", "FS1", "FV2", "OFFSET1"}
    for name, (lo, hi) in b["boxes"].items():
        v, tol = b["values"][name], 1e-6 * max(1.0, abs(lo or 0), abs(hi or 0))
        assert (lo is None or v >= lo - tol) and (hi is None or v <= hi + tol), (name, v, lo, hi)
    assert "CX2" in b["active"]
    assert b["values"]["M2"] * b["values"]["CX2"] == pytest.approx(
        {p["name"]: p["value"] for p in doc["params"]}["MX2"], rel=1e-6)


def test_wide_boxes_give_the_unbounded_result(arm, logfile, free, tmp_path, capsys):  # noqa: F811
    """A box of ±10 (±10 m for two centres of mass) on every standard parameter (25 to 10⁴ times each value): the
    base parameters of the free fit (1e-4 of the largest), nothing at a bound."""
    base, _ = free
    names = [n for n in arm.standard_names]
    text = "".join(f"{n} = [-10.0, 10.0]\n" for n in names) + "CX1 = [-10.0, 10.0]\nCZ2 = [-10.0, 10.0]\n"
    code, doc, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, text))
    assert code == 0, err
    v = {p["name"]: p["value"] for p in doc["params"]}
    scale = max(abs(x) for x in base.values())
    for name, x in base.items():
        assert abs(v[name] - x) <= 1e-4 * scale, (name, v[name], x)
    assert doc["bounds"]["active"] == []


def test_json_and_toml_files_give_the_same_fit(arm, logfile, free, tmp_path, capsys):  # noqa: F811
    base, _ = free
    hi = 0.5 * base["FV1"]
    _, a, _ = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, f"FV1 = [0.0, {hi!r}]\nM1 = {{lower = 0.01}}\n"))
    _, b, _ = _identify(capsys, arm, logfile, "--bounds",
                        _write(tmp_path, json.dumps({"FV1": [0.0, hi], "M1": {"lower": 0.01}}), "b.json"))
    assert [p["value"] for p in a["params"]] == pytest.approx([p["value"] for p in b["params"]], rel=1e-9, abs=1e-12)
    assert a["bounds"]["boxes"] == b["bounds"]["boxes"] == {"FV1": [0.0, hi], "M1": [0.01, None]}


@pytest.mark.parametrize("flags", [[], ["--plain"]])
def test_without_consistent_refused_in_one_line(arm, logfile, tmp_path, capsys, flags):  # noqa: F811
    """The plain and the default (consistent only when not physical) fits take no boxes: refused before the
    device or the log is read (the relation is OPTION_NEEDS' row)."""
    b = _write(tmp_path, "FV1 = [0.0, 1.0]\n")
    code = main(["identify", "no_such_device", str(logfile), "--bounds", str(b), *flags])
    _one_line(code, capsys.readouterr().err, "needs --consistent")


def test_unknown_name_refused_in_one_line(arm, logfile, tmp_path, capsys):  # noqa: F811
    """A name that is not one of the device's standard parameters (FV3 on a 2-joint arm, CX9) names itself."""
    for bad in ("FV3", "CX9", "mass2"):
        code, _, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, f"{bad} = [0.0, 1.0]\n"),
                                 "--out", tmp_path / "o.json")
        _one_line(code, err, repr(bad), "not a standard parameter")
    assert not (tmp_path / "o.json").exists()


def test_infeasible_boxes_refused_in_one_line(arm, logfile, tmp_path, capsys):  # noqa: F811
    """A box below 0 on a parameter the fit keeps ≥ 0 (a friction) is refused before the fit; boxes that only the
    pseudo-inertia LMIs exclude (XX2 = S_yy + S_zz < 0 about the origin) are refused once the solver says
    infeasible: one line naming --bounds and the file, exit 2, nothing written."""
    out = tmp_path / "o.json"
    code, _, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, "FV1 = [-1.0, -0.5]\n"), "--out", out)
    _one_line(code, err, "FV1 upper -0.5 < 0", "b.toml")
    code, _, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, "XX2 = [-1.0, -0.5]\n"), "--out", out)
    _one_line(code, err, "admit no parameters", "infeasible", "b.toml")
    code, _, err = _identify(capsys, arm, logfile, "--bounds",
                             _write(tmp_path, "M2 = [1.0, 2.0]\nMX2 = [5.0, 6.0]\nCX2 = [-0.1, 0.1]\n"), "--out", out)
    _one_line(code, err, "admit no parameters")
    assert not out.exists()


@pytest.mark.parametrize("text, name, words", [
    ("M1 = [2.0, 1.0]\n", "b.toml", ["M1 lower 2.0 > upper 1.0"]),
    ("M1 = [0.0, inf]\n", "b.toml", ["M1 upper", "finite"]),
    ("M1 = [nan, 1.0]\n", "b.toml", ["M1 lower", "finite"]),
    ('{"M1": [0, Infinity]}', "b.json", ["not JSON"]),
    ("M1 = [0.0, 1.0, 2.0]\n", "b.toml", ["[lower, upper]", "3 values"]),
    ('M1 = {lower = 0, above = 1}\n', "b.toml", ["above"]),
    ("M1 = [0, 1]\n[[[\n", "b.toml", ["not TOML"]),
    ("", "b.toml", ["non-empty"]),
    ("M1,0,1\n", "b.csv", [".toml or .json"]),
    ('M1 = ["0", 1]\n', "b.toml", ["finite number"]),
])
def test_file_outside_its_domain_refused_in_one_line(tmp_path, capsys, text, name, words):
    """Parsed by the option's converter, before the device or the logs are read (BoxesDomain)."""
    b = _write(tmp_path, text, name)
    code = main(["identify", "no_such_device", str(b), "--consistent", "--bounds", str(b)])
    _one_line(code, capsys.readouterr().err, *words)


def test_a_stated_unit_must_be_the_parameters(arm, logfile, tmp_path, capsys):  # noqa: F811
    """``unit`` is optional; when stated it must be the parameter's (kg for M2, m for a centre of mass, the motor
    side's unit without its note for FVm2); a gram is refused."""
    code, _, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, 'M2 = {lower = 0, upper = 5, unit = "g"}\n'))
    _one_line(code, err, "M2 is in kg, not 'g'")
    code, _, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, 'CX2 = {lower = -1, upper = 1, unit = "kg·m"}\n'))
    _one_line(code, err, "CX2 is in m")
    good = 'M2 = {lower = 0, upper = 5, unit = "kg"}\nCX2 = {lower = -1, upper = 1, unit = "m"}\n' \
           'FVm2 = {upper = 1, unit = "N·m·s/rad"}\n'
    code, doc, err = _identify(capsys, arm, logfile, "--bounds", _write(tmp_path, good))
    assert code == 0, err
    assert set(doc["bounds"]["boxes"]) == {"M2", "CX2", "FVm2"}


def test_with_stream_refused(arm, logfile, tmp_path, capsys):  # noqa: F811
    b = _write(tmp_path, "FV1 = [0.0, 1.0]\n")
    code = main(["identify", str(arm.file), str(logfile), "--stream", "--consistent", "--bounds", str(b)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "--consistent" in lines[0] and "--stream" in lines[0], lines


def test_the_declared_domain_and_relation(tmp_path):
    """The table the parser and the fuzz read: every example outside BoxesDomain is refused by the converter and
    every one inside is accepted; OPTION_NEEDS names --bounds → --consistent; the parser binds the converter."""
    import argparse

    from tendyn.cli import build_parser
    from tendyn.commands.args import OPTION_NEEDS, BoxesDomain, boxes_file

    dom = boxes_file.domain
    assert isinstance(dom, BoxesDomain)
    for k, (suffix, text) in enumerate(dom.outside()):
        p = _write(tmp_path, text, f"o{k}{suffix}")
        with pytest.raises(argparse.ArgumentTypeError):
            boxes_file(str(p))
    for k, (suffix, text) in enumerate(dom.inside()):
        b = boxes_file(str(_write(tmp_path, text, f"i{k}{suffix}")))
        assert b.bounds and all(lo is None or hi is None or lo <= hi for lo, hi in b.bounds.values())
    assert OPTION_NEEDS["identify"]["bounds"][0] == "consistent"
    sub = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)][0]
    act = [a for a in sub.choices["identify"]._actions if a.dest == "bounds"][0]
    assert act.type is boxes_file and act.default is None


def test_wpi_boxes_in_the_docs_are_wpi_bounds(tmp_path):
    """docs/realdata.md's `wpi_boxes.toml` block (WPI's 63 SDP boxes, typed from their published settings) is read
    by the option's converter as ``mtm.wpi_bounds()`` maps them (1e-12) and every name and stated unit is one of
    tendyn's MTM device (generated from the public DH table: no MTM data read)."""
    import importlib.util
    import re
    import sys
    from pathlib import Path

    from tendyn.commands.args import boxes_file
    from tendyn.device import load_device
    from tendyn.ident.consistent import check_bounds
    from tendyn.ident.estimate import cached_model

    repo = Path(__file__).resolve().parents[2]
    text = (repo / "docs" / "realdata.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- wpi_boxes.toml -->\n```toml\n(.*?)```", text, re.S).group(1)
    boxes = boxes_file(str(_write(tmp_path, block, "wpi_boxes.toml")))
    folder = str(repo / "benchmarks" / "realdata")
    sys.path.insert(0, folder)
    try:
        spec = importlib.util.spec_from_file_location("mtm_for_boxes", Path(folder) / "mtm.py")
        mtm = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mtm)
        from mtm_device import write_mtm_device
    finally:
        sys.path.remove(folder)
    want = mtm.wpi_bounds()
    assert len(boxes.bounds) == len(want) == 63 and set(boxes.bounds) == set(want)
    for name, (lo, hi) in want.items():
        got = boxes.bounds[name]
        for g, w in zip(got, (lo, hi)):
            assert (g is None and w is None) or g == pytest.approx(w, rel=1e-12, abs=1e-15), (name, got, (lo, hi))
    model = cached_model(load_device(write_mtm_device(tmp_path)))
    assert check_bounds(model, boxes.bounds, boxes.units) == boxes.bounds
