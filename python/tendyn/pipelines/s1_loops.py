"""S1's loops from the logs a bench records (issue 21, item 4): every open- and closed-loop frequency response
and input/output loop that :func:`tendyn.pipelines.s1.run_s1` reports is estimated from simulated bench logs,
not from the twin's arrays in memory.

A run of the twin (:func:`tendyn.sim.tendon_bench.simulate_closed_loop`, 20 kHz steps, the controller inside the
C++ loop) is logged as a bench would record it (:func:`tendyn.sim.tendon_bench.loop_log`): ``force_ref`` the
reference r [N] (closed loop), ``force_cmd`` the command u [N], ``force_tendon`` the sensed F_m [N], every
:data:`LOG_EVERY` steps (1 kHz), the controller in ``meta.options["controller"]``
(:meth:`~tendyn.sim.tendon_bench.Controller.to_dict`) and the settling time in ``meta.options["settle_s"]``.
The estimators read only those columns and options:

* frequency responses: one log per stepped-sine frequency (the plan of
  :func:`tendyn.sim.tendon_bench.loop_stepped_sine`), H1 at the tone after ``settle_s``
  (:func:`tendyn.ident.frf.frf_from_logs`, three-parameter sine fit); F_m/r in closed loop, F_m/F_τ open;
* input/output loops: the sine log's measured cycles (:func:`tendyn.sim.tendon_bench.io_record`), the area by
  :func:`tendyn.pipelines.s1.loop_area`;
* command noise above 40 Hz (C27): the ``force_cmd`` column of a log at the controller's rate
  (:data:`NOISE_LOG_EVERY`, 10 kHz) — at 1 kHz the command's noise up to 5 kHz would fold into 40–400 Hz.

The twin's noise-free F_m (not a bench signal) is reported only as the truth beside the logged numbers.
:class:`LogBook` counts the logs and, given a folder (``tendyn pipeline s1 --logs DIR``), writes each with its
truth sidecar (:func:`tendyn.io.write_run`) under ``DIR/<group>/NNN.parquet`` and an ``index.json``.

The in-memory routes (``loop_stepped_sine``, ``loop_io``: 20 kHz arrays, scipy csd H1, half-step phase
correction) are the oracle of tests/python/test_s1_loops.py.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from tendyn.device import compile_device
from tendyn.results import FrequencyResponse
from tendyn.sim import tendon_bench as tb

__all__ = ["LOG_EVERY", "NOISE_LOG_EVERY", "LogBook", "loop_area", "noise_log", "sine_loop", "stepped_sine_frf"]

LOG_EVERY = 20
"""Steps of the 20 kHz twin per log sample: logs at 1 kHz [-]."""
NOISE_LOG_EVERY = 2
"""Steps per sample of the noise logs: the 10 kHz controller rate (:data:`tendyn.pipelines.s1.CONTROL_HZ`) [-]."""


class LogBook:
    """The logs a pipeline used: a count per group and, when ``folder`` is given, the files
    ``folder/<group>/NNN.parquet`` with their truth ``NNN.truth.json`` (the bench's fields, with the run's
    changes) and ``folder/index.json`` (group → experiment, controller label, files)."""

    def __init__(self, bench, folder=None):
        self.bench = compile_device(bench).device
        self.folder = None if folder is None else Path(folder)
        self.groups: dict = {}

    def add(self, group: str, logs, **changes) -> list:
        """Record ``logs`` (one or a list) under ``group``; returns them as a list."""
        from tendyn.io import write_run

        logs = list(logs) if isinstance(logs, (list, tuple)) else [logs]
        entry = self.groups.setdefault(group, {"experiment": logs[0].meta["experiment"], "files": [],
                                               "controller": (logs[0].meta["options"].get("controller") or {}).get("label"),
                                               "count": 0})
        for lg in logs:
            entry["count"] += 1
            if self.folder is not None:
                path = self.folder / group / f"{entry['count']:03d}.parquet"
                path.parent.mkdir(parents=True, exist_ok=True)
                truth = (self.bench.replace(**changes) if changes else self.bench).to_dict()
                write_run(lg, truth, path)
                entry["files"].append(str(path.relative_to(self.folder)))
        return logs

    @property
    def count(self) -> int:
        return sum(g["count"] for g in self.groups.values())

    def index(self) -> dict:
        """Group → {experiment, controller, count, files} (files: relative paths, empty without a folder)."""
        return {k: dict(v) for k, v in self.groups.items()}

    def close(self) -> None:
        """Write ``index.json`` into the folder (nothing without one)."""
        if self.folder is not None:
            from tendyn.io import atomic_write_text

            self.folder.mkdir(parents=True, exist_ok=True)
            atomic_write_text(self.folder / "index.json", json.dumps({"logs": self.count, "groups": self.index()},
                                                                      indent=1))


def _add(book, group, logs, **changes) -> list:
    if book is not None:
        return book.add(group, logs, **changes)
    return list(logs) if isinstance(logs, (list, tuple)) else [logs]


def stepped_sine_frf(bench, controller, *, omega, amplitude_N: float, T0: float = 1.0, book: LogBook | None = None,
                     group: str = "stepped_sine", seed: int = 0, **plan) -> FrequencyResponse:
    """F_m/r (closed loop) or F_m/F_τ (``controller`` None) at ``omega`` [rad/s] from the stepped-sine logs of the
    twin at ``amplitude_N`` [N] (:func:`tendyn.sim.tendon_bench.loop_stepped_sine_logs`; ``plan``: cycles,
    settle_cycles, settle_s), tone H1 from the logs' columns, divided by ``T0`` (S1's normalisation by T(0)).
    ``meta``: source, coherence_min, logs, log rate [Hz]."""
    from tendyn.ident.frf import frf_from_logs

    logs = _add(book, group, tb.loop_stepped_sine_logs(bench, controller, omega=omega, amplitude_N=amplitude_N,
                                                       log_every=LOG_EVERY, seed=seed, **plan))
    closed = controller is not None
    m = frf_from_logs(logs, "force_ref" if closed else "force_cmd", "force_tendon")
    name = controller.label if closed and controller.label else ("closed loop" if closed else "open loop")
    return FrequencyResponse(m.omega, m.h1 / T0, output="F_m", input="r" if closed else "F_tau", unit="-",
                             method="stepped_sine", amplitude=float(amplitude_N),
                             label=f"{name}, {amplitude_N:.2f} N" + (" / T(0)" if T0 != 1.0 else ""),
                             meta={"source": "logs", "logs": len(logs), "log_rate_hz": logs[0].meta["rate_hz"],
                                   "coherence_min": float(m.coherence.min()), "estimator": "h1 (tone)", "T0": T0,
                                   "controller": None if not closed else controller.label})


def sine_loop(bench, controller, *, freq_hz: float, amplitude_N: float, cycles: int = 2, settle_cycles: int = 1,
              book: LogBook | None = None, group: str = "sine_loop", log_every: int = LOG_EVERY):
    """The input/output record r → F_m of a sine log (S1 Figs. 10b and 13) as a
    :class:`tendyn.sim.tendon_bench.LowSpeedLoop` read back from the log (:func:`tendyn.sim.tendon_bench.io_record`)."""
    log = _add(book, group, tb.loop_sine_log(bench, controller, freq_hz=freq_hz, amplitude_N=amplitude_N,
                                             cycles=cycles, settle_cycles=settle_cycles, log_every=log_every))[0]
    return tb.io_record(log)


def noise_log(bench, controller, reference, *, seed: int, book: LogBook | None = None, group: str = "noise",
              **changes):
    """The closed-loop run of ``reference`` (one value per 20 kHz step) with bench ``changes`` (e.g. sensor
    noise), logged at the controller's rate (:data:`NOISE_LOG_EVERY`). The changes are the twin's: they go to the
    truth sidecar (:class:`LogBook`), not into the log."""
    log = tb.loop_log(bench, controller, reference, experiment="closed_loop_noise", log_every=NOISE_LOG_EVERY,
                      seed=seed, **changes)
    return _add(book, group, log, **changes)[0]


def loop_area(x: np.ndarray, y: np.ndarray) -> float:
    """Normalised area of the input/output loop y(x): |∮ y dx| / (π · half-range(x) · half-range(y)) [-]
    (1 for a circle, sin φ for an ellipse of phase lag φ, 0 for a single-valued curve)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    ax = 0.5 * (x.max() - x.min())
    ay = 0.5 * (y.max() - y.min())
    return float(area / (math.pi * ax * ay)) if ax > 0 and ay > 0 else 0.0
