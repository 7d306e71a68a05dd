"""Experiment logs, schema version 1: one table of float64 columns plus a small JSON meta record.

A log holds the signals of one experiment (measured on a bench or simulated), sampled on one time grid:

>>> import numpy as np
>>> from tendyn.io.logs import make_log
>>> t = np.arange(5) / 1000.0
>>> log = make_log({"time": t, "q_motor_1": np.zeros(5), "q_motor_2": np.ones(5)},
...                device="lexos", rate_hz=1000.0, seed=None, experiment="static")
>>> log.stack("q_motor_").shape
(5, 2)
>>> log.units["q_motor_1"]
'rad'

Every column name must match one entry of :data:`COLUMNS` (the registry: name pattern, unit, meaning);
indices in names are 1-based like joints and transmissions in device files (``q_motor_1`` is the motor of
transmission 1). Two file layouts hold the same content (``docs/logs.md``):

* ``.parquet``: one float64 column per signal, the meta JSON in the Arrow schema metadata under ``b"tendyn"``
  and the unit of each column in its field metadata under ``b"unit"``.
* ``.csv``: a comment line ``# tendyn-log {meta JSON}``, a header row of ``name [unit]`` cells, then one row
  per sample, floats written with ``repr`` (shortest text that reads back bit-exact).

The ground truth of a simulated log (the twin's parameters) never goes inside the log: it is written beside it,
``run.parquet`` → ``run.truth.json`` (:func:`write_truth`), so an estimator reading the log cannot see it.
A log and its truth are one pair: :func:`write_run` writes both with the same run id (``meta["run_id"]`` and
the truth's ``"run_id"``), the truth first, and :func:`read_run` / :func:`read_truth` refuse a pair whose ids
differ (the log was replaced, or a run was killed between the two writes).

All writes are atomic (temporary file + rename); all reads validate and raise :class:`LogError`, whose message
names the file, the column and the row (and the CSV line) of the first problem. :func:`check_log_path` checks
an output path before the work that produces the log.

This module uses only the standard library, numpy and (for Parquet, imported lazily) pyarrow; it never imports
the compiled core.
"""

from __future__ import annotations

import copy
import difflib
import io
import json
import math
import operator
import re
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tendyn.io.files import atomic_write_bytes, creatable, interrupts_deferred, parse_json, to_jsonable

__all__ = [
    "COLUMNS",
    "META_KEYS",
    "OPTIONAL_META_KEYS",
    "SCHEMA_VERSION",
    "ColumnSpec",
    "Log",
    "LogError",
    "check_log_path",
    "column_spec",
    "column_unit",
    "is_generic",
    "LINEAR_UNITS",
    "make_log",
    "read_meta",
    "read_log",
    "read_run",
    "read_truth",
    "truth_path",
    "write_log",
    "write_run",
    "write_truth",
]

SCHEMA_VERSION = 1
"""The log schema version this module writes and reads (``meta["schema"]``)."""

PARQUET_META_KEY = b"tendyn"
"""Key of the meta JSON in the Arrow schema metadata of a Parquet log."""

PARQUET_UNIT_KEY = b"unit"
"""Key of the unit in the Arrow field metadata of each column of a Parquet log."""

CSV_META_PREFIX = "# tendyn-log "
"""A CSV log starts with this prefix followed by the meta JSON on one line."""

TRUTH_SUFFIX = ".truth.json"
"""Suffix of the ground-truth sidecar: ``run.parquet`` → ``run.truth.json``."""

FORMATS = (".parquet", ".csv")
"""File suffixes understood by :func:`write_log` / :func:`read_log`."""


# ----------------------------------------------------------------------------------------------------------
# Errors
# ----------------------------------------------------------------------------------------------------------

class LogError(ValueError):
    """A log (file or in memory) is invalid, or cannot be written.

    The message names the file, the column and the row when relevant, e.g.
    ``run.csv: column q_motor_2, row 17 (line 20, time 0.017 s): value nan is not finite``.

    Attributes
    ----------
    file : str or None
        The file (or ``"<memory>"``) the error is about.
    column : str or None
        The column name (or ``meta.<key>`` for a meta entry).
    row : int or None
        0-based sample index of the first bad row.
    line : int or None
        1-based line number in a CSV file.
    problem : str
        What is wrong, without the location prefix.
    """

    def __init__(self, problem: str, *, file=None, column: str | None = None, row: int | None = None,
                 line: int | None = None, time: float | None = None):
        self.file = None if file is None else str(file)
        self.column = column
        self.row = row
        self.line = line
        self.problem = problem
        where = []
        if column is not None:
            where.append(column if column.startswith("meta") else f"column {column}")
        extra = []
        if line is not None:
            extra.append(f"line {line}")
        if time is not None:
            extra.append(f"time {time!r} s")
        if row is not None:
            where.append(f"row {row}" + (f" ({', '.join(extra)})" if extra else ""))
        elif extra:
            where.append(", ".join(extra))
        head = ", ".join(where)
        parts = [p for p in (self.file, head) if p]
        super().__init__(": ".join(parts + [problem]))


# ----------------------------------------------------------------------------------------------------------
# Column registry
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ColumnSpec:
    """One entry of the column registry.

    Parameters
    ----------
    name : str
        Name template as documented, ``<i>`` for a 1-based transmission/motor index, ``<j>`` for a joint.
    unit : str
        SI unit of the values.
    description : str
        One-line meaning (also used in ``docs/logs.md``).
    """

    name: str
    unit: str
    description: str

    @property
    def indexed(self) -> bool:
        """Whether the name ends with a 1-based index (``q_motor_<i>``)."""
        return self.name.endswith(">")

    @property
    def base(self) -> str:
        """The name without the index placeholder (``q_motor_``), or the full name if not indexed."""
        return self.name[: self.name.rindex("<")] if self.indexed else self.name

    @property
    def pattern(self) -> re.Pattern:
        """Regular expression a column name must fully match (indices: 1, 2, …, no leading zero)."""
        return re.compile(re.escape(self.base) + r"([1-9][0-9]*)" if self.indexed else re.escape(self.name))


