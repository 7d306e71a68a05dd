"""Calibration history: identification results of a device over time, in an embedded SQLite database.

``tendyn identify … --record`` and ``tendyn identify-friction … --record`` add their result (``--db PATH`` for
another database than :func:`default_db`); ``tendyn history DEVICE`` shows each parameter over time with its σ,
flags a change beyond 3σ from one record to the next, plots it and exports CSV or Parquet.

Records are keyed by the device hash — SHA-256 of the device file's bytes, so an edited device file is another
device — and the UTC date. The file carries SQLite's ``application_id`` (:data:`APPLICATION_ID`) and its schema
version in ``user_version`` (also table ``meta``, key ``schema_version``); before anything is written
:func:`check_db` / :func:`connect` refuse another application's database, a damaged one or one whose tables are
not exactly those of its version (issue 34: a file tendyn does not own stays byte-identical); :func:`connect`
migrates an older tendyn database in place, step by step (:data:`MIGRATIONS`), and refuses a newer one.
Standard library only (``sqlite3``).
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import sys
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from tendyn.results import Result, format_table

__all__ = ["APPLICATION_ID", "SCHEMA_VERSION", "MIGRATIONS", "KINDS", "default_db", "device_hash", "check_db", "connect", "record",
           "parameters_of", "history", "History", "DRIFT_SIGMAS"]

KINDS = ("identify", "identify-friction", "validate")
"""What a record holds: base dynamic parameters (IDIM), transmission friction (FRICTION.json), a validation."""
DRIFT_SIGMAS = 3.0
"""A change between consecutive records beyond this many combined σ is flagged as drift."""

MIGRATIONS = (
    # 1: runs and their parameters
    ("CREATE TABLE runs (id INTEGER PRIMARY KEY AUTOINCREMENT, device TEXT NOT NULL, device_hash TEXT NOT NULL, "
     "kind TEXT NOT NULL, created TEXT NOT NULL, source TEXT NOT NULL, document TEXT NOT NULL)",
     "CREATE TABLE parameters (run_id INTEGER NOT NULL REFERENCES runs(id), name TEXT NOT NULL, "
     "value REAL NOT NULL, sigma REAL, unit TEXT)",
     "CREATE INDEX runs_by_device ON runs (device_hash, created)"),
    # 2: the tendyn version that wrote a run
    ("ALTER TABLE runs ADD COLUMN tendyn_version TEXT NOT NULL DEFAULT ''",),
)
"""SQL of each schema version, applied in order (schema version = number of steps applied)."""
SCHEMA_VERSION = len(MIGRATIONS)


def default_db() -> Path:
    """The user's data folder: ``$XDG_DATA_HOME/tendyn`` (``~/.local/share/tendyn``) on Linux, ``~/Library/
    Application Support/tendyn`` on macOS, ``%APPDATA%/tendyn`` on Windows; file ``history.sqlite``."""
    if sys.platform == "win32":
        base = Path(os.environ.get("APPDATA", Path.home() / "AppData" / "Roaming"))
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Application Support"
    else:
        base = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
    return base / "tendyn" / "history.sqlite"


def device_hash(device) -> str:
    """SHA-256 (hex) of the device file's bytes."""
    return hashlib.sha256(Path(device.path).read_bytes()).hexdigest()


APPLICATION_ID = 0x54445948
"""SQLite ``application_id`` of a tendyn history database ("TDYH"): a file without it is another application's
(a database written before issue 34 is recognised by its exact tables and stamped on its next write)."""


def _expected_schema(version: int) -> dict[str, tuple[str, ...]]:
    """{table or index name: column names} of a history database of schema ``version`` (built in memory from
    :data:`MIGRATIONS`, the one definition)."""
    con = sqlite3.connect(":memory:")
    try:
        con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
        for step in MIGRATIONS[:version]:
            for sql in step:
                con.execute(sql)
        return _schema_of(con)
    finally:
        con.close()


