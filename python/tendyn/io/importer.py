"""Turn a lab's files into a log: an import map says which column, variable or topic field is which signal.

RAW files are CSV (below), MATLAB ``.mat`` v4–v7.3 and HDF5 ``.h5``/``.hdf5`` (``column`` names the variable, the
struct field ``data.q`` or the dataset path ``/run1/q``; ``index`` the 1-based column of a 2-D one;
:mod:`tendyn.io.arrays`), and ROS bags (``topic``, ``field``, ``joint`` and ``log.time_source``;
:mod:`tendyn.io.bags`).

An import map is a small TOML file (``import.toml`` of ``tendyn data path tx40`` is the one for the Stäubli TX40 files)::

    schema = 1
    [log]
    device = "tx40"              # meta.device
    experiment = "exciting"      # meta.experiment
    rate_hz = 5000.0             # the sampling rate; required when no signal is "time"
    delimiter = ","              # optional, default ","
    header = true                # optional: the first row holds the column names (default true)

    [[signals]]
    file = "pos_read_data.csv"   # which RAW file (its name); optional when only one file is imported
    column = "Joint_1"           # a header name, or a 1-based column number when header = false
    signal = "q_motor_1"         # a log column name (docs/logs.md)
    scale = 1.0                  # optional: value = scale * raw + offset, in the log column's SI unit
    offset = 0.0                 # optional

    [[signals]]                  # a generic signal: any unit, kept in the log's meta.signals
    column = "U_motor"
    signal = "input_1"           # input_<k> or output_<k>
    name = "voltage"             # required for a generic signal: the name commands use (--input voltage)
    unit = "V"                   # required for a generic signal: the unit after scale and offset

    [[signals]]                  # a prismatic joint or a linear motor: m, m/s, N instead of rad, rad/s, N·m
    column = "x"
    signal = "q_motor_1"
    unit = "m"                   # optional for a registry signal: its registry unit or LINEAR_UNITS' counterpart

Every problem raises one :class:`~tendyn.io.logs.LogError` naming the map, the entry and the column,
e.g. ``tx40_import.toml: signals[7].column: no column 'Joint_7' in pos_read_data.csv (columns: Joint_1, …)``.
"""

from __future__ import annotations

import csv
import math
import tomllib
from pathlib import Path

import numpy as np

from tendyn.io.logs import (IMPORT_RATE_SLACK, LINEAR_UNITS, Log, LogError, column_spec, is_generic, make_log,
                            parse_number, rate_contradicts_time, time_column_rate)

__all__ = ["import_logs", "read_import_map"]

_LOG_KEYS = {"device": str, "experiment": str, "rate_hz": float, "delimiter": str, "header": bool,
             "time_source": str}
_SIGNAL_KEYS = {"file": str, "column": (str, int), "index": int, "topic": str, "field": str, "joint": str,
                "signal": str, "scale": float, "offset": float, "name": str, "unit": str}
TIME_SOURCES = ("header", "receive")


def _err(mapfile, where, problem):
    e = LogError(f"{where}: {problem}" if where else problem, file=Path(mapfile).name)
    return e