COLUMNS: tuple[ColumnSpec, ...] = (
    ColumnSpec("time", "s", "sample time (required, the first column, strictly increasing)"),
    ColumnSpec("q_motor_<i>", "rad", "measured motor position (quantised encoder)"),
    ColumnSpec("qd_motor_<i>", "rad/s", "motor velocity (estimate)"),
    ColumnSpec("q_joint_<j>", "rad", "joint position (when sensed, or the simulator's truth in a truth-only log)"),
    ColumnSpec("qd_joint_<j>", "rad/s", "joint velocity"),
    ColumnSpec("torque_motor_<i>", "N·m", "measured motor torque (k_t × measured current)"),
    ColumnSpec("torque_motor_cmd_<i>", "N·m", "commanded motor torque"),
    ColumnSpec("current_<i>", "A", "measured motor current"),
    ColumnSpec("q_ref_<j>", "rad", "joint position reference of the controller"),
    ColumnSpec("qd_ref_<j>", "rad/s", "joint velocity reference of the controller"),
    ColumnSpec("q_motor_ref_<i>", "rad", "motor position reference (motor space)"),
    ColumnSpec("qd_motor_ref_<i>", "rad/s", "motor velocity reference (motor space)"),
    ColumnSpec("torque_joint_ext_<j>", "N·m", "external torque applied on joint j (blocked-link tests, user)"),
    ColumnSpec("force_cmd", "N", "commanded tendon force (McGill tendon bench)"),
    ColumnSpec("force_tendon", "N", "sensed differential tendon force (McGill tendon bench)"),
    ColumnSpec("force_ref", "N", "tendon force reference of a closed loop (McGill tendon bench; controller in meta.options)"),
    ColumnSpec("x_tendon", "m", "sensed tendon displacement (McGill tendon bench)"),
    ColumnSpec("current_cmd", "A", "commanded motor current (McGill tendon bench)"),
    ColumnSpec("input_<k>", "*", "generic input signal k of a bench (any unit: its name and unit in meta.signals)"),
    ColumnSpec("output_<k>", "*", "generic output signal k of a bench (any unit: its name and unit in meta.signals)"),
)
"""The column registry of schema version 1: every column of a log matches exactly one entry."""

_PATTERNS = tuple((spec, spec.pattern) for spec in COLUMNS)

GENERIC_UNIT = "*"
"""Registry unit of the generic columns ``input_<k>`` / ``output_<k>``: the unit is the log's own,
declared with the signal's name in ``meta.signals`` (``{"input_1": {"name": "voltage", "unit": "V"}}``)."""

UNIT_ALIASES: dict[str, tuple[str, ...]] = {"N·m": ("N.m", "N*m", "Nm", "N m", "N⋅m")}
"""ASCII spellings accepted in a CSV header for a registry unit (the files we write use the registry unit)."""


LINEAR_UNITS: dict[str, str] = {"rad": "m", "rad/s": "m/s", "N·m": "N"}
"""The unit a position, velocity or torque column holds instead of the registry's when it belongs to a
prismatic joint or a linear motor (metres, m/s, newtons); a log declares such columns in ``meta.units``
(``{"q_motor_1": "m", "torque_motor_1": "N"}``)."""


def column_spec(name: str) -> ColumnSpec | None:
    """The registry entry a column name matches, or None."""
    if not isinstance(name, str):
        return None
    for spec, pat in _PATTERNS:
        if pat.fullmatch(name):
            return spec
    return None


def _column_index(name: str, prefix: str) -> int | None:
    """The 1-based index of ``name`` if it is ``prefix`` followed by an index, else None."""
    if name.startswith(prefix):
        rest = name[len(prefix):]
        if rest.isascii() and rest.isdigit() and not rest.startswith("0"):
            return int(rest)
    return None


def _suggest(name: str) -> str:
    """A hint for an unknown column name: the closest registry entry."""
    m = re.fullmatch(r"(.*?)_?([0-9]+)", name) if isinstance(name, str) else None
    idx = int(m.group(2)) if m else None
    if m and idx == 0 and column_spec(m.group(1) + "_1") is not None:
        return f"; indices are 1-based (did you mean {m.group(1)}_1?)"
    candidates = {}
    for spec in COLUMNS:
        example = spec.base + str(idx if idx else 1) if spec.indexed else spec.name
        candidates[example] = spec
    close = difflib.get_close_matches(str(name), list(candidates), n=1, cutoff=0.6)
    if close:
        spec = candidates[close[0]]
        return f"; did you mean {close[0]} ({spec.name} [{spec.unit}], {spec.description})?"
    return "; known columns: " + ", ".join(s.name for s in COLUMNS)


def is_generic(name: str) -> bool:
    """Whether a column is a generic ``input_<k>`` / ``output_<k>`` (unit and name in ``meta.signals``)."""
    spec = column_spec(name)
    return spec is not None and spec.unit == GENERIC_UNIT


def column_unit(name: str, meta: dict) -> str:
    """The unit of column ``name`` in a log with ``meta``: the registry's, for a generic column the one
    declared in ``meta["signals"]``, for a linear column (prismatic joint, linear motor) ``meta["units"]``'s."""
    if is_generic(name):
        return meta["signals"][name]["unit"]
    return meta.get("units", {}).get(name) or column_spec(name).unit


def _unit_matches(found: str, expected: str) -> bool:
    return found == expected or found in UNIT_ALIASES.get(expected, ())


# ----------------------------------------------------------------------------------------------------------
# Meta
# ----------------------------------------------------------------------------------------------------------

META_KEYS: dict[str, str] = {
    "schema": "int, the log schema version (1)",
    "device": "str, the device name or device file the log is about",
    "rate_hz": "float > 0 [Hz], the sampling rate of the log",
    "seed": "int or null, the seed of a simulated log (null for a measured log)",
    "experiment": "str, the experiment name (e.g. 'static', 'chirp', 'blocked_link')",
    "options": "dict (JSON), the experiment settings",
    "created_by": "str, 'tendyn <version>' of the writer",
}
"""Keys of ``Log.meta`` that are required, and their types."""

