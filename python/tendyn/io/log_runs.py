"""A simulated log and its ground truth as one pair: the truth sidecar beside the log (``run.parquet`` →
``run.truth.json``), written truth first with one run id in both, and read back only when the ids agree."""

from __future__ import annotations

import json
import uuid
from pathlib import Path

from tendyn.io.files import atomic_write_bytes, interrupts_deferred, parse_json, to_jsonable
from tendyn.io.log_error import LogError
from tendyn.io.log_formats import _log_bytes, _read_meta, read_log
from tendyn.io.log_table import Log

TRUTH_SUFFIX = ".truth.json"
"""Suffix of the ground-truth sidecar: ``run.parquet`` → ``run.truth.json``."""

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
