"""Benchmarks of issue 11: vectorised sensitivities vs a python-control loop, Dask sweep speed-up."""

from __future__ import annotations

import math
import sys
import time

import numpy as np


def bench_sensitivity_sweep(results: list, n_freq: int = 1000, n_design: int = 1000, baseline_designs: int = 50) -> None:
    """7 parameters × n_freq frequencies × n_design designs (k1 and k_z varied): tendyn's broadcast numeric route
    vs a python-control loop (build G per design, evaluate, central finite-difference sensitivity per parameter),
    the loop timed on ``baseline_designs`` designs and scaled. Prints the max relative difference."""
    import control

    from tendyn.analysis.s1_plant import PARAMETERS, PlantParams, TendonDrivePlant, sensitivity, sensitivity_symbolic

    p = PlantParams()
    rng = np.random.default_rng(5)
    k1 = 10 ** rng.uniform(3, 7, n_design)
    kz = 10 ** rng.uniform(-2, 9, n_design)
    omega = 2 * math.pi * np.logspace(-1, 3, n_freq)
    sensitivity(p, omega=omega[:4], k1=k1[:4], k_z=kz[:4])
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        out = sensitivity(p, omega=omega, k1=k1, k_z=kz)
        best = min(best, time.perf_counter() - t0)
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
    rel_fd = max(float(np.max(np.abs(out[n][d] - fd[(d, n)])) / np.max(np.abs(out[n][d]))) for (d, n) in fd)
    print(f"[bench] sensitivity_sweep: {best:.4f} s; max rel. diff vs sympy closed forms {rel_sym:.2e}, "
          f"vs python-control finite differences {rel_fd:.2e} (normwise per design)", file=sys.stderr)
    results.append(dict(name="sensitivity_sweep", value=best, unit="s",
                        baseline=f"python-control loop + finite differences (timed on {baseline_designs} designs, scaled)",
                        baseline_value=base_t, ratio=base_t / best, max_rel_diff_symbolic=rel_sym,
                        max_rel_diff_finite_difference=rel_fd))


def bench_dask_sweep(results: list, n_designs: int = 16, repeats: int = 3) -> None:
    """A sweep of n_designs designs (friction_c0 × k1 grid, the sweep's default amplitudes and frequencies) on
    2 local Dask workers (:func:`tendyn.pipelines.sweep.local_cluster`) vs the same design points in one
    process. The cluster is started and its workers warmed (imports, cached derivations) before the clock
    starts, as the serial process is warm; serial and Dask runs are interleaved ``repeats`` times and the
    medians compared. The machine is shared: Linux autogroups give each session one share of the CPU
    whatever its process count, so while other sessions are busy two workers cannot get two cores; the
    load average at the start is recorded with the result."""
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
    t_serial, t_dask = [], []
    with local_cluster(2) as cluster, Client(cluster) as client:
        client.run(evaluate_design, fields, grid[0], amps, freqs[:2])
        for _ in range(repeats):
            t0 = time.perf_counter()
            serial = [evaluate_design(fields, d, amps, freqs) for d in grid]
            t_serial.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            res = run_sweep(dev, params, amplitudes=amps, freqs_hz=freqs, client=client, progress=False)
            t_dask.append(time.perf_counter() - t0)
    assert all(abs(a["peak_shift_hz"] - b["peak_shift_hz"]) < 1e-9 for a, b in zip(serial, res.rows))
    ts, td = statistics.median(t_serial), statistics.median(t_dask)
    print(f"[bench] dask_sweep_speedup: {len(grid)} designs, serial {', '.join(f'{t:.2f}' for t in t_serial)} s, "
          f"2 workers {', '.join(f'{t:.2f}' for t in t_dask)} s, median ratio {ts / td:.2f} (load {load:.1f})",
          file=sys.stderr)
    results.append(dict(name="dask_sweep_speedup", value=td, unit="s",
                        baseline=f"one process, {len(grid)} designs (median of {repeats}, interleaved)",
                        baseline_value=ts, ratio=ts / td, ratios=[a / b for a, b in zip(t_serial, t_dask)],
                        load_average_1min=load, cpu_count=os.cpu_count()))