OPTIONAL_META_KEYS: dict[str, str] = {
    "run_id": "str, the id a log shares with its truth file (32 hex digits, set by write_run; absent in "
              "measured logs and in files written before run ids)",
    "units": "dict, column -> unit for the columns of a prismatic joint or a linear motor, which hold m, m/s, N "
             "instead of the registry's rad, rad/s, N·m (LINEAR_UNITS)",
    "signals": "dict, one entry per generic column input_<k>/output_<k>: {\"name\": str, \"unit\": str} "
               "(required when the log has generic columns)",
}
"""Keys of ``Log.meta`` that may be present; no keys other than these and :data:`META_KEYS` are allowed."""

_ALL_META_KEYS = (*META_KEYS, *OPTIONAL_META_KEYS)


def parse_number(cell: str) -> float:
    """A CSV cell as a float. Python's float() also reads ``1_000`` (as 1000), which no lab file means: refused."""
    if "_" in cell:
        raise ValueError(f"{cell!r}: '_' in a number")
    return float(cell)


# How far a declared rate may be from a time column, as a factor on its steps: an import map's rate must match the
# column (1 %); a log's nominal rate may sit anywhere among irregular steps, but not off them by a factor of 2
# (`rate_hz = 5000` over a 1 kHz time column is refused on import and on read).
IMPORT_RATE_SLACK = 1.01
LOG_RATE_SLACK = 2.0


def time_column_rate(time: np.ndarray) -> float:
    """The sampling rate of a time column [Hz]: 1 / median step (robust to a few jittered samples)."""
    return float(1.0 / np.median(np.diff(time)))


def rate_contradicts_time(rate: float, time: np.ndarray, slack: float) -> bool:
    """Whether a declared (nominal) rate [Hz] contradicts a time column of two or more samples: its period 1/rate
    must lie between the shortest step / ``slack`` and the longest step × ``slack``."""
    steps = np.diff(time)
    return not (steps.min() / slack <= 1.0 / rate <= steps.max() * slack)


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _json_text(obj) -> str:
    return json.dumps(obj, ensure_ascii=False, allow_nan=False)


def _check_meta(meta, source) -> None:
    if not isinstance(meta, dict):
        raise LogError(f"meta must be a dict, got {type(meta).__name__}", file=source, column="meta")
    missing = [k for k in META_KEYS if k not in meta]
    if missing:
        raise LogError("missing key(s) " + ", ".join(missing) + " (meta keys: " + ", ".join(META_KEYS) + ")",
                       file=source, column="meta")
    unknown = [str(k) for k in meta if k not in _ALL_META_KEYS]
    if unknown:
        raise LogError("unknown key(s) " + ", ".join(unknown) + "; experiment settings go in meta.options "
                       "and ground truth in the truth sidecar (meta keys: " + ", ".join(_ALL_META_KEYS) + ")",
                       file=source, column="meta")

    def bad(key, problem):
        expected = META_KEYS.get(key) or OPTIONAL_META_KEYS[key]
        return LogError(f"{problem} (expected {expected})", file=source, column=f"meta.{key}")

    schema = meta["schema"]
    if not _is_int(schema):
        raise bad("schema", f"got {schema!r} of type {type(schema).__name__}")
    if schema != SCHEMA_VERSION:
        raise bad("schema", f"schema {schema} is not the version this tendyn reads ({SCHEMA_VERSION})")
    for key in ("device", "experiment", "created_by"):
        val = meta[key]
        if not isinstance(val, str):
            raise bad(key, f"got {val!r} of type {type(val).__name__}")
        if not val.strip():
            raise bad(key, "must not be empty")
    rate = meta["rate_hz"]
    if not isinstance(rate, (int, float)) or isinstance(rate, bool):
        raise bad("rate_hz", f"got {rate!r} of type {type(rate).__name__}")
    if not math.isfinite(rate) or rate <= 0:
        raise bad("rate_hz", f"must be finite and > 0 (got {rate!r})")
    seed = meta["seed"]
    if seed is not None and not _is_int(seed):
        raise bad("seed", f"got {seed!r} of type {type(seed).__name__}")
    options = meta["options"]
    if not isinstance(options, dict):
        raise bad("options", f"got {options!r} of type {type(options).__name__}")
    try:
        back = parse_json(_json_text(options))
    except (TypeError, ValueError) as exc:
        raise bad("options", f"not JSON-serialisable: {exc}") from None
    if back != options:
        raise bad("options", "does not survive a JSON round trip (tuples, non-string keys or numpy values?); "
                  "build the log with make_log, which converts them")
    if "run_id" in meta:
        run_id = meta["run_id"]
        if not isinstance(run_id, str) or not run_id.strip():
            raise bad("run_id", f"got {run_id!r} of type {type(run_id).__name__}")
    if "signals" in meta:
        _check_signals(meta["signals"], bad)
    if "units" in meta:
        _check_units(meta["units"], bad)


def _check_units(units, bad) -> None:
    """``meta.units``: column → the linear counterpart (:data:`LINEAR_UNITS`) of its registry unit."""
    if not isinstance(units, dict):
        raise bad("units", f"got {units!r} of type {type(units).__name__}")
    for col, unit in units.items():
        spec = column_spec(col)
        if spec is None or spec.unit not in LINEAR_UNITS:
            raise bad("units", f"{col!r}: only a column in rad, rad/s or N·m can be declared linear")
        if unit != LINEAR_UNITS[spec.unit]:
            raise bad("units", f"{col}: got {unit!r}, expected {LINEAR_UNITS[spec.unit]!r} (a linear "
                      f"{spec.unit} column) or no entry")