def read_import_map(path) -> dict:
    """Read and check an import map; returns {"log": {...}, "signals": [...]} with defaults filled."""
    p = Path(path)
    if not p.is_file():
        raise LogError("import map not found", file=str(p))
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _err(p, "", f"TOML syntax error: {exc}") from None
    except RecursionError:
        raise _err(p, "", "TOML nested too deeply") from None
    for key in raw:
        if key not in ("schema", "log", "signals"):
            raise _err(p, key, "unknown key (expected schema, [log], [[signals]])")
    if raw.get("schema") != 1:
        raise _err(p, "schema", f"must be 1 (got {raw.get('schema')!r})")
    log = dict(raw.get("log") or {})
    for key, val in log.items():
        if key not in _LOG_KEYS:
            raise _err(p, f"log.{key}", f"unknown key (known: {', '.join(_LOG_KEYS)})")
        want = _LOG_KEYS[key]
        if want is float and isinstance(val, int) and not isinstance(val, bool):
            val = log[key] = float(val)
        if not isinstance(val, want) or (want is not bool and isinstance(val, bool)):
            raise _err(p, f"log.{key}", f"must be a {want.__name__} (got {val!r})")
    for key in ("device", "experiment"):
        if not log.get(key):
            raise _err(p, f"log.{key}", "missing required key")
    if "rate_hz" in log and not (math.isfinite(log["rate_hz"]) and log["rate_hz"] > 0):
        raise _err(p, "log.rate_hz", f"must be finite and > 0 (got {log['rate_hz']!r})")
    log.setdefault("delimiter", ",")
    if len(log["delimiter"]) != 1 or log["delimiter"] in '"\r\n':
        raise _err(p, "log.delimiter", f"must be one character other than a quote or a line break "
                                       f"(got {log['delimiter']!r})")
    log.setdefault("header", True)
    log.setdefault("time_source", "header")
    if log["time_source"] not in TIME_SOURCES:
        raise _err(p, "log.time_source", f"must be one of {', '.join(TIME_SOURCES)} (a bag's header stamps or the "
                                         f"recorder's receive times; got {log['time_source']!r})")
    sigs = raw.get("signals")
    if not isinstance(sigs, list) or not sigs:
        raise _err(p, "signals", "missing: one [[signals]] entry per log column")
    out, seen, names = [], {}, {}
    for i, s in enumerate(sigs, start=1):
        where = f"signals[{i}]"
        if not isinstance(s, dict):
            raise _err(p, where, "must be a table")
        for key in s:
            if key not in _SIGNAL_KEYS:
                raise _err(p, f"{where}.{key}", f"unknown key (known: {', '.join(_SIGNAL_KEYS)})")
        if "signal" not in s:
            raise _err(p, f"{where}.signal", "missing required key")
        if ("column" in s) == ("topic" in s):
            raise _err(p, f"{where}.column", "give either column (a CSV column, a .mat variable, an HDF5 dataset) "
                                             "or topic and field (a ROS bag)" + (", not both" if "topic" in s else ""))
        sig = s["signal"]
        if not isinstance(sig, str) or column_spec(sig) is None:
            raise _err(p, f"{where}.signal", f"{sig!r} is not a log column name (see docs/logs.md)")
        if sig in seen:
            raise _err(p, f"{where}.signal", f"{sig} is mapped twice (also signals[{seen[sig]}])")
        seen[sig] = i
        for key in ("file", "topic", "field", "joint"):
            if key in s and (not isinstance(s[key], str) or not s[key].strip()):
                raise _err(p, f"{where}.{key}", f"must be a non-empty string (got {s[key]!r})")
        col = s.get("column")
        if "topic" in s:
            if "field" not in s:
                raise _err(p, f"{where}.field", f"missing required key: the message field of {s['topic']} "
                                                "(position, velocity or effort with joint; else a path like "
                                                "wrench.force.x or data[2])")
            if "index" in s:
                raise _err(p, f"{where}.index", "only for a column of a .mat/.h5 matrix; a bag field takes [k] "
                                                "in its path (data[2])")
            if sig == "time":
                raise _err(p, f"{where}.signal", "time of a bag comes from log.time_source (header stamps or "
                                                 "receive times), not from a field")
        else:
            for key in ("field", "joint"):
                if key in s:
                    raise _err(p, f"{where}.{key}", "only for a bag topic (give topic)")
            if isinstance(col, bool) or not isinstance(col, (str, int)):
                raise _err(p, f"{where}.column", f"must be a header name or a 1-based column number (got {col!r})")
            if isinstance(col, int) and col < 1:
                raise _err(p, f"{where}.column", f"column numbers start at 1 (got {col})")
        if "index" in s and (isinstance(s["index"], bool) or not isinstance(s["index"], int) or s["index"] < 1):
            raise _err(p, f"{where}.index", f"must be a 1-based column number of a .mat/.h5 matrix, an integer "
                                            f"≥ 1 (got {s['index']!r})")
        entry = {"file": s.get("file"), "column": col, "signal": sig, "scale": 1.0, "offset": 0.0, "where": where,
                 "index": s.get("index"), "topic": s.get("topic"), "field": s.get("field"), "joint": s.get("joint")}
        for key in ("scale", "offset"):
            if key in s:
                v = s[key]
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise _err(p, f"{where}.{key}", f"must be a finite number (got {v!r})")
                entry[key] = float(v)
        if entry["scale"] == 0.0:
            raise _err(p, f"{where}.scale", "must be nonzero")
        if is_generic(sig):
            for key in ("name", "unit"):
                v = s.get(key)
                if not isinstance(v, str) or not v.strip() or any(c in v for c in "[],"):
                    raise _err(p, f"{where}.{key}", f"required for the generic signal {sig}: a non-empty string "
                                                    f"without brackets or commas (got {v!r})")
            if s["name"] in names:
                raise _err(p, f"{where}.name", f"{s['name']!r} also names signals[{names[s['name']]}]")
            names[s["name"]] = i
            entry["meta"] = {"name": s["name"], "unit": s["unit"]}
        else:
            reg = column_spec(sig).unit
            for key in ("name",) if reg in LINEAR_UNITS else ("name", "unit"):
                if key in s:
                    raise _err(p, f"{where}.{key}", f"only for generic signals (input_<k>, output_<k>); {sig} has "
                                                    f"the registry's name and unit [{reg}]")
            allowed = (reg, LINEAR_UNITS[reg]) if reg in LINEAR_UNITS else (reg,)
            if "unit" in s and s["unit"] not in allowed:
                raise _err(p, f"{where}.unit", f"{sig} is in {' or '.join(allowed)} (a linear joint or motor: "
                                               f"m, m/s, N); got {s['unit']!r}")
            if s.get("unit", reg) != reg:
                entry["unit"] = s["unit"]
        out.append(entry)
    if "time" not in seen and "rate_hz" not in log and not any(e["topic"] for e in out):
        raise _err(p, "log.rate_hz", "required: no signal is mapped to `time`, so the rate sets the time grid")
    return {"log": log, "signals": out}


