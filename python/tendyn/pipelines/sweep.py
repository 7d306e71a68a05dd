"""Design sweeps of the nonlinear McGill twin on Dask (issue 11, item 8).

A grid of designs (bench fields, each ``NAME=LO:HI:N``, log-spaced when LO and HI are > 0 and span more than
a decade, else linear) × a set of stepped sines at several input amplitudes. Each design point is evaluated by
:func:`evaluate_design`, a pure function of plain values; the designs go to the workers in a few contiguous
batches per worker (:func:`batches`, :func:`evaluate_designs`: one task and one round trip per batch), run on
a local Dask cluster (default) or on a given scheduler. Metrics per design:

* ``peak_shift_hz``: max − min over the amplitudes of the open-loop resonance peak [Hz] (C22);
* ``open_loop_spread_db``: spread of |F_m/F_τ| across the amplitudes below 30 Hz [dB];
* ``closed_loop_spread_db`` (``loop="closed"``): spread below 30 Hz of F_m/(T(0) r) with S1's loop-shaping
  controller in the twin (:func:`tendyn.pipelines.s1.s1_controller`, Ĝ_L identified on the design's own
  stepped sine at the largest amplitude), C28;
* ``robust_performance``: ‖ |W1 S| + |W2 T| ‖∞ of C = L/P with P the design's analytic plant (C25).

The local cluster (:func:`tendyn.ident.cluster.local_cluster`) runs single-threaded worker processes without the
memory monitor and the statistical profiler: a design point is ~0.15 s of CPU, and with the
defaults these periodic samplers cost the workers (and the client process that hosts the nannies) a third again
as much CPU as the design points themselves (issue 11 report: 16 designs, busiest worker 1.59 s → 1.20 s of CPU
against 2.0–2.3 s for all of them in one process).
"""

from __future__ import annotations

import itertools
import math
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from tendyn.device import compile_device
from tendyn.ident.cluster import local_cluster, placement  # noqa: F401  (local_cluster re-exported)
from tendyn.results import Result, format_table

__all__ = ["LOOPS", "METRICS", "SweepResult", "batches", "design_grid", "evaluate_design", "evaluate_designs",
           "local_cluster", "memory_needed",
           "parse_param", "run_sweep"]

METRICS = ("peak_shift_hz", "open_loop_spread_db", "closed_loop_spread_db", "robust_performance")
LOOPS = ("open", "closed")
METRIC_LABELS = {"peak_shift_hz": "open-loop peak shift [Hz]", "open_loop_spread_db": "open-loop spread < 30 Hz [dB]",
                 "closed_loop_spread_db": "closed-loop spread < 30 Hz [dB] (C = L/P̂)",
                 "robust_performance": "|| |W1 S| + |W2 T| ||_inf [-]"}


SPREAD_BOUND_DB = 120.0
"""A spread of |H| across amplitudes above this [dB] (a ratio of 10⁶) is no response of a moving bench: one of the
responses sits at the 1e-12 floor of :func:`tendyn.pipelines.s1.spread_db` (the output did not move, or the
loop went unstable). Flagged, not dropped."""

MAX_DESIGNS = 10_000
"""Most designs a sweep evaluates (each is several twin runs: 10 000 is hours on a laptop); checked before the
grid is built, so `N = 10**9` is one line, not a MemoryError after minutes."""


def field_label(name: str) -> str:
    """An axis label of a bench field: its name and unit from the device schema (``name [unit]``)."""
    from tendyn.device.tendon_bench import BENCH_FIELDS

    return f"{name} [{BENCH_FIELDS[name][0] if name in BENCH_FIELDS else '-'}]"


WORKER_BYTES = 400e6
"""Memory of one local worker process [bytes]: the interpreter with numpy, scipy, control and tendyn imported
(~250 MB measured) and a design's runs."""
TASK_BYTES = 40e3
"""Memory of one design on the client and scheduler [bytes]: the Dask task and future, its row."""