def _schema_of(con: sqlite3.Connection) -> dict[str, tuple[str, ...]]:
    out = {}
    for kind, name in con.execute("SELECT type, name FROM sqlite_master WHERE type IN ('table', 'index') "
                                  "AND name NOT LIKE 'sqlite_%'"):
        pragma = "table_info" if kind == "table" else "index_info"
        out[f"{kind} {name}"] = tuple(r[2] if kind == "index" else r[1]
                                      for r in con.execute(f"PRAGMA {pragma}(\"{name}\")"))
    return out


def _inspect(path: Path) -> tuple[int, bool]:
    """(schema version, stamped) of the existing file ``path``, read-only; raises ValueError unless it is a
    tendyn history database of this or an older schema, undamaged, with exactly the tables of its version."""
    if path.stat().st_size == 0:
        return 0, False                         # an empty file holds nobody's data: a new database
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    except sqlite3.Error as exc:
        raise ValueError(f"{path}: cannot open ({exc})") from None
    try:
        app = con.execute("PRAGMA application_id").fetchone()[0]
        user_version = con.execute("PRAGMA user_version").fetchone()[0]
        ok = con.execute("PRAGMA quick_check").fetchone()[0]
        if ok != "ok":
            raise ValueError(f"{path}: damaged database ({ok}); left unchanged")
        schema = _schema_of(con)
        if app == APPLICATION_ID:
            version = int(user_version)
        elif app == 0 and user_version == 0 and "table meta" in schema:
            row = con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            version = int(row[0]) if row else -1
        else:
            raise ValueError(f"{path}: not a tendyn history database (application_id {app:#x}, tendyn's is "
                             f"{APPLICATION_ID:#x}); left unchanged")
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"{path}: not a tendyn history database ({exc}); left unchanged") from None
    except (TypeError, ValueError) as exc:
        if str(exc).startswith(f"{path}:"):
            raise
        raise ValueError(f"{path}: not a tendyn history database (bad schema version: {exc}); left unchanged") \
            from None
    finally:
        con.close()
    if version > SCHEMA_VERSION:
        raise ValueError(f"{path}: schema version {version} is newer than this tendyn's ({SCHEMA_VERSION}); "
                         "left unchanged")
    if version < 1 or schema != _expected_schema(version):
        missing = sorted(set(_expected_schema(max(version, 1))) - set(schema))
        extra = sorted(set(schema) - set(_expected_schema(max(version, 1))))
        what = "; ".join(x for x in (f"missing {', '.join(missing)}" if missing else "",
                                     f"foreign {', '.join(extra)}" if extra else "") if x) or "columns differ"
        raise ValueError(f"{path}: not a tendyn history database of schema {version} ({what}); left unchanged")
    return version, app == APPLICATION_ID


def check_db(path=None) -> Path:
    """Before any work: the database at ``path`` (default :func:`default_db`) can be recorded into — an existing
    tendyn history database (its ``application_id``, ``user_version`` ≤ :data:`SCHEMA_VERSION`, undamaged, exactly
    the tables of its version) that this user can write, or a file that can be created. Reads only, creates
    nothing (a command refused later leaves no empty database behind), never writes a file tendyn does not own.
    Raises ValueError."""
    from tendyn.io.files import creatable

    path = Path(path) if path is not None else default_db()
    if not path.exists():
        parent, problem = creatable(path)
        if problem:
            raise ValueError(f"{path}: cannot create: {parent} is {problem}")
        return path
    if not path.is_file():
        raise ValueError(f"{path}: not a file")
    if not os.access(path, os.R_OK | os.W_OK):
        raise ValueError(f"{path}: permission denied")
    _inspect(path)
    return path


