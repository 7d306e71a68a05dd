"""Calibration history (tendyn.ident.history, `tendyn history`, `--record`): records keyed by the device file's hash
and the date, drift beyond 3σ between consecutive records, schema versions migrated, CSV/Parquet/plot exports."""

import json
import sqlite3
import subprocess
import sys
from datetime import datetime, timedelta, timezone

import pytest

from tendyn.device import load_device
from tendyn.devices import bundled
from tendyn.ident import history as hist


def _friction_doc(c0, nu, sigma=0.002):
    """A FRICTION.json-like document (the fields history reads) for len(c0) transmissions."""
    return {"fits": [{"transmission": t + 1, "coulomb_motor": c, "coulomb_motor_std": sigma,
                      "viscous_motor": v, "viscous_motor_std": sigma / 10} for t, (c, v) in enumerate(zip(c0, nu))]}


@pytest.fixture
def lexos():
    return load_device(bundled("lexos"))


@pytest.fixture
def db(tmp_path, lexos):
    """Three identify-friction records a day apart; the third moves C_m0[2] by 5σ and nu[1] by 2.5σ."""
    path = tmp_path / "h.sqlite"
    day = datetime(2026, 3, 1, tzinfo=timezone.utc)
    c0, nu = [0.05, 0.06, 0.04, 0.03], [0.001, 0.002, 0.001, 0.001]
    hist.record(lexos, "identify-friction", _friction_doc(c0, nu), db=path, created=day)
    hist.record(lexos, "identify-friction", _friction_doc(c0, nu), db=path, created=day + timedelta(days=1))
    moved_c0, moved_nu = list(c0), list(nu)
    moved_c0[1] += 5 * 0.002 * 2 ** 0.5      # 5 combined σ (both records σ = 0.002)
    moved_nu[0] += 2.5 * 0.0002 * 2 ** 0.5   # 2.5 combined σ: 3.5 σ of one record alone, not a drift
    hist.record(lexos, "identify-friction", _friction_doc(moved_c0, moved_nu), db=path,
                created=day + timedelta(days=2))
    return path


def test_history_flags_only_changes_beyond_three_sigma(db, lexos):
    h = hist.history(lexos, db=db)
    assert len(h.rows) == 3 * 8
    assert [(r["name"], r["created"][:10]) for r in h.drifts()] == [("C_m0[2]", "2026-03-03")]
    c = [r["value"] for r in h.rows if r["name"] == "C_m0[2]"]
    assert c[0] == c[1] < c[2]
    assert [r["created"] for r in h.rows] == sorted(r["created"] for r in h.rows)      # oldest first
    only = hist.history(lexos, db=db, names={"nu[1]"})
    assert {r["name"] for r in only.rows} == {"nu[1]"} and not only.drifts()


def test_records_are_keyed_by_the_device_files_hash(db, lexos, tmp_path):
    """An edited device file is another device: its history is empty, the old records are counted apart."""
    edited = tmp_path / "lexos_edited.toml"
    edited.write_text(bundled("lexos").read_text() + "\n# new cable\n")
    other = load_device(edited)
    assert other.name == lexos.name and hist.device_hash(other) != hist.device_hash(lexos)
    h = hist.history(other, db=db)
    assert h.rows == [] and h.other_hashes == 3