def _read_csv(path: Path, delimiter: str, header: bool):
    """Header names and data rows of a RAW file. Comment rows (`#`) may only come before the first row: one
    among the data would be dropped and, without a time column, shift every later sample by one period."""
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise LogError(f"cannot read: {exc.strerror or exc}", file=str(path)) from None
    except UnicodeDecodeError as exc:
        raise LogError(f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start}): save the "
                       "CSV as UTF-8", file=str(path)) from None
    if "\0" in text:
        raise LogError(f"a NUL byte at line {text[:text.index(chr(0))].count(chr(10)) + 1}: not a text CSV file",
                       file=str(path))
    lines = text.splitlines()
    k = 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("#")):
        k += 1                                  # leading comments and blank lines
    rows = []
    for lineno, row in enumerate(csv.reader(lines[k:], delimiter=delimiter), start=k + 1):
        if not row:
            continue
        if row[0].lstrip().startswith("#"):
            raise LogError(f"line {lineno}: a comment row among the data rows (comments may only come before "
                           "the first row: dropping it would shift the samples after it)", file=str(path))
        rows.append(row)
    names = [c.strip() for c in rows[0]] if header and rows else []
    return names, rows[1:] if header else rows


def file_kind(path: Path) -> str:
    """How a RAW file is read: ``"bag"`` (a ROS 2 bag folder, ``.mcap``, ``.db3``, a ROS 1 ``.bag``), ``"array"``
    (``.mat``, ``.h5``, ``.hdf5``) or ``"csv"`` (anything else)."""
    from tendyn.io.arrays import ARRAY_SUFFIXES
    from tendyn.io.bags import is_bag

    if is_bag(path):
        return "bag"
    return "array" if path.suffix.lower() in ARRAY_SUFFIXES else "csv"


def _entry_file(mp, s, files) -> str:
    fname = s["file"]
    if fname is None:
        if len(files) != 1:
            raise _err(mp, f"{s['where']}.file", f"needed: {len(files)} RAW files are imported ({', '.join(files)})")
        fname = next(iter(files))
    if fname not in files:
        raise _err(mp, f"{s['where']}.file", f"{fname!r} is not among the RAW files ({', '.join(files)})")
    return fname


def _table_column(mp, spec, s, fname, path, kind, cache) -> np.ndarray:
    """One signal of a CSV, .mat or HDF5 file, as the raw values (before scale and offset)."""
    where, col = s["where"], s["column"]
    if kind == "array":
        from tendyn.io.arrays import ArrayFile

        if isinstance(col, int):
            raise _err(mp, f"{where}.column", f"{fname} is a .mat/HDF5 file: name the variable or dataset "
                                              f"(got the column number {col})")
        if fname not in cache:
            try:
                cache[fname] = ArrayFile(path)
            except ValueError as exc:
                raise LogError(str(exc), file=fname) from None
        try:
            return cache[fname].get(col, s["index"])
        except ValueError as exc:
            raise _err(mp, f"{where}.column", str(exc)) from None
    if s["index"] is not None:
        raise _err(mp, f"{where}.index", f"only for a matrix of a .mat/.h5 file; {fname} is read as CSV")
    if fname not in cache:
        cache[fname] = _read_csv(path, spec["log"]["delimiter"], spec["log"]["header"])
    names, rows = cache[fname]
    if isinstance(col, str):
        if not spec["log"]["header"]:
            raise _err(mp, f"{where}.column", f"{col!r} is a name but log.header = false: give a column number")
        if col not in names:
            raise _err(mp, f"{where}.column", f"no column {col!r} in {fname} (columns: {', '.join(names)})")
        k = names.index(col)
    else:
        k = col - 1
        width = len(rows[0]) if rows else 0
        if k >= width:
            raise _err(mp, f"{where}.column", f"column {col} does not exist in {fname} ({width} columns)")
    vals = np.empty(len(rows))
    for r, row in enumerate(rows):
        try:
            vals[r] = parse_number(row[k])
        except (ValueError, IndexError):
            cell = row[k] if k < len(row) else "<missing>"
            raise LogError(f"value {cell!r} is not a number (mapped to {s['signal']} by {mp.name} {where})",
                           file=fname, column=str(col), row=r,
                           line=r + 2 if spec["log"]["header"] else r + 1) from None
    return vals


