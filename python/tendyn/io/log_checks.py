"""The meta record of a log (its keys and their types) and the checks of a whole log in memory: names,
shapes, finite values, increasing time, the rate against the time column, declared signals and units."""

from __future__ import annotations

import json
import math

import numpy as np

from tendyn.io.files import parse_json
from tendyn.io.log_columns import LINEAR_UNITS, _suggest, column_spec, is_generic
from tendyn.io.log_error import LogError

SCHEMA_VERSION = 1
"""The log schema version this module writes and reads (``meta["schema"]``)."""

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