def _check_signals(signals, bad) -> None:
    """``meta.signals``: generic column → {"name": non-empty str, "unit": non-empty str}, names unique."""
    if not isinstance(signals, dict):
        raise bad("signals", f"got {signals!r} of type {type(signals).__name__}")
    names = {}
    for col, entry in signals.items():
        if not is_generic(col):
            raise bad("signals", f"{col!r} is not a generic column (input_<k> or output_<k>)")
        if not isinstance(entry, dict) or set(entry) != {"name", "unit"}:
            raise bad("signals", f"{col}: got {entry!r}, expected exactly the keys name and unit")
        for key in ("name", "unit"):
            if not isinstance(entry[key], str) or not entry[key].strip() or any(c in entry[key] for c in "[],") \
                    or not entry[key].isprintable():          # no control character or newline (docs/security.md)
                raise bad("signals", f"{col}.{key}: got {entry[key]!r}, expected a non-empty printable string "
                          "without brackets or commas")
        if entry["name"] in names:
            raise bad("signals", f"{col}.name: {entry['name']!r} also names {names[entry['name']]}")
        names[entry["name"]] = col


# ----------------------------------------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------------------------------------

def _check_names(names, source) -> None:
    """Column names: not empty, ``time`` first, every name known, no duplicate."""
    if not names:
        raise LogError("no columns (a log needs at least time [s])", file=source)
    if "time" not in names:
        raise LogError(f"missing the required column time [s] (columns: {', '.join(map(str, names))})",
                       file=source, column="time")
    if names[0] != "time":
        raise LogError(f"the first column is {names[0]}; time [s] must come first", file=source, column="time")
    seen = set()
    for name in names:
        if not isinstance(name, str):
            raise LogError(f"column name {name!r} is not a string", file=source)
        if name in seen:
            raise LogError("duplicate column", file=source, column=name)
        seen.add(name)
        if column_spec(name) is None:
            raise LogError(f"unknown column {name!r}, not in the log schema{_suggest(name)}", file=source)


def _validate(columns, meta, source, line_of_row: int | None = None) -> None:
    """Check a whole log; ``line_of_row`` is the CSV line of row 0 (to name lines in messages)."""
    if not isinstance(columns, dict):
        raise LogError(f"columns must be a dict of name -> array, got {type(columns).__name__}", file=source)
    names = list(columns)
    _check_names(names, source)
    for name, arr in columns.items():
        if not isinstance(arr, np.ndarray):
            raise LogError(f"values must be a numpy array, got {type(arr).__name__} (make_log converts)",
                           file=source, column=name)
        if arr.ndim != 1:
            raise LogError(f"values must be 1-D, got shape {arr.shape}", file=source, column=name)
        if arr.dtype != np.float64:
            raise LogError(f"values must be float64, got {arr.dtype} (make_log converts)", file=source,
                           column=name)
    time = columns["time"]
    n = time.shape[0]
    for name, arr in columns.items():
        if arr.shape[0] != n:
            raise LogError(f"has {arr.shape[0]} values but time has {n}", file=source, column=name)
    if n == 0:
        raise LogError("empty log (no samples)", file=source)

    def line(row):
        return None if line_of_row is None else line_of_row + row

    for name, arr in columns.items():
        finite = np.isfinite(arr)
        if not finite.all():
            row = int(np.argmin(finite))
            t = float(time[row]) if name != "time" and math.isfinite(time[row]) else None
            raise LogError(f"value {float(arr[row])!r} is not finite", file=source, column=name, row=row,
                           line=line(row), time=t)
    if n > 1:
        bad = np.flatnonzero(np.diff(time) <= 0.0)
        if bad.size:
            row = int(bad[0]) + 1
            raise LogError(f"time is not strictly increasing: {float(time[row])!r} s after "
                           f"{float(time[row - 1])!r} s at row {row - 1}", file=source, column="time", row=row,
                           line=line(row))
    _check_meta(meta, source)
    if n > 1 and rate_contradicts_time(meta["rate_hz"], time, LOG_RATE_SLACK):
        raise LogError(f"{meta['rate_hz']:g} Hz, but the time column is sampled at {time_column_rate(time):g} Hz",
                       file=source, column="meta.rate_hz")
    declared = meta.get("signals", {})
    for name in names:
        if is_generic(name) and name not in declared:
            raise LogError(f"generic column without a name and unit: declare it in meta.signals "
                           f"({{\"{name}\": {{\"name\": ..., \"unit\": ...}}}})", file=source, column=name)
    for name, entry in declared.items():
        if name not in columns:
            raise LogError(f"meta.signals declares {name}, which is not a column of the log", file=source,
                           column="meta.signals")
        if entry["name"] in columns and entry["name"] != name:
            raise LogError(f"{name}.name {entry['name']!r} is the name of another column (a signal is called by "
                           "either name)", file=source, column="meta.signals")
    for name in meta.get("units", {}):
        if name not in columns:
            raise LogError(f"meta.units declares {name}, which is not a column of the log", file=source,
                           column="meta.units")


# ----------------------------------------------------------------------------------------------------------
# The Log
# ----------------------------------------------------------------------------------------------------------