def connect(path=None, *, write: bool = True) -> sqlite3.Connection:
    """Open the database at ``path`` (default :func:`default_db`), checked first as by :func:`check_db` (a file
    tendyn does not own is refused before anything is written); with ``write`` create it and bring its schema up
    to :data:`SCHEMA_VERSION` (stamping ``application_id`` and ``user_version``), else open it read-only.
    Raises ValueError."""
    path = Path(path) if path is not None else default_db()
    version, stamped = _inspect(path) if path.exists() else (0, False)
    if not write:
        return sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    con = sqlite3.connect(path)
    if version == SCHEMA_VERSION and stamped:
        return con
    try:
        with con:
            if version == 0:
                con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            for step in MIGRATIONS[version:]:
                for sql in step:
                    con.execute(sql)
            con.execute("INSERT OR REPLACE INTO meta (key, value) VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
            con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    except sqlite3.DatabaseError as exc:
        con.close()
        raise ValueError(f"{path}: not a tendyn history database ({exc})") from None
    return con


def parameters_of(kind: str, doc: dict) -> list[tuple[str, float, float | None, str]]:
    """(name, value, σ, unit) of a result document: ``identify`` its base parameters (``params``);
    ``identify-friction`` per transmission ``C_m0[i]`` [N·m] and ``nu[i]`` [N·m·s/rad] with their σ;
    ``validate`` its ``metrics`` mapping (name → value or {value, sigma, unit})."""
    if kind == "identify":
        return [(p["name"], float(p["value"]), float(p["stderr"]), p.get("unit") or "") for p in doc["params"]]
    if kind == "identify-friction":
        out = []
        for f in doc["fits"]:
            t = f["transmission"]
            out.append((f"C_m0[{t}]", float(f["coulomb_motor"]), float(f["coulomb_motor_std"]), "N·m"))
            out.append((f"nu[{t}]", float(f["viscous_motor"]), float(f["viscous_motor_std"]), "N·m·s/rad"))
        return out
    if kind == "validate":
        out = []
        for name, v in doc["metrics"].items():
            if isinstance(v, dict):
                out.append((name, float(v["value"]), None if v.get("sigma") is None else float(v["sigma"]),
                            v.get("unit", "")))
            else:
                out.append((name, float(v), None, ""))
        return out
    raise ValueError(f"kind must be one of {', '.join(KINDS)} (got {kind!r})")


def record(device, kind: str, doc: dict, *, db=None, source: str = "", created: datetime | None = None) -> int:
    """Add one result to the history; returns its run id. ``created`` defaults to now (UTC)."""
    from tendyn import __version__
    from tendyn.io.files import to_jsonable

    params = parameters_of(kind, doc)
    when = (created or datetime.now(timezone.utc)).astimezone(timezone.utc).isoformat(timespec="seconds")
    con = connect(db)
    try:
        with con:
            cur = con.execute("INSERT INTO runs (device, device_hash, kind, created, source, document, "
                              "tendyn_version) VALUES (?, ?, ?, ?, ?, ?, ?)",
                              (device.name, device_hash(device), kind, when, source,
                               json.dumps(to_jsonable(doc)), __version__))
            run = int(cur.lastrowid)
            con.executemany("INSERT INTO parameters (run_id, name, value, sigma, unit) VALUES (?, ?, ?, ?, ?)",
                            [(run, n, v, s, u) for n, v, s, u in params])
    finally:
        con.close()
    return run


@dataclass(eq=False)
class History(Result):
    """Every recorded parameter of a device over time.

    Attributes
    ----------
    device : name; device_hash : SHA-256 of its file
    rows : one dict per (run, parameter): run, kind, created (ISO, UTC), name, value, sigma, unit, drift
        (True when |value − previous| > 3 √(σ² + σ_prev²), the previous record of the same parameter and kind)
    other_hashes : records of a device of the same name with another file (not shown)
    """

    device: str
    device_hash: str
    rows: list = field(default_factory=list)
    other_hashes: int = 0
    _figsize = (7.5, 4.2)

    def names(self) -> list[str]:
        return sorted({r["name"] for r in self.rows})

    def drifts(self) -> list[dict]:
        return [r for r in self.rows if r["drift"]]

    @property
    def warnings(self) -> list[str]:
        """One line per drift beyond 3σ (the report's warnings)."""
        return [f"{r['name']} moved beyond 3σ from its previous record on {r['created'][:10]} ({r['kind']}: "
                f"{r['value']:.6g} {r['unit']})" for r in self.drifts()]

    reading = ('Each identified parameter over the records, divided by its first value (bars: 3σ); a red cross marks '
               'a drift beyond 3σ, a change of the device.')

    def _draw(self, ax) -> None:
        for name in self.names():
            rows = [r for r in self.rows if r["name"] == name]
            t = [datetime.fromisoformat(r["created"]) for r in rows]
            v = np.array([r["value"] for r in rows])
            s = np.array([np.nan if r["sigma"] is None else r["sigma"] for r in rows])
            ref = abs(v[0]) if v[0] != 0 else 1.0
            ax.errorbar(t, v / ref, yerr=3 * s / ref, marker="o", ms=3, capsize=2,
                        label=f"{name} [{rows[0]['unit']}] / {v[0]:.4g}")
            bad = [k for k, r in enumerate(rows) if r["drift"]]
            if bad:
                ax.plot([t[k] for k in bad], v[bad] / ref, "rx", ms=9, mew=2)
        ax.set_xlabel("record date (UTC)")
        ax.set_ylabel("value / first record (bars: 3σ; ×: drift > 3σ)")
        ax.set_title(f"{self.device}: calibration history")
        ax.legend(fontsize=6, ncol=2)
        ax.figure.autofmt_xdate()

    def to_dict(self) -> dict:
        return {"device": self.device, "device_hash": self.device_hash, "rows": self.rows,
                "drifts": self.drifts(), "other_hashes": self.other_hashes}

    def table(self) -> str:
        rows = [(r["created"], r["kind"], r["name"], f"{r['value']:.6g}",
                 "—" if r["sigma"] is None else f"{r['sigma']:.3g}", r["unit"], "DRIFT" if r["drift"] else "")
                for r in self.rows]
        text = format_table(("date (UTC)", "kind", "parameter", "value", "σ", "unit", ""), rows,
                            title=f"{self.device} ({self.device_hash[:12]}): calibration history")
        if self.other_hashes:
            text += f"\n{self.other_hashes} record(s) of another file named {self.device!r} not shown"
        return text

    def to_csv(self) -> str:
        import csv
        import io

        from tendyn.text import spreadsheet_cell

        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=["run", "kind", "created", "name", "value", "sigma", "unit", "drift"])
        w.writeheader()
        w.writerows({k: spreadsheet_cell(v) for k, v in r.items()} for r in self.rows)   # no cell runs as a formula
        return buf.getvalue()

    def to_parquet(self) -> bytes:
        import io

        import pyarrow as pa
        import pyarrow.parquet as pq

        buf = io.BytesIO()
        cols = ["run", "kind", "created", "name", "value", "sigma", "unit", "drift"]
        pq.write_table(pa.table({c: [r[c] for r in self.rows] for c in cols}), buf)
        return buf.getvalue()


