"""Files in and out: atomic writes (nothing half-written), JSON of numpy results, experiment logs."""

from tendyn.io.files import atomic_write_bytes, atomic_write_text, save_png, to_jsonable
from tendyn.io.logs import (
    COLUMNS,
    Log,
    LogError,
    make_log,
    read_log,
    read_truth,
    truth_path,
    write_log,
    write_truth,
)

__all__ = [
    "COLUMNS",
    "Log",
    "LogError",
    "atomic_write_bytes",
    "atomic_write_text",
    "save_png",
    "make_log",
    "read_log",
    "read_truth",
    "to_jsonable",
    "truth_path",
    "write_log",
    "write_truth",
]
