"""Issue 32: `tendyn design` benchmarks.

* ``design_evaluations_per_s``: statics-and-maps evaluations of L-EXOS designs (4 transmissions × motor radius,
  driven radius, reducer ratio; every quantity of :class:`tendyn.analysis.design_space.DesignSpace` over its pose
  grid) per second, in batches (numpy over the designs); baseline: the same objectives evaluated one design at a
  time (a plain per-design loop of the same numpy code), same run.
* ``dask_design_speedup``: a design run of 4 NSGA-II islands on 2 local Dask workers (the design space scattered
  once to each worker, one task per island) against the same islands one after the other in one process; beside
  the CPU speed-up, the minor page faults of the in-process runs and of the busiest worker (allocator churn: a
  fresh worker with glibc's start thresholds re-faulted its heap every generation, docs/design.md).

The machine is shared: the 1-minute load average is recorded beside each number.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

VARY = {f"t{i}.{f}": rng for i in range(1, 5)
        for f, rng in (("motor_radius", (0.004, 0.02)), ("driven_radius", (0.02, 0.1)), ("reducer_ratio", (1.0, 16.0)))}


def bench_design_evaluations(results: list, n: int = 20_000, baseline_n: int = 300) -> None:
    from tendyn.analysis.design_space import DesignSpace

    space = DesignSpace("lexos", VARY)
    rng = np.random.default_rng(0)
    X = rng.uniform(space.lower, space.upper, (n, len(space.names)))
    space.evaluate(X[:10])                                   # warm
    t0 = time.perf_counter()
    for k in range(0, n, 2000):                              # batches of 2000 (the memory of one batch ~ 100 MB)
        space.evaluate(X[k:k + 2000])
    batch = n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for x in X[:baseline_n]:
        space.evaluate(x[None])
    plain = baseline_n / (time.perf_counter() - t0)
    load = os.getloadavg()[0]
    print(f"[bench] design_evaluations_per_s: batch {batch:.0f}/s, per design {plain:.0f}/s "
          f"({len(space.serial.Q)} poses, load {load:.1f})", file=sys.stderr)
    results.append(dict(name="design_evaluations_per_s", value=batch, unit="1/s",
                        baseline="the same objectives one design at a time (plain numpy loop)", baseline_value=plain,
                        ratio=batch / plain, poses=len(space.serial.Q), designs=n, load_average_1min=load,
                        cpu_count=os.cpu_count()))


def _usage() -> tuple[float, int]:
    """(CPU seconds, minor page faults) of the calling process so far."""
    import resource

    return time.process_time(), resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def bench_dask_design(results: list, islands: int = 4, population: int = 64, generations: int = 80,
                      repeats: int = 3) -> None:
    """Medians of ``repeats`` interleaved pairs (one process, then 2 workers), as the sweep's entry: the host's
    other tenants move a single pair by ±20 % (measured 1.95 then 1.57 in two runs a minute apart, session
    parallelism 1.89 then 1.25)."""
    import statistics

    from dask.distributed import Client

    from tendyn.analysis.design_space import DesignSpace
    from tendyn.pipelines.design import island, run_design
    from tendyn.pipelines.sweep import local_cluster

    from s1_bench import session_parallelism

    space = DesignSpace("lexos", VARY)
    obj = ["apparent_mass", "dry_friction", "peak_force"]
    island(space, obj, [], 0, 8, 2)                          # warm (imports)
    load = os.getloadavg()[0]
    par = session_parallelism()
    t_serial, c_serial, t_dask, c_worker, c_client = [], [], [], [], []
    f_serial, f_worker = [], []                              # minor page faults (allocator churn, issue 32)
    with local_cluster(2) as cluster, Client(cluster) as client:
        client.run(island, space, obj, [], 0, 8, 2)          # warm the workers as this process is warm
        for _ in range(repeats):
            (c0, f0), t0 = _usage(), time.perf_counter()
            here = run_design(space, obj, population=population, generations=generations, islands=islands)
            t_serial.append(time.perf_counter() - t0)
            c1, f1 = _usage()
            c_serial.append(c1 - c0)
            f_serial.append(f1 - f0)
            w0 = client.run(_usage)
            c0, t0 = time.process_time(), time.perf_counter()
            there = run_design(space, obj, population=population, generations=generations, islands=islands,
                               client=client)
            t_dask.append(time.perf_counter() - t0)
            c_client.append(time.process_time() - c0)
            w1 = client.run(_usage)
            busiest = max(w1, key=lambda k: w1[k][0] - w0[k][0])
            c_worker.append(w1[busiest][0] - w0[busiest][0])
            f_worker.append(w1[busiest][1] - w0[busiest][1])
            assert np.array_equal(here.X, there.X)
    serial, dask_s = statistics.median(t_serial), statistics.median(t_dask)
    serial_cpu, busiest, client_cpu = (statistics.median(c) for c in (c_serial, c_worker, c_client))
    cpu_speedup = serial_cpu / (busiest + client_cpu)      # critical path: the busier worker, then the client
    print(f"[bench] dask_design_speedup per pair: in-process CPU {', '.join(f'{c:.2f}' for c in c_serial)} s, busiest "
          f"worker {', '.join(f'{c:.2f}' for c in c_worker)} s, client {', '.join(f'{c:.2f}' for c in c_client)} s",
          file=sys.stderr)
    print(f"[bench] dask_design_speedup: {islands} islands, one process {', '.join(f'{t:.2f}' for t in t_serial)} s, "
          f"2 workers {', '.join(f'{t:.2f}' for t in t_dask)} s: median wall speed-up {serial / dask_s:.2f}, CPU "
          f"speed-up {cpu_speedup:.2f} (in-process CPU {serial_cpu:.2f} s over busiest worker {busiest:.2f} s + "
          f"client {client_cpu:.2f} s); page faults in process {statistics.median(f_serial):.0f}, busiest worker "
          f"{statistics.median(f_worker):.0f}; session parallelism {par:.2f} (load {load:.1f} on {os.cpu_count()} "
          f"cores)",
          file=sys.stderr)
    results.append(dict(name="dask_design_speedup", value=dask_s, unit="s",
                        baseline=f"{islands} NSGA-II islands one after the other in one process (median of "
                                 f"{repeats}, interleaved)",
                        baseline_value=serial, ratio=serial / dask_s, ratios=[a / b for a, b in zip(t_serial, t_dask)],
                        cpu_speedup=cpu_speedup, serial_cpu_s=serial_cpu, busiest_worker_cpu_s=busiest,
                        client_cpu_s=client_cpu, serial_page_faults=statistics.median(f_serial),
                        busiest_worker_page_faults=statistics.median(f_worker), session_parallelism=par,
                        load_average_1min=load, cpu_count=os.cpu_count()))