def test_an_older_schema_is_migrated_and_a_newer_one_refused(tmp_path, lexos):
    path = tmp_path / "v1.sqlite"
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    for sql in hist.MIGRATIONS[0]:
        con.execute(sql)
    con.execute("INSERT INTO meta VALUES ('schema_version', '1')")
    con.execute("INSERT INTO runs (device, device_hash, kind, created, source, document) VALUES (?, ?, ?, ?, ?, ?)",
                (lexos.name, hist.device_hash(lexos), "identify-friction", "2025-01-01T00:00:00+00:00", "", "{}"))
    con.execute("INSERT INTO parameters VALUES (1, 'C_m0[1]', 0.05, 0.002, 'N·m')")
    con.commit()
    con.close()
    before = path.read_bytes()
    h = hist.history(lexos, db=path)                     # a read writes nothing, the v1 record is read
    assert [r["name"] for r in h.rows] == ["C_m0[1]"] and path.read_bytes() == before
    hist.connect(path).close()                           # migrated (and stamped) when opened for writing
    assert [r["name"] for r in hist.history(lexos, db=path).rows] == ["C_m0[1]"]
    con = sqlite3.connect(path)
    assert con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0] == str(hist.SCHEMA_VERSION)
    assert con.execute("PRAGMA application_id").fetchone()[0] == hist.APPLICATION_ID
    assert con.execute("PRAGMA user_version").fetchone()[0] == hist.SCHEMA_VERSION
    assert "tendyn_version" in [c[1] for c in con.execute("PRAGMA table_info(runs)")]
    con.execute("PRAGMA user_version = 99")
    con.commit()
    con.close()
    with pytest.raises(ValueError, match="newer"):
        hist.history(lexos, db=path)
    (tmp_path / "junk.sqlite").write_bytes(b"not a database at all" * 100)
    with pytest.raises(ValueError, match="not a tendyn history database"):
        hist.connect(tmp_path / "junk.sqlite")


def test_default_database_is_in_the_users_data_folder(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert hist.default_db() == tmp_path / "xdg" / "tendyn" / "history.sqlite"


def test_validate_and_identify_documents_are_recorded_too(tmp_path, lexos):
    path = tmp_path / "h.sqlite"
    hist.record(lexos, "identify", {"params": [{"name": "ZZ1", "value": 0.5, "stderr": 0.01, "unit": "kg·m²"}]},
                db=path)
    hist.record(lexos, "validate", {"metrics": {"reduction_joint1": 0.735, "rms_joint1": {"value": 0.07,
                                                                                           "sigma": 0.002,
                                                                                           "unit": "N·m"}}}, db=path)
    names = {r["name"]: r for r in hist.history(lexos, db=path).rows}
    assert names["ZZ1"]["sigma"] == 0.01 and names["reduction_joint1"]["sigma"] is None
    assert names["rms_joint1"]["unit"] == "N·m"
    with pytest.raises(ValueError, match="kind"):
        hist.record(lexos, "guess", {}, db=path)


def _tendyn(*args):
    return subprocess.run([sys.executable, "-m", "tendyn.cli", *args], capture_output=True, text=True)


def test_history_command_shows_exports_and_plots(db, tmp_path):
    out = _tendyn("history", "lexos", "--db", str(db), "--json", "--csv", str(tmp_path / "h.csv"),
                  "--parquet", str(tmp_path / "h.parquet"), "--plot", str(tmp_path / "h.png"))
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert len(doc["rows"]) == 24 and [d["name"] for d in doc["drifts"]] == ["C_m0[2]"]
    assert (tmp_path / "h.csv").read_text().count("\n") == 25 and (tmp_path / "h.png").stat().st_size > 1000
    import pyarrow.parquet as pq

    assert pq.read_table(tmp_path / "h.parquet").num_rows == 24
    text = _tendyn("history", "lexos", "--db", str(db))
    assert text.returncode == 0 and "DRIFT" in text.stdout


def test_history_report_page_with_the_drift_as_a_warning(db, tmp_path):
    """--report: the page, its JSON, the table and the figure; the one drift beyond 3σ is a warning on the page and
    on stderr, the 2.5σ move is not."""
    out = _tendyn("history", "lexos", "--db", str(db), "--report", str(tmp_path / "r"))
    assert out.returncode == 0, out.stderr
    files = {p.name for p in (tmp_path / "r").iterdir()}
    assert {"report.html", "history.json", "history.txt", "history.png"} <= files, files
    warned = [line for line in out.stderr.splitlines() if "warning" in line]
    assert len(warned) == 1 and "C_m0[2]" in warned[0] and "2026-03-03" in warned[0], out.stderr
    assert "C_m0[2] moved beyond 3σ" in (tmp_path / "r" / "report.html").read_text()
    assert json.loads((tmp_path / "r" / "history.json").read_text())["drifts"][0]["name"] == "C_m0[2]"


@pytest.mark.parametrize("argv,problem", [
    (["--report", "DB"], "--report"),
    (["--db", "/nonexistent/h.sqlite"], "--db"),
    (["--parameter", "C_m0[9]"], "--parameter"),
    (["--csv", "h.txt"], "--csv"),
])
def test_history_command_usage_errors(db, argv, problem):
    args = [a if a != "DB" else str(db) for a in argv]
    if "--db" not in args:
        args += ["--db", str(db)]
    out = _tendyn("history", "lexos", *args)
    assert out.returncode == 2 and problem in out.stderr and out.stderr.count("\n") == 1, out.stderr


def test_record_options_are_checked_before_any_work(tmp_path):
    out = _tendyn("identify-friction", "lexos", str(bundled("lexos")), "--out", str(tmp_path / "f.json"),
                  "--db", str(tmp_path / "h.sqlite"))
    assert out.returncode == 2 and "--db needs --record" in out.stderr


def _foreign(path):
    """Another application's SQLite file (a notes app with its own tables)."""
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY, body TEXT)")
    con.execute("INSERT INTO notes (body) VALUES ('keep me')")
    con.commit()
    con.close()


