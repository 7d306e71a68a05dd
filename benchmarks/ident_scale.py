"""Benchmarks stream_identify_1h and dask_identify_speedup (issue 9, item 8).

stream_identify_1h: a synthetic 6-DOF TX40 log of TENDYN_BENCH_STREAM_SECONDS (default 3600 s) at 5 kHz
(18 M samples), written to Parquet batch by batch, identified by :class:`tendyn.ident.stream.StreamingIDIM`
(normal equations, W never held). Reported: wall time against the log's duration (real-time factor) and the
peak memory growth against the size the full-rate W would have.

dask_identify_speedup: a campaign of 8 logs (issue 9: at least 8) treated in process, one after the other,
against the same on a local Dask cluster of 2 worker processes, in the same run. The in-process baseline runs the
core regressor on every CPU (threads), as a user's single process does by default.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def _write_synthetic(path: Path, model, seconds: float, rate_hz: float = 5000.0, batch: int = 500_000,
                     seed: int = 0) -> int:
    """A smooth 6-DOF trajectory and plausible motor torques (viscous + Coulomb + a position term), written
    in batches so that the generator never holds the log."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from tendyn.io.log_formats import _parquet_bytes
    from tendyn.io.logs import make_log  # noqa: F401  (schema via a one-row log)

    rng = np.random.default_rng(seed)
    amp, freq, ph = rng.uniform(0.2, 0.6, (3, 6)), rng.uniform(0.1, 1.2, (3, 6)), rng.uniform(0, 6.3, (3, 6))
    G = model.G
    n = int(seconds * rate_hz)
    names = ["time"] + [f"q_motor_{i + 1}" for i in range(6)] + [f"torque_motor_{i + 1}" for i in range(6)]
    probe = make_log({k: [0.0] for k in names}, device="tx40", rate_hz=rate_hz, seed=seed, experiment="exciting")
    import io
    schema = pq.read_schema(io.BytesIO(_parquet_bytes(probe)))
    with pq.ParquetWriter(str(path), schema, compression="zstd") as w:
        for s0 in range(0, n, batch):
            t = np.arange(s0, min(n, s0 + batch)) / rate_hz
            arg = 2 * np.pi * freq[:, None, :] * t[None, :, None] + ph[:, None, :]
            q = (amp[:, None, :] * np.sin(arg)).sum(0)
            qd = (amp[:, None, :] * 2 * np.pi * freq[:, None, :] * np.cos(arg)).sum(0)
            tau = 5.0 * qd + 3.0 * np.sign(qd) + 10.0 * np.sin(q) + 0.05 * rng.normal(size=q.shape)
            qm = (q - model.joint_offsets) @ G.T
            y = np.linalg.solve(G.T, tau.T).T
            cols = [t] + [qm[:, i] for i in range(6)] + [y[:, i] for i in range(6)]
            w.write_table(pa.Table.from_arrays([pa.array(c) for c in cols], schema=schema))
    return n


def _write_file(path: str, seconds: float) -> int:
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident.estimate import cached_model

    return _write_synthetic(Path(path), cached_model(load_device(bundled("tx40"))), seconds)