def import_logs(raw_files, map_path) -> Log:
    """One log from the RAW files and the import map (see the module docstring).

    RAW files are CSV, MATLAB ``.mat`` (v4–v7.3), HDF5 (``.h5``, ``.hdf5``) or ROS bags (a ROS 2 bag folder,
    ``.mcap``, ``.db3``, a ROS 1 ``.bag``; :mod:`tendyn.io.bags`). What the import did to a bag's samples
    (dropped stamps, missing joints, resampling) is said in ``meta.options["import_notes"]``.
    """
    spec = read_import_map(map_path)
    mp = Path(map_path)
    files = {}
    for f in map(Path, raw_files):
        if f.name in files:
            raise _err(mp, "", f"two RAW files are named {f.name} ({files[f.name]} and {f}): the map names files "
                               "by name, so one would replace the other; rename one")
        files[f.name] = f
    if not files:
        raise LogError("no RAW file given", file=mp.name)
    kinds = {name: file_kind(f) for name, f in files.items()}
    targets = {s["signal"]: _entry_file(mp, s, files) for s in spec["signals"]}
    for s in spec["signals"]:
        kind = kinds[targets[s["signal"]]]
        if (kind == "bag") != (s["topic"] is not None):
            raise _err(mp, s["where"], f"{targets[s['signal']]} is " + (
                "a ROS bag: give topic and field, not column" if kind == "bag" else
                f"a {'.mat/HDF5' if kind == 'array' else 'CSV'} file: give column, not topic"))
    notes: list[str] = []
    rate = spec["log"].get("rate_hz")
    if any(s["topic"] for s in spec["signals"]):
        from tendyn.io.bags import read_bag_signals

        columns, rate, notes = read_bag_signals(files, targets, spec, mp.name)
        n_rows = columns["time"].size
    else:
        cache: dict = {}
        columns = {}
        n_rows = None
        try:
            for s in spec["signals"]:
                fname = targets[s["signal"]]
                vals = _table_column(mp, spec, s, fname, files[fname], kinds[fname], cache)
                if n_rows is None:
                    n_rows = vals.size
                elif vals.size != n_rows:
                    raise _err(mp, s["where"], f"{fname} gives {vals.size} samples, the signals before have "
                                               f"{n_rows}: the signals must be sampled on one grid")
                columns[s["signal"]] = s["scale"] * vals + s["offset"]
        finally:
            for c in cache.values():
                if hasattr(c, "close"):
                    c.close()
        if not n_rows:
            raise _err(mp, "", f"no data rows in {', '.join(files)}")
        if "time" not in columns:
            columns["time"] = np.arange(n_rows) / rate
        elif n_rows < 2:
            raise _err(mp, "", "one data row: a log needs at least two samples (time and a rate)")
        else:
            from_time = time_column_rate(columns["time"])
            if rate is None:
                rate = from_time
            elif rate_contradicts_time(rate, columns["time"], IMPORT_RATE_SLACK):
                raise _err(mp, "log.rate_hz", f"{rate:g} Hz, but the signal mapped to time is sampled at "
                                              f"{from_time:g} Hz: remove log.rate_hz or fix the time column's scale")
    options = {"import_map": mp.name, "raw_files": sorted(files)}
    if notes:
        options["import_notes"] = notes
    signals = {s["signal"]: s["meta"] for s in spec["signals"] if "meta" in s}
    units = {s["signal"]: s["unit"] for s in spec["signals"] if "unit" in s}
    return make_log(columns, device=spec["log"]["device"], rate_hz=rate, seed=None,
                    experiment=spec["log"]["experiment"], options=options, signals=signals or None,
                    units=units or None, source=f"{', '.join(sorted(files))} (imported with {mp.name})")
