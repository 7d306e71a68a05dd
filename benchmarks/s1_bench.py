"""Benchmarks of issue 11: vectorised sensitivities vs a python-control loop, Dask sweep speed-up."""

from __future__ import annotations

import math
import sys
import time

import numpy as np


def bench_sensitivity_sweep(results: list, n_freq: int = 1000, n_design: int = 1000, baseline_designs: int = 50) -> None:
    """7 parameters × n_freq frequencies × n_design designs (k1 and k_z varied): tendyn's broadcast numeric route
    (best of 7 runs; the machine is shared) vs a python-control loop (build G per design, evaluate, central finite-difference sensitivity per parameter),
    the loop timed on ``baseline_designs`` designs and scaled. Prints the max relative difference."""
    import control

    from tendyn.analysis.s1_plant import PARAMETERS, PlantParams, TendonDrivePlant, sensitivity, sensitivity_symbolic

    p = PlantParams()
    rng = np.random.default_rng(5)
    k1 = 10 ** rng.uniform(3, 7, n_design)
    kz = 10 ** rng.uniform(-2, 9, n_design)
    omega = 2 * math.pi * np.logspace(-1, 3, n_freq)
    sensitivity(p, omega=omega[:4], k1=k1[:4], k_z=kz[:4])
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        out = sensitivity(p, omega=omega, k1=k1, k_z=kz)
        times.append(time.perf_counter() - t0)
    best = min(times)
    sym = sensitivity_symbolic(p, omega=omega, k1=k1[:100], k_z=kz[:100])
    rel_sym = max(float(np.max(np.abs(out[n][:100] - sym[n]) / np.abs(sym[n]))) for n in PARAMETERS)

    def loop(designs):
        res = {}
        for d in designs:
            base = p.replace(k1=float(k1[d]), k_z=float(kz[d]))
            g = control.tf(*TendonDrivePlant(base).num_den())(1j * omega)
            for name in PARAMETERS:
                a = getattr(base, name)
                h = 1e-6
                gp = control.tf(*TendonDrivePlant(base.replace(**{name: a * (1 + h)})).num_den())(1j * omega)
                gm = control.tf(*TendonDrivePlant(base.replace(**{name: a * (1 - h)})).num_den())(1j * omega)
                res[(d, name)] = (gp - gm) / (2 * h) / g
        return res

    t0 = time.perf_counter()
    fd = loop(range(baseline_designs))
    base_t = (time.perf_counter() - t0) * n_design / baseline_designs
    rel = {(d, n): float(np.max(np.abs(out[n][d] - fd[(d, n)])) / np.max(np.abs(out[n][d]))) for (d, n) in fd}
    rel_fd = max(rel.values())
    # a central difference with step h resolves S only above its round-off floor ~ eps·cond/h: for a soft load
    # (k_z → 0.01 N/m) S_kz ~ 1e-7 and the k_z step vanishes in the rounding of D's coefficients
    big = [(d, n) for (d, n) in fd if np.max(np.abs(out[n][d])) >= 1e-3]
    rel_fd_big = max(rel[k] for k in big)
    print(f"[bench] sensitivity_sweep: {best:.4f} s best of 7 (median {sorted(times)[3]:.4f} s; "
          f"{base_t / best:.1f}x the python-control loop); max rel. diff "
          f"vs sympy closed forms {rel_sym:.2e}; vs python-control central differences {rel_fd:.2e} (normwise per "
          f"design and parameter), {rel_fd_big:.2e} where max|S| >= 1e-3 ({len(big)} of {len(fd)} pairs)",
          file=sys.stderr)
    results.append(dict(name="sensitivity_sweep", value=best, unit="s",
                        baseline=f"python-control loop + finite differences (timed on {baseline_designs} designs, scaled)",
                        baseline_value=base_t, ratio=base_t / best, median_s=sorted(times)[3], max_rel_diff_symbolic=rel_sym,
                        max_rel_diff_finite_difference=rel_fd, max_rel_diff_finite_difference_resolved=rel_fd_big,
                        resolved_pairs=len(big), pairs=len(fd)))


def _burn(n: int = 3_000_000) -> float:
    """Pure-Python CPU work; returns its wall time [s]."""
    t0 = time.perf_counter()
    x = 0
    for i in range(n):
        x += i
    return time.perf_counter() - t0


def session_parallelism() -> float:
    """Wall-clock speed-up of the same pure-Python work in 2 processes vs 1, measured now (≈ 2 on an idle
    2-core machine; ≈ 1 when other sessions keep the cores busy: Linux autogroups then give this session one
    share whatever its process count). An upper bound for any 2-worker speed-up measured at the same time."""
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(2) as pool:
        pool.map(_burn, [10, 10])
        t1 = _burn()
        t0 = time.perf_counter()
        pool.map(_burn, [3_000_000] * 2)
        t2 = time.perf_counter() - t0
    return 2.0 * t1 / t2