def memory_needed(n_designs: int, n_amplitudes: int, n_workers: int, local: bool = True) -> float:
    """Peak memory [bytes] of a sweep on this machine: the local workers (none with a remote scheduler) and the
    client's tasks and rows (a row holds two peaks per amplitude)."""
    return (n_workers * WORKER_BYTES if local else 0.0) + n_designs * (TASK_BYTES + 16.0 * 8 * n_amplitudes)


def parse_param(text: str) -> tuple[str, np.ndarray]:
    """``NAME=LO:HI:N`` → (name, grid); raises ValueError with the reason."""
    if "=" not in text:
        raise ValueError(f"expected NAME=LO:HI:N (got {text!r})")
    name, spec = text.split("=", 1)
    parts = spec.split(":")
    if len(parts) != 3:
        raise ValueError(f"expected NAME=LO:HI:N (got {text!r})")
    try:
        lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"LO and HI must be numbers and N an integer (got {spec!r})") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or n < 1 or (n > 1 and hi <= lo):
        raise ValueError(f"need finite LO < HI and N ≥ 1 (got {spec!r})")
    if n > MAX_DESIGNS:
        raise ValueError(f"N = {n}: at most {MAX_DESIGNS} designs per sweep (MAX_DESIGNS)")
    if n == 1:
        return name.strip(), np.array([lo])
    grid = np.geomspace(lo, hi, n) if lo > 0 and hi / lo > 10 else np.linspace(lo, hi, n)
    return name.strip(), grid


def design_grid(params: dict) -> list[dict]:
    """The Cartesian product of the grids, as a list of {name: value}."""
    names = list(params)
    return [dict(zip(names, map(float, vals))) for vals in itertools.product(*(params[k] for k in names))]


def evaluate_design(bench_fields: dict, design: dict, amplitudes: Sequence[float], freqs_hz: Sequence[float],
                    cycles: int = 4, loop: str = "open") -> dict:
    """One design point: stepped sines at each amplitude (open loop, H1), the metrics; with ``loop="closed"``
    also S1's loop-shaping controller identified on the design's largest-amplitude response and run in the
    twin at every amplitude. Plain in, plain out."""
    from tendyn.analysis.s1_plant import PlantParams, TendonDrivePlant
    from tendyn.control.loop_shaping import fit_plant_frf, loop_shaping_controller, robust_performance, target_loop
    from tendyn.device.tendon_bench import TendonBench
    from tendyn.pipelines.s1 import s1_controller, spread_db
    from tendyn.sim.tendon_bench import loop_stepped_sine

    if loop not in LOOPS:
        raise ValueError(f"loop must be one of {', '.join(LOOPS)} (got {loop!r})")
    bench = TendonBench(**{**bench_fields, **design})
    omega = 2 * math.pi * np.asarray(freqs_hz, float)
    cyc = dict(cycles=cycles, settle_cycles=6, settle_s=0.3)
    frs = {float(a): loop_stepped_sine(bench, None, omega=omega, amplitude_N=float(a), **cyc) for a in amplitudes}
    peaks = [fr.peak_hz() for fr in frs.values()]
    has_band = bool(np.any(np.asarray(freqs_hz) <= 30.0))
    row = {**design, "peak_shift_hz": float(max(peaks) - min(peaks)),
           "open_loop_spread_db": spread_db(list(frs.values()), 30.0) if has_band else float("nan")}
    P = TendonDrivePlant(PlantParams.from_bench(bench)).tf()
    row["robust_performance"] = float(robust_performance(loop_shaping_controller(P, target_loop()) * P,
                                                         omega=2 * math.pi * np.logspace(-1, 3, 2000)).value)
    row.update({f"peak_hz_{a:g}N": float(p) for a, p in zip(frs, peaks)})
    if loop == "closed":
        big = frs[max(frs)]
        _, ctrl, _ = s1_controller(fit_plant_frf(big.omega, big.ratio))
        closed = []
        for a in frs:
            fr = loop_stepped_sine(bench, ctrl, omega=omega, amplitude_N=a, **cyc)
            closed.append(fr)
            row[f"closed_peak_hz_{a:g}N"] = float(fr.peak_hz())
        row["closed_loop_spread_db"] = spread_db(closed, 30.0) if has_band else float("nan")
    return row


