"""Every export writes names as data (issue 36 item 4, docs/security.md): one test per format, each with names
that carry the format's own syntax; the name round-trips to itself or the export is refused in one line.

XML (MJCF, ros2_control URDF): through an XML writer; the line-based compensator file (.comp): a name holding
``#`` (a comment there) or outer spaces is refused before anything is written; the transmission model file
(.model) holds no name at all; CSV (``tendyn history --csv``): a text cell a spreadsheet would run as a formula
starts with ``'``; SQL (the history database): names only through parameters.
"""

from __future__ import annotations

import csv
import io
import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

XML_HOSTILE = '<a href="x">&amp; \'q\' --> <!-- ]]> -- # '
"""XML's own syntax: tags, entities, both quotes, comment and CDATA ends."""

SQL_HOSTILE = "x'); DROP TABLE runs; -- \" ; SELECT * FROM parameters WHERE ''='"

FORMULAS = ('=HYPERLINK("http://example.invalid","x")', "+1+1", "-2+3", "@SUM(1,1)", "\tlead tab", "\rlead cr")


def _device(tmp_path, prefix: str, n: int = 2):
    """A generated device whose device, joint and transmission names start with ``prefix``."""
    from tendyn.device import load_device
    from tendyn.devices.generate import cable_device_toml

    text = re.sub(r'^name = "([^"]*)"', lambda m: f"name = {json.dumps(prefix + m[1])}",
                  cable_device_toml(n, seed=3), flags=re.M)
    path = tmp_path / "dev.toml"
    path.write_text(text, encoding="utf-8")
    return load_device(path)


def _names(xml_text: str) -> set:
    return {e.get("name") for e in ET.fromstring(xml_text).iter() if e.get("name")}


def test_mjcf_names_round_trip(tmp_path):
    from tendyn.interop.mjcf import to_mjcf

    dev = _device(tmp_path, XML_HOSTILE)
    names = _names(to_mjcf(dev))
    for j in dev.kinematics.joints:
        assert j.name in names, j.name
    for t in dev.transmissions:
        assert t.name in names, t.name


def test_ros2_control_names_round_trip(tmp_path):
    from tendyn.interop.ros2_control import to_ros2_control

    dev = _device(tmp_path, XML_HOSTILE)
    root = ET.fromstring(to_ros2_control(dev, four_bar=True))
    assert root.get("name") == dev.name
    names = _names(to_ros2_control(dev, four_bar=True))
    assert {j.name for j in dev.kinematics.joints} <= names and {t.name for t in dev.transmissions} <= names


@pytest.mark.parametrize("prefix", ["<b>ok</b> 'q' \"d\" & ", "with # a comment ", "with#hash "])
def test_compensator_file_device_name_round_trips_or_is_refused(tmp_path, prefix):
    """The .comp `device` line: the name reads back as itself, or export refuses it in one line and writes
    nothing (before: `#` cut the name at the comment and the file claimed another device)."""
    from tendyn.control import Compensator

    dev = _device(tmp_path, prefix)
    comp = Compensator.from_device(dev)
    out = tmp_path / "x.comp"
    try:
        comp.export(out)
    except ValueError as exc:
        msg = str(exc)
        assert "\n" not in msg and "cannot be written in a compensator file" in msg and "#" in prefix, msg
        assert not out.exists()
        return
    assert Compensator.load(out).device == dev.name


def test_export_compensator_command_refuses_a_hash_in_one_line(tmp_path):
    """`tendyn export compensator` names the device in its one error line, exit 2 (no traceback)."""
    from contextlib import redirect_stderr, redirect_stdout

    from tendyn.cli import main

    dev = _device(tmp_path, "a # b ")
    friction = tmp_path / "f.json"
    friction.write_text("{}", encoding="utf-8")
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        code = main(["export", "compensator", str(dev.path), "--friction", str(friction), "--out",
                     str(tmp_path / "x.comp")])
    assert code == 2 and err.getvalue().count("\n") == 1, err.getvalue()
    assert err.getvalue().startswith("tendyn: error: device: its name 'a # b gen2p3' cannot be written"), err.getvalue()


def test_transmission_model_file_holds_no_name(tmp_path):
    """The .model file carries numbers under fixed field names only: nothing of a hostile name reaches it, and
    it reads back bit for bit."""
    from tendyn.device import compile_device
    from tendyn.transmission import Transmission

    dev = _device(tmp_path, XML_HOSTILE)
    tr = compile_device(dev).transmission
    out = tmp_path / "x.model"
    tr.export(out)
    text = out.read_text(encoding="utf-8")
    assert "<" not in text and "gen2p3" not in text
    back = Transmission.load(out).to_dict()
    for key, value in tr.to_dict().items():
        np.testing.assert_array_equal(back[key], value, err_msg=key)


def test_history_csv_quotes_formula_cells(tmp_path):
    """`history --csv`: a text cell a spreadsheet would run (=, +, -, @, tab, CR first) starts with ' ; numbers
    (negative ones too) stay numbers; dropping that ' gives the name back."""
    from tendyn.ident import history as hist
    from tendyn.text import FORMULA_START

    dev = _device(tmp_path, "")
    metrics = {f: {"value": -0.5, "sigma": 0.1, "unit": f} for f in FORMULAS}
    db = tmp_path / "h.sqlite"
    hist.record(dev, "validate", {"metrics": metrics}, db=db)
    rows = list(csv.DictReader(io.StringIO(hist.history(dev, db=db).to_csv())))
    assert len(rows) == len(FORMULAS)
    for r in rows:
        for key in ("name", "unit"):
            assert not r[key].startswith(FORMULA_START), r
            assert r[key].startswith("'") and r[key][1:] in FORMULAS, r
        assert r["value"] == "-0.5"


def test_history_database_takes_names_as_parameters(tmp_path):
    """SQL only through parameters: a device and a parameter name in SQL's syntax are stored and read back as
    they are, and the tables are still there."""
    import sqlite3

    from tendyn.ident import history as hist

    dev = _device(tmp_path, SQL_HOSTILE)
    db = tmp_path / "h.sqlite"
    hist.record(dev, "validate", {"metrics": {SQL_HOSTILE: 1.0}}, db=db)
    h = hist.history(dev, db=db)
    assert h.device == dev.name and [r["name"] for r in h.rows] == [SQL_HOSTILE]
    con = sqlite3.connect(db)
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    finally:
        con.close()
    assert {"runs", "parameters", "meta"} <= tables