def _cpu_seconds() -> float:
    return time.process_time()


def bench_dask_sweep(results: list, n_designs: int = 16, repeats: int = 3) -> None:
    """A sweep of n_designs designs (friction_c0 × k1 grid, the sweep's default amplitudes and frequencies) on
    2 local Dask workers (:func:`tendyn.pipelines.sweep.local_cluster`) vs the same design points in one
    process. The cluster is started and its workers warmed (imports, cached derivations) before the clock
    starts, as the serial process is warm; serial and Dask runs are interleaved ``repeats`` times and the
    medians compared (``ratio``, wall clock).

    The machine is shared: Linux autogroups give each session one share of the CPU whatever its process
    count, so while other sessions are busy two workers cannot get two cores. Recorded beside the ratio:
    ``session_parallelism`` (:func:`session_parallelism`, the bound on any 2-process speed-up right then) and
    ``cpu_speedup`` = serial CPU time / (CPU time of the busier worker + the client process's: the critical
    path with one core per process; the client hosts the local scheduler and nannies), ``dask_client_cpu_s``."""
    import os
    import statistics

    from tendyn.device import load_device
    from tendyn.devices import bundled
    from tendyn.pipelines.sweep import design_grid, evaluate_design, local_cluster, run_sweep

    dev = load_device(bundled("mcgill_bench"))
    params = {"friction_c0": np.linspace(0.05, 0.2, 4), "k1": np.geomspace(1e4, 1e5, max(1, n_designs // 4))}
    amps = (0.31, 0.38, 0.6, 2.0)
    freqs = list(np.arange(8.0, 42.0, 2.0))
    grid = design_grid(params)
    fields = {k: v for k, v in dev.to_dict().items() if k not in ("name", "description", "source")}
    evaluate_design(fields, grid[0], amps, freqs[:2])   # warm (imports, cached sympy derivation)
    from dask.distributed import Client

    load = os.getloadavg()[0]
    par = session_parallelism()
    t_serial, t_dask, c_serial, c_worker, c_client = [], [], [], [], []
    with local_cluster(2) as cluster, Client(cluster) as client:
        client.run(evaluate_design, fields, grid[0], amps, freqs[:2])
        for _ in range(repeats):
            c0, t0 = _cpu_seconds(), time.perf_counter()
            serial = [evaluate_design(fields, d, amps, freqs) for d in grid]
            t_serial.append(time.perf_counter() - t0)
            c_serial.append(_cpu_seconds() - c0)
            w0 = client.run(_cpu_seconds)
            c0, t0 = _cpu_seconds(), time.perf_counter()
            res = run_sweep(dev, params, amplitudes=amps, freqs_hz=freqs, client=client, progress=False)
            t_dask.append(time.perf_counter() - t0)
            c_client.append(_cpu_seconds() - c0)
            w1 = client.run(_cpu_seconds)
            c_worker.append(max(w1[k] - w0[k] for k in w1))
    assert all(abs(a["peak_shift_hz"] - b["peak_shift_hz"]) < 1e-9 for a, b in zip(serial, res.rows))
    ts, td = statistics.median(t_serial), statistics.median(t_dask)
    # CPU critical path: the busier worker, then the client's share (scheduler, nannies, gathering) that no
    # worker can do
    cpu_speedup = statistics.median(c_serial) / (statistics.median(c_worker) + statistics.median(c_client))
    print(f"[bench] dask_sweep_speedup: {len(grid)} designs, serial {', '.join(f'{t:.2f}' for t in t_serial)} s, "
          f"2 workers {', '.join(f'{t:.2f}' for t in t_dask)} s: median wall speed-up {ts / td:.2f}, CPU speed-up "
          f"{cpu_speedup:.2f} (in-process CPU {statistics.median(c_serial):.2f} s over busiest worker "
          f"{statistics.median(c_worker):.2f} s + client {statistics.median(c_client):.2f} s); session parallelism "
          f"now {par:.2f} (load {load:.1f} on {os.cpu_count()} cores)", file=sys.stderr)
    results.append(dict(name="dask_sweep_speedup", value=td, unit="s",
                        baseline=f"one process, {len(grid)} designs (median of {repeats}, interleaved)",
                        baseline_value=ts, ratio=ts / td, ratios=[a / b for a, b in zip(t_serial, t_dask)],
                        cpu_speedup=cpu_speedup, serial_cpu_s=statistics.median(c_serial),
                        busiest_worker_cpu_s=statistics.median(c_worker),
                        dask_client_cpu_s=statistics.median(c_client), session_parallelism=par,
                        load_average_1min=load, cpu_count=os.cpu_count()))