def evaluate_designs(bench_fields: dict, designs: Sequence[dict], amplitudes: Sequence[float],
                     freqs_hz: Sequence[float], cycles: int = 4, loop: str = "open") -> list[dict]:
    """:func:`evaluate_design` of several designs in one Dask task (a sweep is split into a few batches per
    worker: one task and one round trip per batch, not per design)."""
    return [evaluate_design(bench_fields, d, amplitudes, freqs_hz, cycles, loop) for d in designs]


def batches(n: int, n_workers: int, per_worker: int = 2) -> list[list[int]]:
    """Indices 0…n−1 in contiguous batches, ``per_worker`` per worker (for balance when designs differ in cost),
    at most n; concatenated in order they are 0…n−1."""
    k = max(1, min(n, n_workers * per_worker))
    return [list(map(int, b)) for b in np.array_split(np.arange(n), k) if len(b)]


@dataclass(eq=False)
class SweepResult(Result):
    """Rows (one per design) and the metric drawn over the grid (a line for one parameter, a map for two)."""

    device: str
    params: dict
    rows: list
    metric: str
    scheduler: str = "local"
    freqs_hz: Sequence[float] | None = None     # the stepped-sine grid [Hz] the peaks are picked on

    reading = ("Each point is one design of the grid; the vertical axis (or the colour) is the metric named in "
               "its label, computed from stepped sines on the twin at every input amplitude.")

    def column(self, name: str) -> np.ndarray:
        return np.array([r[name] for r in self.rows], float)

    @property
    def warnings(self) -> list[str]:
        """Peaks on the first or last frequency of the grid (the true peak may lie beyond it) and spreads beyond
        :data:`SPREAD_BOUND_DB`, one sentence per column."""
        out = []
        if self.freqs_hz is not None and len(self.freqs_hz) > 1 and self.rows:
            lo, hi = float(min(self.freqs_hz)), float(max(self.freqs_hz))
            for col in [c for c in self.rows[0] if "peak_hz" in c]:
                v = self.column(col)
                for edge, name in ((lo, "lowest"), (hi, "highest")):
                    n = int(np.sum(np.isclose(v, edge)))
                    if n:
                        out.append(f"{col}: {n} of {v.size} designs peak at {edge:g} Hz, the {name} frequency of "
                                   f"the grid ({lo:g}–{hi:g} Hz): the true peak may lie outside it")
        for col in ("open_loop_spread_db", "closed_loop_spread_db"):
            if self.rows and col in self.rows[0]:
                v = self.column(col)
                big = v[np.isfinite(v) & (v > SPREAD_BOUND_DB)]
                if big.size:
                    out.append(f"{col}: {big.size} of {v.size} designs spread {big.max():.4g} dB > "
                               f"{SPREAD_BOUND_DB:g} dB: one response is at the numerical floor (no motion, or an "
                               "unstable loop), not a measurable spread")
        return out

    def _draw(self, ax) -> None:
        names = list(self.params)
        z = self.column(self.metric)
        if len(names) == 1:
            x = self.column(names[0])
            order = np.argsort(x)
            ax.plot(x[order], z[order], "o-")
            ax.set_xlabel(field_label(names[0]))
            ax.set_ylabel(METRIC_LABELS.get(self.metric, self.metric))
            if x.min() > 0 and x.max() / x.min() > 10:
                ax.set_xscale("log")
        else:
            a, b = names[:2]
            sc = ax.scatter(self.column(a), self.column(b), c=z, s=60, cmap="viridis")
            ax.figure.colorbar(sc, ax=ax, label=METRIC_LABELS.get(self.metric, self.metric))
            ax.set_xlabel(field_label(a))
            ax.set_ylabel(field_label(b))
        ax.set_title(f"{self.device}: {self.metric}")
        ax.grid(alpha=0.3)

    def to_dict(self) -> dict:
        return {"device": self.device, "params": {k: list(map(float, v)) for k, v in self.params.items()},
                "metric": self.metric, "scheduler": self.scheduler, "rows": self.rows,
                "freqs_hz": None if self.freqs_hz is None else [float(f) for f in self.freqs_hz],
                "warnings": self.warnings}

    def table(self) -> str:
        cols = list(self.params) + [self.metric]
        return format_table(cols, [[r[c] for c in cols] for r in self.rows], f"{self.device}: design sweep")


