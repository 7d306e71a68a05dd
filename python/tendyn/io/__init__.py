"""Files in and out: atomic writes (nothing half-written), all-or-none sets of files, JSON of numpy results,
experiment logs and their truth files (one run id per pair)."""

from tendyn.io.files import all_or_none, atomic_write_bytes, atomic_write_text, save_png, to_jsonable
from tendyn.io.logs import (
    COLUMNS,
    Log,
    LogError,
    check_log_path,
    make_log,
    read_log,
    read_run,
    read_truth,
    truth_path,
    write_log,
    write_run,
    write_truth,
)

__all__ = [
    "COLUMNS",
    "Log",
    "LogError",
    "all_or_none",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_log_path",
    "save_png",
    "make_log",
    "read_log",
    "read_run",
    "read_truth",
    "to_jsonable",
    "truth_path",
    "write_log",
    "write_run",
    "write_truth",
]
