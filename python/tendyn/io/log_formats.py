"""A log on disk: the two file layouts (``.parquet``, ``.csv``, ``docs/logs.md``), their atomic write and
checked read, the output-path check, and the meta record read without the samples."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from tendyn.io.files import atomic_write_bytes, creatable, parse_json
from tendyn.io.log_checks import _check_meta, _check_names, _json_text, _validate, parse_number
from tendyn.io.log_columns import _unit_matches, column_spec, column_unit, is_generic
from tendyn.io.log_error import LogError
from tendyn.io.log_table import Log

PARQUET_META_KEY = b"tendyn"
"""Key of the meta JSON in the Arrow schema metadata of a Parquet log."""

PARQUET_UNIT_KEY = b"unit"
"""Key of the unit in the Arrow field metadata of each column of a Parquet log."""

CSV_META_PREFIX = "# tendyn-log "
"""A CSV log starts with this prefix followed by the meta JSON on one line."""
FORMATS = (".parquet", ".csv")
"""File suffixes understood by :func:`write_log` / :func:`read_log`."""

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
