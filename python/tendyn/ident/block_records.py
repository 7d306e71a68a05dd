"""The records a block model is fitted on (input and output of one log at its rate), read from logs, and
the NRMS they are scored with."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class Record:
    """One input/output record: ``u`` [input unit], ``y`` [output unit], sampled at ``rate_hz`` [Hz]."""

    u: np.ndarray
    y: np.ndarray
    rate_hz: float
    name: str = ""

    def __post_init__(self):
        self.u = np.ascontiguousarray(self.u, float).ravel()
        self.y = np.ascontiguousarray(self.y, float).ravel()
        if self.u.shape != self.y.shape or self.u.size < 10:
            raise ValueError(f"record {self.name or ''}: u and y must have the same length >= 10 "
                             f"(got {self.u.size}, {self.y.size})")
        if not np.all(np.isfinite(self.u)) or not np.all(np.isfinite(self.y)):
            raise ValueError(f"record {self.name}: values must be finite")


def records_from_logs(logs, input: str, output: str, shift: int = 0) -> tuple[list, dict]:
    """Records of ``input`` → ``output`` (column names or ``meta.signals`` names) from logs or paths, and the
    units ``{"input": …, "output": …}`` (the logs must agree).

    ``shift`` pairs y_k with u_{k+shift} [samples]. The model's G(z) is the zero-order-hold sampling of G(s)
    when u_k is the command held from t_k to t_{k+1} (shift 0: a controller that logs what it sends at t_k);
    a log whose u_k was held over the interval that *ends* at t_k (the twins' logs, ``bench_log``) needs
    shift 1."""
    from tendyn.io import Log, read_log

    if int(shift) != shift:
        raise ValueError(f"shift must be a whole number of samples (got {shift!r})")
    shift = int(shift)
    out, units = [], None
    for k, lg in enumerate(logs if isinstance(logs, (list, tuple)) else [logs]):
        name = str(lg) if not isinstance(lg, Log) else f"log {k + 1}"
        lg = lg if isinstance(lg, Log) else read_log(lg)
        ci, co = lg.resolve(input), lg.resolve(output)
        u_units = {"input": lg.units[ci], "output": lg.units[co]}
        if units is not None and u_units != units:
            raise ValueError(f"{name}: units {u_units} differ from the first log's {units}")
        units = u_units
        u, y, n = lg[ci], lg[co], lg.n_samples
        u, y = (u[shift:], y[:n - shift]) if shift >= 0 else (u[:n + shift], y[-shift:])
        out.append(Record(u, y, float(lg.meta["rate_hz"]), name))
    return out, units


def _as_records(data, rate_hz) -> list:
    if isinstance(data, Record):
        return [data]
    if isinstance(data, tuple) and len(data) == 2 and np.ndim(data[0]) == 1:
        return [Record(data[0], data[1], rate_hz)]
    return [d if isinstance(d, Record) else Record(d[0], d[1], rate_hz) for d in data]


def nrms(y, yhat) -> float:
    """‖y − ŷ‖ / ‖y − ȳ‖ [-]."""
    y = np.asarray(y, float)
    d = np.linalg.norm(y - y.mean())
    return float(np.linalg.norm(y - yhat) / d) if d > 0 else math.inf
