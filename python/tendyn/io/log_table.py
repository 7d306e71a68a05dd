"""The log in memory: :class:`Log` (float64 columns on one time grid and the meta record) and
:func:`make_log`, which converts and validates."""

from __future__ import annotations

import copy
import operator
from dataclasses import dataclass, field

import numpy as np

from tendyn.io.files import parse_json, to_jsonable
from tendyn.io.log_checks import META_KEYS, SCHEMA_VERSION, _json_text, _validate
from tendyn.io.log_columns import _column_index, column_unit
from tendyn.io.log_error import LogError

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