def history(device, *, db=None, names=None) -> History:
    """The history of ``device`` (its file's hash) from the database, oldest first, drift flagged; ``names``
    keeps only these parameters."""
    h = device_hash(device)
    path = Path(db) if db is not None else default_db()
    if not path.exists():                       # nothing recorded yet: a read creates no database
        return History(device.name, h, [], 0)
    con = connect(path, write=False)            # a read writes nothing (no migration, no stamp)
    try:
        rows = con.execute("SELECT r.id, r.kind, r.created, p.name, p.value, p.sigma, p.unit FROM runs r JOIN "
                           "parameters p ON p.run_id = r.id WHERE r.device_hash = ? ORDER BY r.created, r.id",
                           (h,)).fetchall()
        others = con.execute("SELECT COUNT(*) FROM runs WHERE device = ? AND device_hash != ?",
                             (device.name, h)).fetchone()[0]
    finally:
        con.close()
    out, last = [], {}
    for run, kind, created, name, value, sigma, unit in rows:
        if names and name not in names:
            continue
        prev = last.get((kind, name))
        drift = False
        if prev is not None and sigma is not None and prev[1] is not None:
            drift = abs(value - prev[0]) > DRIFT_SIGMAS * float(np.hypot(sigma, prev[1]))
        last[(kind, name)] = (value, sigma)
        out.append({"run": run, "kind": kind, "created": created, "name": name, "value": value, "sigma": sigma,
                    "unit": unit or "", "drift": bool(drift)})
    return History(device.name, h, out, int(others))