def _rss_gb() -> float:
    """The current resident set size [GB] (/proc/self/statm), not the process's lifetime peak."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e9


class _PeakRSS:
    """Samples the current RSS every 20 ms in a thread: the peak growth during a block."""

    def __enter__(self):
        import threading

        self.start, self.peak, self._stop = _rss_gb(), 0.0, threading.Event()

        def run():
            while not self._stop.wait(0.02):
                self.peak = max(self.peak, _rss_gb())
        self._t = threading.Thread(target=run, daemon=True)
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()
        self.growth = max(self.peak, _rss_gb()) - self.start


def bench_stream(results: list) -> None:
    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident.estimate import cached_model
    from tendyn.ident.stream import StreamingIDIM

    seconds = float(os.environ.get("TENDYN_BENCH_STREAM_SECONDS", "3600"))
    dev = load_device(bundled("tx40"))
    model = cached_model(dev)
    model.base
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "stream.parquet"
        t0 = time.perf_counter()
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:   # the writer's
            n = pool.submit(_write_file, str(path), seconds).result()                             # memory is not ours
        print(f"[bench] stream: wrote {n} samples ({path.stat().st_size / 1e9:.2f} GB) in "
              f"{time.perf_counter() - t0:.1f} s")
        with _PeakRSS() as mem:
            t0 = time.perf_counter()
            est = StreamingIDIM(dev, chunk_rows=200_000).fit(path)
            wall = time.perf_counter() - t0
        grow = max(mem.growth, 1e-3)
    w_gb = n * 6 * len(model.standard_names) * 8 / 1e9
    print(f"[bench] stream_identify: {n} samples in {wall:.1f} s, peak memory growth of the fit {grow:.2f} GB "
          f"(full-rate W would be {w_gb:.1f} GB); residual {est.result_.residual_rel:.3f}")
    label = "1h" if seconds == 3600 else f"{seconds:g}s"
    results.append(dict(name=f"stream_identify_{label}", value=wall, unit="s", baseline="the log's duration "
                        "(real time)", baseline_value=seconds, ratio=seconds / wall))
    results.append(dict(name=f"stream_identify_{label}_memory", value=grow, unit="GB",
                        baseline="full-rate W in memory", baseline_value=w_gb, ratio=w_gb / grow))


def bench_dask(results: list, n_logs: int = 8) -> None:
    from dask.distributed import Client

    from tendyn.ident.cluster import local_cluster

    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.ident import IDIM
    from tendyn.ident.estimate import cached_model

    dev = load_device(bundled("tx40"))
    model = cached_model(dev)
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for k in range(n_logs):
            p = Path(tmp) / f"run{k}.parquet"
            _write_synthetic(p, model, 9.0, seed=k)
            paths.append(p)
        logs = paths                       # both routes read the files (workers read their own)
        from s1_bench import _cpu_seconds, session_parallelism

        IDIM(dev).fit(logs[:1], crossval=False)                 # warm-up
        load = os.getloadavg()[0]
        sp = session_parallelism()
        c0, t0 = _cpu_seconds(), time.perf_counter()
        IDIM(dev).fit(logs, crossval=False)
        seq, seq_cpu = time.perf_counter() - t0, _cpu_seconds() - c0
        # the same process on one core (the regressor's threads set to 1): what one worker alone would take, so
        # the two baselines bracket the cluster's gain (on 2 cores the default process already uses both)
        before, model.threads = model.threads, 1
        try:
            t0 = time.perf_counter()
            IDIM(dev).fit(logs, crossval=False)
            seq1 = time.perf_counter() - t0
        finally:
            model.threads = before
        with local_cluster(2) as cl, Client(cl) as client:
            client.run(lambda: None)
            est = IDIM(dev, scheduler=cl.scheduler_address)
            est.fit(logs[:2], crossval=False)                     # warm the workers (imports, models)
            w0 = client.run(_cpu_seconds)
            c0, t0 = _cpu_seconds(), time.perf_counter()
            est.fit(logs, crossval=False)
            par, client_cpu = time.perf_counter() - t0, _cpu_seconds() - c0
            w1 = client.run(_cpu_seconds)
        busiest = max(w1[k] - w0[k] for k in w1)
        # CPU speed-up with one core per process: the in-process CPU over the critical path (the busier worker's
        # treatment, then the client's stacking and solve, which no worker can do)
        cpu_speedup = seq_cpu / (busiest + client_cpu)
    print(f"[bench] dask_identify_speedup: {n_logs} logs, in process {seq:.2f} s, 2 Dask workers {par:.2f} s: wall "
          f"speed-up {seq / par:.2f} (against one process on one core {seq1:.2f} s: {seq1 / par:.2f}), CPU speed-up "
          f"{cpu_speedup:.2f} (in-process CPU {seq_cpu:.2f} s over busiest "
          f"worker {busiest:.2f} s + client {client_cpu:.2f} s); session parallelism now {sp:.2f} "
          f"(load {load:.1f} on {os.cpu_count()} cores)")
    results.append(dict(name="dask_identify_speedup", value=par, unit="s", baseline=f"{n_logs} logs one after "
                        "the other in process", baseline_value=seq, ratio=seq / par, one_core_s=seq1,
                        ratio_one_core=seq1 / par, cpu_speedup=cpu_speedup,
                        serial_cpu_s=seq_cpu, busiest_worker_cpu_s=busiest, client_cpu_s=client_cpu,
                        session_parallelism=sp, load_average_1min=load, cpu_count=os.cpu_count()))