def _dropped(path, lexos):
    hist.record(lexos, "validate", {"metrics": {"rms": 0.1}}, db=path)
    con = sqlite3.connect(path)
    con.execute("DROP TABLE parameters")
    con.commit()
    con.close()


def _foreign_app_id(path, lexos):
    _foreign(path)
    con = sqlite3.connect(path)
    con.execute("PRAGMA application_id = 1234")
    con.commit()
    con.close()


def _extra_table(path, lexos):
    hist.record(lexos, "validate", {"metrics": {"rms": 0.1}}, db=path)
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE notes (id INTEGER)")
    con.commit()
    con.close()


def _damaged(path, lexos):
    hist.record(lexos, "validate", {"metrics": {"rms": 0.1}}, db=path)
    data = bytearray(path.read_bytes())
    data[100:4096] = b"\xff" * (4096 - 100)            # the first page's b-tree wrecked, the header kept
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("make", ["foreign", "foreign_app_id", "dropped", "extra_table", "damaged", "junk"])
def test_a_file_tendyn_does_not_own_is_refused_and_left_byte_identical(tmp_path, lexos, capsys, make):
    """history --db F, identify --record --db F and the library calls on another application's database, a
    history whose table was dropped or that gained a foreign table, a damaged file, junk: refused in one line
    (exit 2), the file byte-identical afterwards (issue 34 item 4)."""
    from tendyn.cli import main

    path = tmp_path / "other.sqlite"
    {"foreign": lambda: _foreign(path), "foreign_app_id": lambda: _foreign_app_id(path, lexos),
     "dropped": lambda: _dropped(path, lexos), "extra_table": lambda: _extra_table(path, lexos),
     "damaged": lambda: _damaged(path, lexos),
     "junk": lambda: path.write_bytes(b"SQLite format 3\x00" + b"junk" * 300)}[make]()
    before = path.read_bytes()
    for call in (lambda: hist.check_db(path), lambda: hist.connect(path), lambda: hist.history(lexos, db=path),
                 lambda: hist.record(lexos, "validate", {"metrics": {"rms": 0.1}}, db=path)):
        with pytest.raises(ValueError, match="not a tendyn history database|damaged"):
            call()
        assert path.read_bytes() == before
    for argv in (["history", "lexos", "--db", str(path)],
                 ["identify-friction", "lexos", str(bundled("lexos")), "--out", str(tmp_path / "f.json"),
                  "--record", "--db", str(path)]):
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and err.startswith("tendyn: error:") and str(path) in err, (argv, err)
        assert path.read_bytes() == before


def test_a_new_database_is_stamped_and_an_empty_file_is_adopted(tmp_path, lexos):
    for path in (tmp_path / "new.sqlite", tmp_path / "empty.sqlite"):
        if path.name == "empty.sqlite":
            path.write_bytes(b"")
        hist.record(lexos, "validate", {"metrics": {"rms": 0.1}}, db=path)
        con = sqlite3.connect(path)
        assert con.execute("PRAGMA application_id").fetchone()[0] == hist.APPLICATION_ID
        assert con.execute("PRAGMA user_version").fetchone()[0] == hist.SCHEMA_VERSION
        con.close()
        before = path.read_bytes()
        hist.history(lexos, db=path)
        assert path.read_bytes() == before
