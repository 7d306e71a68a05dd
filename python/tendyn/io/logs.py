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

These modules use only the standard library, numpy and (for Parquet, imported lazily) pyarrow; they never
import the compiled core.

The parts, one job each: :mod:`~tendyn.io.log_error` (the error), :mod:`~tendyn.io.log_columns` (the column
registry), :mod:`~tendyn.io.log_checks` (the meta record and the checks of a whole log),
:mod:`~tendyn.io.log_table` (:class:`Log`, :func:`make_log`), :mod:`~tendyn.io.log_formats` (Parquet and CSV
files) and :mod:`~tendyn.io.log_runs` (a log and its truth as one pair). This face re-exports their names.
"""

from __future__ import annotations

from tendyn.io.log_checks import (IMPORT_RATE_SLACK, LOG_RATE_SLACK, META_KEYS, OPTIONAL_META_KEYS,  # noqa: F401
                                  SCHEMA_VERSION, parse_number, rate_contradicts_time, time_column_rate)
from tendyn.io.log_columns import (COLUMNS, GENERIC_UNIT, LINEAR_UNITS, UNIT_ALIASES, ColumnSpec,  # noqa: F401
                                   column_spec, column_unit, is_generic)
from tendyn.io.log_error import LogError
from tendyn.io.log_formats import (CSV_META_PREFIX, FORMATS, PARQUET_META_KEY, PARQUET_UNIT_KEY,  # noqa: F401
                                   check_log_path, read_log, read_meta, write_log)
from tendyn.io.log_runs import TRUTH_SUFFIX, read_run, read_truth, truth_path, write_run, write_truth  # noqa: F401
from tendyn.io.log_table import Log, make_log

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