@contextmanager
def dask_client(scheduler: str | None = None, n_workers: int = 2, client=None):
    """A Dask client for a grid: ``client`` itself when given (left open); else a client of the scheduler at
    ``scheduler`` (ConnectionError when unreachable) or of a :func:`local_cluster` of ``n_workers``, both
    closed on exit."""
    from dask.distributed import Client

    if client is not None:
        yield client
        return
    cluster = None
    if scheduler:
        from tendyn.ident.cluster import connect_scheduler
        from tendyn.progress import quiet_dask

        quiet_dask()

        client = connect_scheduler(scheduler)
    else:
        cluster = local_cluster(n_workers)
        client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def gather_in_order(futures, desc: str, unit: str, progress: bool = True) -> list:
    """The results of Dask futures in submission order, gathered as they complete (progress bar on stderr)."""
    import sys

    from dask.distributed import as_completed
    from tqdm import tqdm

    index = {f.key: i for i, f in enumerate(futures)}
    rows: list = [None] * len(futures)
    with tqdm(total=len(futures), desc=desc, unit=unit, disable=not progress or None, file=sys.stderr) as bar:
        for fut in as_completed(futures):
            rows[index[fut.key]] = fut.result()
            bar.update(1)
    return rows


def run_sweep(device: Any, params: dict, *, amplitudes=(0.31, 0.38, 0.6, 2.0), freqs_hz=None, metric="peak_shift_hz",
              loop: str = "open", scheduler: str | None = None, n_workers: int = 2, progress: bool = True,
              client=None) -> SweepResult:
    """Evaluate every design of ``params`` ({name: grid}) on Dask; ``scheduler`` an address or None (a local
    cluster of ``n_workers`` single-threaded processes, :func:`local_cluster`, closed afterwards); ``client``
    an existing Client. ``loop="closed"`` adds S1's loop-shaping controller (needed by
    ``metric="closed_loop_spread_db"``)."""
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {', '.join(METRICS)} (got {metric!r})")
    if loop not in LOOPS:
        raise ValueError(f"loop must be one of {', '.join(LOOPS)} (got {loop!r})")
    if metric == "closed_loop_spread_db" and loop != "closed":
        raise ValueError("metric closed_loop_spread_db needs loop='closed'")
    bench = compile_device(device).device
    fields = {k: v for k, v in bench.to_dict().items() if k not in ("name", "description", "source")}
    for k in params:
        if k not in fields:
            raise KeyError(k)
    freqs_hz = list(np.arange(8.0, 42.0, 2.0)) if freqs_hz is None else list(freqs_hz)
    from tendyn.sim.catalogue import require_memory

    designs = math.prod(len(g) for g in params.values())
    require_memory(memory_needed(designs, len(amplitudes), n_workers, client is None and not scheduler),
                   "fewer designs, amplitudes or --workers", f"a sweep of {designs} designs")
    grid = design_grid(params)
    with dask_client(scheduler, n_workers, client) as client:
        workers = len(client.scheduler_info().get("workers", {})) or n_workers
        parts = batches(len(grid), workers)
        futures = [client.submit(evaluate_designs, fields, [grid[i] for i in b], list(amplitudes), freqs_hz,
                                 loop=loop, pure=False, **kw) for b, kw in zip(parts, placement(client, len(parts)))]
        rows = [r for batch in gather_in_order(futures, f"{bench.name}: sweep", "batch", progress) for r in batch]
    return SweepResult(bench.name, params, rows, metric, scheduler or f"local ({n_workers} workers)",
                       [float(f) for f in freqs_hz])