@dataclass(eq=False)
class Log:
    """One experiment log: float64 columns on one time grid, and its meta record.

    Build one with :func:`make_log` (converts and validates) or :func:`read_log`. Equality (``==``) is
    bit-exact on the values, and compares column order and meta.

    Parameters
    ----------
    columns : dict[str, numpy.ndarray]
        1-D float64 arrays, all the same length, in insertion order, ``"time"`` [s] first. Names and units
        follow :data:`COLUMNS`.
    meta : dict
        ``schema``, ``device``, ``rate_hz`` [Hz], ``seed``, ``experiment``, ``options``, ``created_by``
        (see :data:`META_KEYS`), and ``run_id`` when written by :func:`write_run`.
    """

    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise KeyError(f"no column {name!r} in the log (columns: {', '.join(self.columns)})") from None

    def __contains__(self, name) -> bool:
        return name in self.columns

    def __eq__(self, other) -> bool:
        if not isinstance(other, Log):
            return NotImplemented
        return (list(self.columns) == list(other.columns)
                and all(np.array_equal(a, other.columns[k]) for k, a in self.columns.items())
                and self.meta == other.meta)

    __hash__ = None

    def __repr__(self) -> str:
        return (f"Log(n_samples={self.n_samples}, device={self.meta.get('device')!r}, "
                f"experiment={self.meta.get('experiment')!r}, columns={list(self.columns)})")

    @property
    def n_samples(self) -> int:
        """Number of samples (rows)."""
        return int(self.columns["time"].shape[0]) if "time" in self.columns else 0

    @property
    def time(self) -> np.ndarray:
        """Sample times [s]."""
        return self["time"]

    @property
    def units(self) -> dict[str, str]:
        """Column name → unit, from the registry or, for a generic column, ``meta.signals`` (``"?"`` for a
        name not in either)."""
        out = {}
        for name in self.columns:
            try:
                out[name] = column_unit(name, self.meta)
            except (AttributeError, KeyError, TypeError):
                out[name] = "?"
        return out

    @property
    def signal_names(self) -> dict[str, str]:
        """Column name → the name a user gave its signal (``meta.signals``; a registry column is its own name)."""
        declared = self.meta.get("signals", {})
        return {name: declared[name]["name"] if name in declared else name for name in self.columns}

    def resolve(self, name: str) -> str:
        """The column of a signal given by its column name (``input_1``, ``force_cmd``) or by the name
        ``meta.signals`` gives it (``voltage``). Raises :class:`LogError` naming the known signals."""
        if name in self.columns:
            return name
        for col, given in self.signal_names.items():
            if given == name:
                return col
        known = ", ".join(f"{c} ({n})" if c != n else c for c, n in self.signal_names.items() if c != "time")
        raise LogError(f"no signal {name!r} in the log (signals: {known})", column=name)

    def column_names(self, prefix: str) -> list[str]:
        """Names ``prefix + <index>`` present in the log, sorted by index (``q_motor_9`` before ``q_motor_10``).

        Only exact ``prefix`` + index names count: ``column_names("q_motor_")`` does not return
        ``q_motor_ref_1``. Empty list if none.
        """
        found = []
        for name in self.columns:
            idx = _column_index(name, prefix)
            if idx is not None:
                found.append((idx, name))
        return [name for _, name in sorted(found)]

    def stack(self, prefix: str) -> np.ndarray:
        """The columns ``prefix1, prefix2, …, prefixk`` as an ``(n_samples, k)`` float64 array.

        Column c of the result is index c + 1. Raises :class:`LogError` if no column has this prefix or the
        indices are not exactly 1..k (a gap would shift the columns silently).
        """
        names = self.column_names(prefix)
        if not names:
            raise LogError(f"no column {prefix}<i> in the log (columns: {', '.join(self.columns)})",
                           column=f"{prefix}<i>")
        indices = [_column_index(n, prefix) for n in names]
        if indices != list(range(1, len(names) + 1)):
            missing = sorted(set(range(1, max(indices) + 1)) - set(indices))
            raise LogError("indices must run 1..k without gaps to stack; missing "
                           + ", ".join(f"{prefix}{i}" for i in missing), column=f"{prefix}<i>")
        out = np.empty((self.n_samples, len(names)), dtype=np.float64)
        for c, name in enumerate(names):
            out[:, c] = self.columns[name]
        return out

    def to_dict(self) -> dict:
        """``{"meta": {...}, "columns": {name: list of floats}}`` (JSON-serialisable, a deep copy)."""
        return {"meta": copy.deepcopy(self.meta),
                "columns": {name: arr.tolist() for name, arr in self.columns.items()}}

    def to_pandas(self, time_index: bool = False):
        """The log as a :class:`pandas.DataFrame` (a copy): one float64 column per log column, in log order.

        Units go in the frame's metadata, ``df.attrs["units"]`` (column → unit, as :attr:`units`: ``"rad"``,
        ``"N·m"``, a generic column's declared unit), with the generic columns' names in ``df.attrs["signals"]``
        and the meta record in ``df.attrs["meta"]`` (a deep copy). pandas keeps ``attrs`` through copies and most
        operations; Parquet files written by ``df.to_parquet`` carry them too.

        Parameters
        ----------
        time_index : bool, optional
            Make ``time`` [s] the index instead of the first column (default False).
        """
        import pandas as pd

        df = pd.DataFrame({name: arr.copy() for name, arr in self.columns.items()})
        if time_index:
            df = df.set_index("time")
        df.attrs["units"] = self.units
        df.attrs["signals"] = self.signal_names
        df.attrs["meta"] = copy.deepcopy(self.meta)
        return df

    def validate(self, source="<memory>") -> "Log":
        """Check names, units, shapes, values, time and meta; raise :class:`LogError` naming ``source``,
        the column and the row of the first problem. Returns self."""
        _validate(self.columns, self.meta, str(source))
        return self


def _created_by() -> str:
    from tendyn import __version__

    return f"tendyn {__version__}"


