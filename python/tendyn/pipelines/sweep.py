"""Design sweeps of the nonlinear McGill twin on Dask (issue 11, item 8).

A grid of designs (bench fields, each ``NAME=LO:HI:N``, log-spaced when LO and HI are > 0 and span more than
a decade, else linear) × a set of stepped sines at several input amplitudes. Each design point is one task
(:func:`evaluate_design`, a pure function of plain values) run on a local Dask cluster (default) or on a given
scheduler. Metrics per design:

* ``peak_shift_hz``: max − min over the amplitudes of the open-loop resonance peak [Hz] (C22);
* ``open_loop_spread_db``: spread of |F_m/F_τ| across the amplitudes below 30 Hz [dB];
* ``robust_performance``: ‖ |W1 S| + |W2 T| ‖∞ of C = L/P with P the design's analytic plant (C25).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from tendyn.device import compile_device
from tendyn.results import Result, format_table

__all__ = ["METRICS", "SweepResult", "design_grid", "evaluate_design", "parse_param", "run_sweep", "write_table"]

METRICS = ("peak_shift_hz", "open_loop_spread_db", "robust_performance")


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
    if n == 1:
        return name.strip(), np.array([lo])
    grid = np.geomspace(lo, hi, n) if lo > 0 and hi / lo > 10 else np.linspace(lo, hi, n)
    return name.strip(), grid


def design_grid(params: dict) -> list[dict]:
    """The Cartesian product of the grids, as a list of {name: value}."""
    names = list(params)
    return [dict(zip(names, map(float, vals))) for vals in itertools.product(*(params[k] for k in names))]


def evaluate_design(bench_fields: dict, design: dict, amplitudes: Sequence[float], freqs_hz: Sequence[float],
                    cycles: int = 4) -> dict:
    """One design point: stepped sines at each amplitude (open loop, H1), the metrics. Plain in, plain out."""
    from tendyn.analysis.s1_plant import PlantParams, TendonDrivePlant
    from tendyn.control.loop_shaping import loop_shaping_controller, robust_performance, target_loop
    from tendyn.device.tendon_bench import TendonBench
    from tendyn.sim.tendon_bench import loop_stepped_sine

    bench = TendonBench(**{**bench_fields, **design})
    omega = 2 * math.pi * np.asarray(freqs_hz, float)
    peaks, mags = [], []
    for a in amplitudes:
        fr = loop_stepped_sine(bench, None, omega=omega, amplitude_N=float(a), cycles=cycles, settle_cycles=6, settle_s=0.3)
        peaks.append(fr.peak_hz())
        mags.append(20 * np.log10(np.maximum(fr.magnitude, 1e-12)))
    mags = np.array(mags)
    sel = np.asarray(freqs_hz) <= 30.0
    spread = float(np.max(mags[:, sel].max(axis=0) - mags[:, sel].min(axis=0))) if sel.any() else float("nan")
    P = TendonDrivePlant(PlantParams.from_bench(bench)).tf()
    rp = robust_performance(loop_shaping_controller(P, target_loop()) * P, omega=2 * math.pi * np.logspace(-1, 3, 2000)).value
    return {**design, "peak_shift_hz": float(max(peaks) - min(peaks)), "open_loop_spread_db": spread,
            "robust_performance": float(rp), **{f"peak_hz_{a:g}N": float(p) for a, p in zip(amplitudes, peaks)}}


@dataclass(eq=False)
class SweepResult(Result):
    """Rows (one per design) and the metric drawn over the grid (a line for one parameter, a map for two)."""

    device: str
    params: dict
    rows: list
    metric: str
    scheduler: str = "local"

    def column(self, name: str) -> np.ndarray:
        return np.array([r[name] for r in self.rows], float)

    def _draw(self, ax) -> None:
        names = list(self.params)
        z = self.column(self.metric)
        if len(names) == 1:
            x = self.column(names[0])
            order = np.argsort(x)
            ax.plot(x[order], z[order], "o-")
            ax.set_xlabel(names[0])
            if x.min() > 0 and x.max() / x.min() > 10:
                ax.set_xscale("log")
        else:
            a, b = names[:2]
            sc = ax.scatter(self.column(a), self.column(b), c=z, s=60, cmap="viridis")
            ax.figure.colorbar(sc, ax=ax, label=self.metric)
            ax.set_xlabel(a)
            ax.set_ylabel(b)
        ax.set_title(f"{self.device}: {self.metric}")
        ax.grid(alpha=0.3)

    def to_dict(self) -> dict:
        return {"device": self.device, "params": {k: list(map(float, v)) for k, v in self.params.items()},
                "metric": self.metric, "scheduler": self.scheduler, "rows": self.rows}

    def table(self) -> str:
        cols = list(self.params) + [self.metric]
        return format_table(cols, [[r[c] for c in cols] for r in self.rows], f"{self.device}: design sweep")


def run_sweep(device: Any, params: dict, *, amplitudes=(0.31, 0.38, 0.6, 2.0), freqs_hz=None, metric="peak_shift_hz",
              scheduler: str | None = None, n_workers: int = 2, progress: bool = True, client=None) -> SweepResult:
    """Evaluate every design of ``params`` ({name: grid}) on Dask; ``scheduler`` an address or None (a local
    cluster of ``n_workers`` single-threaded processes, closed afterwards); ``client`` an existing Client."""
    from dask.distributed import Client, LocalCluster, as_completed
    from tqdm import tqdm

    if metric not in METRICS:
        raise ValueError(f"metric must be one of {', '.join(METRICS)} (got {metric!r})")
    bench = compile_device(device).device
    fields = {k: v for k, v in bench.to_dict().items() if k not in ("name", "description", "source")}
    for k in params:
        if k not in fields:
            raise KeyError(k)
    freqs_hz = list(np.arange(8.0, 42.0, 2.0)) if freqs_hz is None else list(freqs_hz)
    grid = design_grid(params)
    own = client is None
    cluster = None
    if own:
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
    try:
        futures = client.map(evaluate_design, [fields] * len(grid), grid, [list(amplitudes)] * len(grid),
                             [freqs_hz] * len(grid), pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        rows: list = [None] * len(grid)
        with tqdm(total=len(grid), desc=f"{bench.name}: sweep", unit="design", disable=not progress or None,
                  file=__import__("sys").stderr) as bar:
            for fut in as_completed(futures):
                rows[index[fut.key]] = fut.result()
                bar.update(1)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    return SweepResult(bench.name, params, rows, metric, scheduler or f"local ({n_workers} workers)")


def write_table(result: SweepResult, path) -> None:
    """Write the rows as one Parquet table (temporary file, then rename: nothing half-written)."""
    import os
    import tempfile
    from pathlib import Path

    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    table = pa.Table.from_pylist(result.rows)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".parquet.tmp")
    os.close(fd)
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