def make_log(columns: dict, *, device: str, rate_hz: float, seed: int | None, experiment: str,
             options: dict | None = None, signals: dict | None = None, units: dict | None = None,
             source: str = "<memory>") -> Log:
    """Build and validate a log.

    Parameters
    ----------
    columns : dict
        Column name → 1-D array-like; converted to new float64 arrays. ``"time"`` [s] is moved first if it is
        not; the other columns keep their order.
    device : str
        Device name (or device file) the log is about.
    rate_hz : float
        Sampling rate of the log [Hz], > 0.
    seed : int or None
        Seed of a simulated log; None for a measured log.
    experiment : str
        Experiment name.
    options : dict, optional
        Experiment settings; numpy values become lists/floats, tuples become lists (JSON).
    signals : dict, optional
        Name and unit of each generic column, ``{"input_1": {"name": "voltage", "unit": "V"}}`` (``meta.signals``;
        required when ``columns`` has ``input_<k>`` / ``output_<k>``).
    units : dict, optional
        Columns of a prismatic joint or linear motor and their unit, ``{"q_motor_1": "m", "torque_motor_1": "N"}``
        (``meta.units``; :data:`LINEAR_UNITS`).
    source : str, optional
        What an error names: the files the columns come from (``log import`` names the RAW files), else
        ``"<memory>"``.

    Returns
    -------
    Log

    Raises
    ------
    LogError
        On any invalid column or meta value.
    """
    source = str(source)
    if not isinstance(columns, dict):
        raise LogError(f"columns must be a dict of name -> array, got {type(columns).__name__}", file=source)
    conv: dict[str, np.ndarray] = {}
    order = (["time"] if "time" in columns else []) + [k for k in columns if k != "time"]
    for name in order:
        try:
            arr = np.array(columns[name], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise LogError(f"cannot convert the values to float64: {exc}", file=source, column=str(name)) \
                from None
        conv[name] = arr
    if isinstance(seed, np.integer):
        seed = operator.index(seed)  # numpy integers -> int; other types are named by the meta check
    if isinstance(rate_hz, (np.floating, np.integer)):
        rate_hz = float(rate_hz)
    if isinstance(rate_hz, int) and not isinstance(rate_hz, bool):
        rate_hz = float(rate_hz)
    if options is None:
        options = {}
    if not isinstance(options, dict):
        raise LogError(f"got {options!r} of type {type(options).__name__} (expected {META_KEYS['options']})",
                       file=source, column="meta.options")
    try:
        options = parse_json(_json_text(to_jsonable(options)))
    except (TypeError, ValueError) as exc:
        raise LogError(f"not JSON-serialisable: {exc}", file=source, column="meta.options") from None
    meta = {"schema": SCHEMA_VERSION, "device": device, "rate_hz": rate_hz, "seed": seed,
            "experiment": experiment, "options": options, "created_by": _created_by()}
    if signals:
        meta["signals"] = {str(k): dict(v) if isinstance(v, dict) else v for k, v in signals.items()}
    if units:
        meta["units"] = dict(units)
    return Log(conv, meta).validate(source)


# ----------------------------------------------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------------------------------------------

def _format(path) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise LogError(f"unknown log format {Path(path).suffix or '(no suffix)'!r}: use .parquet or .csv",
                       file=str(path))
    return suffix


def check_log_path(path) -> Path:
    """Check that a log can be written to ``path``, before the work that produces it; creates nothing.

    Raises
    ------
    LogError
        One line naming ``path`` if its suffix is not ``.parquet`` or ``.csv`` (any case), if it is an existing
        folder, or if its nearest existing parent is a file or a folder this user cannot write to (the missing
        folders in between would be created by the write).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    if path.is_dir():
        raise LogError("is a folder; give a file name ending in .parquet or .csv", file=str(path))
    _format(path)
    parent, problem = creatable(path)
    if problem == "not a folder":
        raise LogError(f"cannot create the log: {parent} is a file, not a folder", file=str(path))
    if problem:
        raise LogError(f"cannot create the log: no permission to write in the folder {parent}", file=str(path))
    return path


def _log_bytes(log: Log, path: Path) -> bytes:
    """The file content of ``log`` in the format of ``path``, after checking the path and validating."""
    fmt = _format(check_log_path(path))
    if not isinstance(log, Log):
        raise LogError(f"expected a Log, got {type(log).__name__}", file=str(path))
    log.validate(str(path))
    return _parquet_bytes(log) if fmt == ".parquet" else _csv_bytes(log)


def write_log(log: Log, path) -> Path:
    """Validate ``log`` and write it atomically to ``path`` (``.parquet`` or ``.csv``, chosen by the suffix).

    The folder is created if needed. On any failure an existing file at ``path`` is left as it was and no
    temporary file remains. A simulated log and its truth are written together with :func:`write_run`.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    return atomic_write_bytes(path, _log_bytes(log, path))


def read_log(path) -> Log:
    """Read and validate a log written by :func:`write_log` (or by hand following ``docs/logs.md``).

    Raises
    ------
    LogError
        Naming the file, the column and the row (and CSV line) of the first problem.
    FileNotFoundError
        If ``path`` does not exist.
    """
    path = Path(path)
    fmt = _format(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such log file")
    if fmt == ".parquet":
        return _read_parquet(path)
    return _read_csv(path)


def _file_unit(name: str, meta, source) -> str:
    """The unit a file must give column ``name``: the registry's, or the one ``meta.signals`` or
    ``meta.units`` declares."""
    if not is_generic(name):
        units = meta.get("units") if isinstance(meta, dict) else None
        return (units.get(name) if isinstance(units, dict) else None) or column_spec(name).unit
    entry = meta.get("signals", {}).get(name) if isinstance(meta, dict) and isinstance(meta.get("signals"), dict) \
        else None
    if not isinstance(entry, dict) or not isinstance(entry.get("unit"), str):
        raise LogError("generic column without a name and unit in meta.signals", file=source, column=name)
    return entry["unit"]


# -- Parquet ------------------------------------------------------------------------------------------------

def _parquet_bytes(log: Log) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    fields = [pa.field(name, pa.float64(), nullable=False,
                       metadata={PARQUET_UNIT_KEY: column_unit(name, log.meta).encode("utf-8")})
              for name in log.columns]
    schema = pa.schema(fields, metadata={PARQUET_META_KEY: _json_text(log.meta).encode("utf-8")})
    table = pa.Table.from_arrays([pa.array(arr, type=pa.float64()) for arr in log.columns.values()],
                                 schema=schema)
    buf = io.BytesIO()
    # no dictionary encoding (float signals rarely repeat; trying it costs 10x the write time)
    # page checksums (CRC32 per data page), verified on read: corrupted bytes are refused, never read as data
    pq.write_table(table, buf, use_dictionary=False, compression="zstd", write_page_checksum=True)
    return buf.getvalue()


def _read_parquet(path: Path) -> Log:
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    source = str(path)
    try:
        table = pq.read_table(path, page_checksum_verification=True)
    except (pa.ArrowException, OSError) as exc:
        raise LogError(f"not a readable Parquet file: {exc}", file=source) from None
    raw = (table.schema.metadata or {}).get(PARQUET_META_KEY)
    if raw is None:
        raise LogError("not a tendyn log: no 'tendyn' meta in the Parquet schema metadata", file=source,
                       column="meta")
    try:
        meta = parse_json(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise LogError(f"the meta is not valid JSON: {exc}", file=source, column="meta") from None
    names = list(table.column_names)
    _check_names(names, source)
    columns: dict[str, np.ndarray] = {}
    for i, name in enumerate(names):
        fld = table.schema.field(i)
        typ = fld.type
        if not (pa.types.is_floating(typ) or pa.types.is_integer(typ)):
            raise LogError(f"Arrow type {typ} is not floating or integer", file=source, column=name)
        expected = _file_unit(name, meta, source)
        unit = (fld.metadata or {}).get(PARQUET_UNIT_KEY)
        if unit is not None:
            unit = unit.decode("utf-8", "replace")
            if not _unit_matches(unit, expected):
                raise LogError(f"unit {unit!r} in the file, expected {expected!r}", file=source, column=name)
        col = table.column(i)
        if col.null_count:
            valid = np.asarray(pc.is_valid(col).to_numpy(zero_copy_only=False), dtype=bool)
            row = int(np.argmin(valid))
            raise LogError("missing value (null)", file=source, column=name, row=row)
        arr = col.to_numpy()
        columns[name] = np.array(arr, dtype=np.float64)  # own, writable copy
    log = Log(columns, meta)
    _validate(log.columns, log.meta, source)
    return log


# -- CSV ----------------------------------------------------------------------------------------------------

def _csv_bytes(log: Log) -> bytes:
    out = io.StringIO()
    out.write(CSV_META_PREFIX + _json_text(log.meta) + "\n")
    out.write(",".join(f"{name} [{column_unit(name, log.meta)}]" for name in log.columns) + "\n")
    lists = [arr.tolist() for arr in log.columns.values()]
    # repr(float) is the shortest text that reads back to the same float64 (bit-exact round trip)
    out.writelines(",".join(map(repr, row)) + "\n" for row in zip(*lists))
    return out.getvalue().encode("utf-8")


_META_LINE = re.compile(r"#\s*tendyn-log(?:\s+(.*))?")
_HEADER_CELL = re.compile(r"\s*([^\[\]]*?)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*")


def _read_csv(path: Path) -> Log:
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise LogError(f"not UTF-8 text: {exc}", file=source) from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()

    meta = None
    k = 0
    while k < len(lines) and lines[k].lstrip().startswith("#"):
        m = _META_LINE.fullmatch(lines[k].strip())
        if m:
            if meta is not None:
                raise LogError("a second '# tendyn-log' meta line", file=source, line=k + 1)
            try:
                meta = parse_json(m.group(1) or "")
            except ValueError as exc:
                raise LogError(f"the meta after '# tendyn-log' is not valid JSON: {exc}", file=source,
                               column="meta", line=k + 1) from None
        k += 1
    if meta is None:
        raise LogError("not a tendyn log: no '# tendyn-log {meta JSON}' comment line before the header",
                       file=source, column="meta")
    if k >= len(lines):
        raise LogError("no header row after the comment lines", file=source, line=k + 1)

    header_line = k + 1
    names, units = [], []
    for c, cell in enumerate(lines[k].split(",")):
        m = _HEADER_CELL.fullmatch(cell)
        if m is None or not m.group(1):
            raise LogError(f"header cell {c + 1} {cell!r} is not 'name [unit]'", file=source, line=header_line)
        names.append(m.group(1))
        units.append(m.group(2))
    _check_names(names, source)
    for name, unit in zip(names, units):
        expected = _file_unit(name, meta, source)
        if unit is None:
            raise LogError(f"no unit in the header (write '{name} [{expected}]')", file=source, column=name,
                           line=header_line)
        if not _unit_matches(unit, expected):
            raise LogError(f"unit {unit!r} in the file, expected {expected!r}", file=source, column=name)

    ncol = len(names)
    body = lines[k + 1:]
    first = k + 2  # line number of row 0
    rows: list[list[float]] = []
    parsed = True
    try:
        if any("_" in line for line in body):
            raise ValueError("'_' in a number")           # float() would read 1_000 as 1000
        for line in body:
            rows.append([float(x) for x in line.split(",")])
    except ValueError:
        parsed = False                                    # the slow path below names the cell
    if parsed:
        for r, row in enumerate(rows):
            if len(row) != ncol:
                raise LogError(f"{len(row)} cells, the header has {ncol}", file=source, row=r, line=first + r)
    else:
        # locate the first problem in order: a row with the wrong number of cells or an unparsable cell
        for r, line in enumerate(body):
            cells = line.split(",")
            if len(cells) != ncol:
                raise LogError(f"{len(cells)} cells, the header has {ncol}", file=source, row=r, line=first + r)
            for name, cell in zip(names, cells):
                try:
                    parse_number(cell)
                except ValueError:
                    raise LogError(f"cannot read {cell.strip()!r} as a number", file=source, column=name,
                                   row=r, line=first + r) from None
    if rows:
        data = np.array(rows, dtype=np.float64)
        columns = {name: np.ascontiguousarray(data[:, c]) for c, name in enumerate(names)}
    else:
        columns = {name: np.empty(0, dtype=np.float64) for name in names}
    log = Log(columns, meta)
    _validate(log.columns, log.meta, source, line_of_row=first)
    return log


# ----------------------------------------------------------------------------------------------------------
# Ground truth sidecar
# ----------------------------------------------------------------------------------------------------------

def truth_path(log_path) -> Path:
    """The ground-truth file beside a log: ``<folder>/<stem>.truth.json`` (``run.parquet`` → ``run.truth.json``)."""
    p = Path(log_path)
    return p.with_name(p.stem + TRUTH_SUFFIX)


def _truth_bytes(truth: dict, out: Path) -> bytes:
    if not isinstance(truth, dict):
        raise LogError(f"truth must be a dict, got {type(truth).__name__}", file=str(out))
    try:
        text = json.dumps(to_jsonable(truth), ensure_ascii=False, allow_nan=False, indent=2)
    except (TypeError, ValueError) as exc:
        raise LogError(f"truth is not JSON-serialisable: {exc}", file=str(out)) from None
    return (text + "\n").encode("utf-8")


def write_truth(truth: dict, log_path) -> Path:
    """Write the ground-truth parameters of a simulated log beside it (never inside it), atomically.

    Alone it writes ``truth`` as given (a ``"run_id"`` key included); :func:`write_run` writes a log and its
    truth as one pair.

    Parameters
    ----------
    truth : dict
        Parameters of the twin that generated the log; numpy values are converted with ``to_jsonable``.
    log_path : path-like
        The log the truth belongs to (it need not exist yet).

    Returns
    -------
    pathlib.Path
        :func:`truth_path` of ``log_path``.
    """
    out = truth_path(log_path)
    return atomic_write_bytes(out, _truth_bytes(truth, out))


def write_run(log: Log, truth: dict, path) -> tuple[Path, Path]:
    """Write a simulated log and its ground truth as one pair, replacing an old pair at ``path``.

    A new run id (``uuid4().hex``) goes into the log's ``meta["run_id"]`` and the truth's ``"run_id"`` key
    (the objects passed in are not changed). Both files are encoded and validated first; then the truth is
    written, then the log, each atomically. A process killed between the two writes leaves the old log beside
    the new truth: their ids differ and :func:`read_run` / :func:`read_truth` say so, instead of pairing a log
    with the parameters of another run.

    Parameters
    ----------
    log : Log
        The log (validated; an old ``run_id`` in its meta is replaced).
    truth : dict
        The twin's parameters (JSON-able after ``to_jsonable``).
    path : path-like
        The log file, ``.parquet`` or ``.csv``; the truth goes to :func:`truth_path` of it.

    Returns
    -------
    tuple of pathlib.Path
        ``(log path, truth path)``.

    Raises
    ------
    LogError
        If the path, the log or the truth is invalid; nothing is written then.
    """
    path = Path(path)
    out = truth_path(path)
    if not isinstance(log, Log):
        raise LogError(f"expected a Log, got {type(log).__name__}", file=str(path))
    if not isinstance(truth, dict):
        raise LogError(f"truth must be a dict, got {type(truth).__name__}", file=str(out))
    run_id = uuid.uuid4().hex
    log_data = _log_bytes(Log(log.columns, {**log.meta, "run_id": run_id}), path)
    truth_data = _truth_bytes({**truth, "run_id": run_id}, out)
    # the truth first: a reader never finds a new log beside an old truth that would look like its own;
    # a Ctrl-C between the two is held until both are written (the pair stays one run)
    with interrupts_deferred():
        atomic_write_bytes(out, truth_data)
        atomic_write_bytes(path, log_data)
    return path, out


def _load_truth(log_path) -> tuple[Path, dict]:
    p = truth_path(log_path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no ground truth beside the log {Path(log_path).name} "
                                "(only simulated logs have one)")
    try:
        truth = parse_json(p.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise LogError(f"not valid JSON: {exc}", file=str(p)) from None
    if not isinstance(truth, dict):
        raise LogError(f"expected a JSON object, got {type(truth).__name__}", file=str(p))
    return p, truth


def _short_id(run_id) -> str:
    return "none" if run_id is None else str(run_id)[:8] + "…"


def _check_same_run(log_path, log_meta: dict, truth_file: Path, truth: dict) -> None:
    """Raise if the log and the truth carry different run ids (a missing id counts as different, unless both
    are missing: files written before run ids)."""
    log_id, truth_id = log_meta.get("run_id"), truth.get("run_id")
    if log_id == truth_id:
        return
    raise LogError(f"belongs to another run than the log {Path(log_path).name} (run id {_short_id(truth_id)} "
                   f"in the truth vs {_short_id(log_id)} in the log): the log was replaced or the run was "
                   "interrupted", file=str(truth_file))


def _read_meta(path: Path) -> dict:
    """The meta record of a log file without reading its samples (Parquet footer, CSV comment lines)."""
    source = str(path)
    if _format(path) == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            raw = (pq.read_schema(path).metadata or {}).get(PARQUET_META_KEY)
        except (pa.ArrowException, OSError) as exc:
            raise LogError(f"not a readable Parquet file: {exc}", file=source) from None
    else:
        raw = None
        with open(path, "rb") as fh:
            for n, line in enumerate(fh, start=1):
                text = line.decode("utf-8-sig" if n == 1 else "utf-8", "replace").strip()
                if not text.startswith("#"):
                    break
                m = _META_LINE.fullmatch(text)
                if m:
                    raw = (m.group(1) or "").encode("utf-8")
                    break
    if raw is None:
        raise LogError("not a tendyn log: no meta record", file=source, column="meta")
    try:
        meta = parse_json(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise LogError(f"the meta is not valid JSON: {exc}", file=source, column="meta") from None
    if not isinstance(meta, dict):
        raise LogError(f"meta must be a dict, got {type(meta).__name__}", file=source, column="meta")
    return meta


def read_meta(path) -> dict:
    """The checked meta record of a log file, without reading its samples (a log too large for memory: the
    device it names can be refused before any work). Raises :class:`LogError` naming the file."""
    path = Path(path)
    meta = _read_meta(path)
    _check_meta(meta, str(path))
    return meta


def read_truth(log_path) -> dict:
    """Read the ground truth beside a simulated log, checking that both belong to the same run.

    If the log exists, its run id (read from its meta only, not its samples) must equal the truth's
    ``"run_id"``; both missing (files written before run ids, or with :func:`write_log` and
    :func:`write_truth` alone) is accepted, one missing is not. If the log does not exist, the truth is
    returned unchecked. The returned dict keeps the ``"run_id"`` key.

    Raises
    ------
    FileNotFoundError
        If there is no truth file (a measured log has none).
    LogError
        If it is not a JSON object, if the log's meta record cannot be read, or if the log and the truth have
        different run ids (the message names both).
    """
    log_path = Path(log_path)
    p, truth = _load_truth(log_path)
    if log_path.is_file():
        _check_same_run(log_path, _read_meta(log_path), p, truth)
    return truth


def read_run(path) -> tuple[Log, dict]:
    """Read a simulated log and its ground truth, checking that both belong to the same run.

    Returns
    -------
    tuple
        ``(Log, truth dict)``; see :func:`read_log` and :func:`read_truth`.

    Raises
    ------
    FileNotFoundError
        If the log or its truth file is missing.
    LogError
        If either file is invalid, or their run ids differ (the message names both files).
    """
    log = read_log(path)
    p, truth = _load_truth(path)
    _check_same_run(path, log.meta, p, truth)
    return log, truth
